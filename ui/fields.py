"""Form fields a scrolling hand cannot change by accident, and that never take a number
the therapist did not type.

Qt's spin boxes and combo boxes take the mouse wheel whenever the pointer is over them,
so scrolling a long form changed its values unseen (Repetitions 5 → 1 while scrolling the
Parameters tab). These take the wheel only when they have the keyboard focus (a click or
Tab gives it); otherwise the wheel goes on to the form, which scrolls.

Qt's spin boxes also drop a keystroke that would take the number out of range without a
word: "500" typed in a body mass of at most 250 kg became 50 kg. These keep every
keystroke on the screen; a number that does not fit when it is committed (Enter, Tab,
Build, Register) is refused with one line naming the field, what is wrong and the allowed
range (`refused`, which the window's message line shows), and the field goes
back to the value it had before the edit: a value nobody typed is never taken. A number
counts when committed, not per keystroke (the Instructions tab says so).
"""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QValidator
from PySide6.QtWidgets import QComboBox, QDoubleSpinBox, QLabel, QSpinBox


class _FocusedWheel:
    """The wheel changes the value only while the field has the focus."""

    def _setup(self) -> None:
        self.setFocusPolicy(Qt.FocusPolicy.StrongFocus)

    def wheelEvent(self, event) -> None:
        if self.hasFocus():
            super().wheelEvent(event)
        else:
            event.ignore()  # to the form behind it, which scrolls


class _Refusing(_FocusedWheel):
    """A spin box that keeps what is typed and refuses, in words, a number that does not
    fit (a subclass of QSpinBox or QDoubleSpinBox with a `refused` signal)."""

    refusal = ""
    """A refusal not yet acted on: one made as the mouse left the field (perhaps for the
    button that uses its value), until the field next commits a number it takes;
    `take_refusal` hands it over once."""

    def _setup(self) -> None:
        super()._setup()
        self.setKeyboardTracking(False)  # the value before the edit stays until commit
        self._refusing = False
        self._emptied = False
        self._left_by_mouse = False
        self.editingFinished.connect(self._committed)

    def validate(self, text: str, pos: int):
        state, text, pos = super().validate(text, pos)
        if state == QValidator.State.Invalid:  # kept on screen, refused at commit
            state = QValidator.State.Intermediate
        return state, text, pos

    def fixup(self, text: str) -> str:
        """Qt calls this when a text that does not fit is committed; it then puts the value
        from before the edit back."""
        special = self.specialValueText()
        if special and special in (text, self._number_text(text)):
            return text  # Qt takes it as the minimum ("not measured")
        typed = self._number_text(text)
        if not typed and self.specialValueText():
            self._emptied = True  # "not measured", once Qt has put the old value back
            return text
        line = self._refusal_line(typed)
        if line != self.refusal or not self._refusing:  # once per commit
            self.refusal = line
            self._refusing = True
            self.refused.emit(line)
        return text

    def focusOutEvent(self, event) -> None:
        # left by the mouse: perhaps for the very button that uses the value (Register),
        # which must then not go on with the old one unseen
        self._left_by_mouse = event.reason() == Qt.FocusReason.MouseFocusReason
        try:
            super().focusOutEvent(event)
        finally:
            self._left_by_mouse = False

    def _committed(self) -> None:
        # refused on Enter or Tab: said then and there, the field's old value in view;
        # refused as the mouse left: kept for the button pressed (`take_refusal`)
        if not (self._refusing and self._left_by_mouse):
            self.refusal = ""
        self._refusing = False
        self._take_emptied()

    def _take_emptied(self) -> None:
        if self._emptied:
            self._emptied = False
            self.setValue(self.minimum())  # the special value: "not measured", "not given"

    def take_refusal(self) -> str:
        """The refusal not yet acted on (''), once: a form refuses its own button once on
        it, the field's old value then being what the therapist has seen."""
        line, self.refusal = self.refusal, ""
        return line

    def commit_typed(self) -> str:
        """Commit a number still being typed (Build, Register: what is on the screen
        counts); returns the refusal line, '' if it was taken."""
        self._refusing = False
        self.interpretText()  # nothing changes if the text is the value's
        self._refusing = False
        self._take_emptied()
        return self.take_refusal()

    # -- words --------------------------------------------------------------------
    def _number_text(self, text: str) -> str:
        text = text.strip()
        if self.prefix() and text.startswith(self.prefix().strip()):
            text = text[len(self.prefix().strip()):]
        if self.suffix().strip() and text.endswith(self.suffix().strip()):
            text = text[:-len(self.suffix().strip())]
        return text.strip()

    def _decimals(self) -> int:
        return self.decimals() if isinstance(self, QDoubleSpinBox) else 0

    def _words(self, value: float) -> str:
        return f"{round(value, self._decimals()):g}{self.suffix()}"

    def field_name(self) -> str:
        """The field's accessible name, else its form label (QFormLayout's buddy)."""
        if self.accessibleName():
            return self.accessibleName()
        window = self.window()
        for label in window.findChildren(QLabel):
            if label.buddy() is self:
                return label.text().replace("&", "")
        return "This field"

    def _refusal_line(self, typed: str) -> str:
        low = self.minimum() + (self.singleStep() if self.specialValueText() else 0)
        high = self.maximum()
        allowed = (f"type a number from {round(low, self._decimals()):g} to "
                   f"{self._words(high)}")
        value, ok = self.locale().toDouble(typed)
        if not typed:
            wrong = "left empty"
        elif not ok:
            wrong = f"“{typed}” is not a number"
        elif value > high:
            wrong = f"{typed}{self.suffix()} is more than {self._words(high)}, the most it takes"
        elif value < low:
            wrong = f"{typed}{self.suffix()} is less than {self._words(low)}, the least it takes"
        elif self._decimals() == 0:
            wrong = f"{typed} is not a whole number"
        else:
            places = self._decimals()
            wrong = (f"{typed}{self.suffix()} has more than {places} "
                     f"decimal{'s' if places > 1 else ''}")
        return f"{self.field_name()}: {wrong}; {allowed}. It stays {self._words_now()}."

    def _words_now(self) -> str:
        if self.specialValueText() and self.value() == self.minimum():
            return f"“{self.specialValueText()}”"
        return f"at {self._words(self.value())}"


class SpinBox(_Refusing, QSpinBox):
    refused = Signal(str)

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self._setup()


class DoubleSpinBox(_Refusing, QDoubleSpinBox):
    refused = Signal(str)

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self._setup()


class ComboBox(_FocusedWheel, QComboBox):
    def __init__(self, *args) -> None:
        super().__init__(*args)
        self._setup()


REFUSING = (SpinBox, DoubleSpinBox)
"""The fields that refuse in words (their `refused(line)` signal)."""


def commit_all(fields) -> list[str]:
    """Commit what is typed in each field; the refusals, in the fields' order."""
    return [line for field in fields if (line := field.commit_typed())]

