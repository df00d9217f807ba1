"""A label that lays its text out again whenever its room or its look changes: the robot
bar's line that takes the lines it needs (ui.robot_bar.WholeLine), the event line's and the
banner's text that is set smaller or cut with a word saying so (ui.window.message_text)."""

from __future__ import annotations

from PySide6.QtCore import QEvent
from PySide6.QtWidgets import QLabel


class FittingLabel(QLabel):
    """Calls `_fit()` (the subclass's) after a resize and after the changes in REFIT_ON
    (a new font scale restyles the window; a problem's bold restyles the label)."""

    REFIT_ON = (QEvent.Type.FontChange, QEvent.Type.StyleChange)

    def _fit(self) -> None:
        raise NotImplementedError

    def resizeEvent(self, event) -> None:
        super().resizeEvent(event)
        self._fit()

    def changeEvent(self, event) -> None:
        super().changeEvent(event)
        if event.type() in self.REFIT_ON:
            self._fit()
