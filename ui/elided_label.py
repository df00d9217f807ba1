"""A one-line label that gives way: when the space it is given is narrower than its text,
it shows the text cut with an ellipsis ("simulator (healthy, a new se…") and its tooltip
shows the whole text. The status bar's robot and trial words are such labels, so that the
warnings beside them (the loop's timing, the shared registry unreachable) are never cut at
1366 px: the warnings say what to do, the robot's words are on screen elsewhere too."""

from __future__ import annotations

from PySide6.QtCore import QEvent, QSize, Qt
from PySide6.QtGui import QPainter
from PySide6.QtWidgets import QLabel, QToolTip

MIN_CHARACTERS = 6
"""Characters' worth of width the label keeps when squeezed (an ellipsis and a few
letters, never nothing)."""


class ElidedLabel(QLabel):
    """A QLabel of plain text, one line, that may be narrower than its text. `text()` is
    always the whole text (the window reads it back); only the painting is cut."""

    def minimumSizeHint(self) -> QSize:
        hint = super().minimumSizeHint()
        narrow = self.fontMetrics().horizontalAdvance("x" * MIN_CHARACTERS)
        return QSize(min(hint.width(), narrow), hint.height())

    def is_elided(self) -> bool:
        return self.fontMetrics().horizontalAdvance(self.text()) > self.contentsRect().width()

    def shown_text(self) -> str:
        """What the label paints: the whole text, or its start and an ellipsis."""
        return self.fontMetrics().elidedText(self.text(), Qt.TextElideMode.ElideRight,
                                             self.contentsRect().width())

    def paintEvent(self, _event) -> None:
        painter = QPainter(self)
        painter.setPen(self.palette().color(self.foregroundRole()))
        painter.drawText(self.contentsRect(), int(self.alignment()), self.shown_text())

    def event(self, event) -> bool:
        """A cut text's tooltip is the whole text (then the label's own tooltip)."""
        if event.type() == QEvent.Type.ToolTip and self.is_elided():
            own = self.toolTip()
            QToolTip.showText(event.globalPos(), self.text() + (f"\n{own}" if own else ""),
                              self)
            return True
        return super().event(event)
