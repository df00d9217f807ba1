"""Form fields a scrolling hand cannot change by accident.

Qt's spin boxes and combo boxes take the mouse wheel whenever the pointer is over them,
so scrolling a long form changed its values unseen (Repetitions 5 → 1 while scrolling the
Parameters tab). These take the wheel only when they have the keyboard focus (a click or
Tab gives it); otherwise the wheel goes on to the form, which scrolls.
"""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QComboBox, QDoubleSpinBox, QSpinBox


class _FocusedWheel:
    """The wheel changes the value only while the field has the focus."""

    def _setup(self) -> None:
        self.setFocusPolicy(Qt.FocusPolicy.StrongFocus)

    def wheelEvent(self, event) -> None:
        if self.hasFocus():
            super().wheelEvent(event)
        else:
            event.ignore()  # to the form behind it, which scrolls


class SpinBox(_FocusedWheel, QSpinBox):
    def __init__(self, *args) -> None:
        super().__init__(*args)
        self._setup()


class DoubleSpinBox(_FocusedWheel, QDoubleSpinBox):
    def __init__(self, *args) -> None:
        super().__init__(*args)
        self._setup()


class ComboBox(_FocusedWheel, QComboBox):
    def __init__(self, *args) -> None:
        super().__init__(*args)
        self._setup()
