"""The words of the event line and of the fault banner, whole in their fixed lines.

Both have a fixed number of lines (ui.window.message_line.MESSAGE_LINES), so that no
message can grow the window and push the emergency stop off the screen. A longer text is
first set in a smaller font (down to SMALLEST of the window's); one longer still (a plan's
refusal naming a block out of reach, with where the shoulder was placed) shows its
beginning and ends with MORE, and a click anywhere on it opens the whole text
(`clicked`). The label's `text()` is always the whole text, and so is its tooltip."""

from __future__ import annotations

from PySide6.QtCore import QEvent, QRect, Qt, Signal
from PySide6.QtGui import QFont, QFontMetrics, QPainter

from ui.fitting_label import FittingLabel

SMALLEST = 0.6
"""The smallest the font gets (of the window's) to show a long text whole."""
MORE = "… (click to read it all)"
"""How a text cut in the fixed lines ends: that there is more, and how to see it."""
WRAP = int(Qt.TextFlag.TextWordWrap)


class WholeText(FittingLabel):
    """A word-wrapped label of fixed height whose text is never cut without saying so: set
    in a smaller font when it needs more lines at its width, and beyond SMALLEST painted as
    its beginning and MORE, a click (`clicked`) then asks for the whole. A fault was cut
    mid-sentence ("…then clear the") with what to do in the part not shown; a plan's
    refusal lost its reason the same way."""

    clicked = Signal()
    REFIT_ON = (QEvent.Type.StyleChange,)  # its own setFont is no change to fit again

    def __init__(self, bold: bool = True) -> None:
        super().__init__()
        self._bold = bold
        self._fitting = False
        self._shown = ""  # what is painted when the text is cut ("" when it is whole)

    def set_bold(self, bold: bool) -> None:
        """Bold or not (a problem is said in bold): its own font, fitted again."""
        self._bold = bold
        self._fit()

    def setText(self, text: str) -> None:
        super().setText(text)
        self._fit()

    def is_cut(self) -> bool:
        """The text does not fit its lines even at SMALLEST: its end is not on screen."""
        return bool(self._shown)

    def shown_text(self) -> str:
        """What is on screen: the whole text, or its beginning and MORE."""
        return self._shown or self.text()

    def mousePressEvent(self, event) -> None:
        if event.button() == Qt.MouseButton.LeftButton and self.is_cut():
            self.clicked.emit()
            event.accept()
            return
        super().mousePressEvent(event)

    def paintEvent(self, event) -> None:
        if not self._shown:
            super().paintEvent(event)
            return
        painter = QPainter(self)
        painter.setPen(self.palette().color(self.foregroundRole()))
        painter.setFont(self.font())
        painter.drawText(self.contentsRect(), int(self.alignment()) | WRAP, self._shown)

    def _fits(self, font: QFont, text: str) -> bool:
        """`text` in `font` fits the label's lines, and no word (a file's path) is wider
        than a line: one would be cut at the right edge."""
        width = max(self.contentsRect().width(), 1)
        needed = QFontMetrics(font).boundingRect(QRect(0, 0, width, 100_000), WRAP, text)
        return needed.height() <= self.contentsRect().height() and needed.width() <= width

    def _fit(self) -> None:
        if self._fitting:
            return
        self._fitting = True
        try:
            base = QFont(self.parentWidget().font() if self.parentWidget() else self.font())
            base.setBold(self._bold)
            fitted = None
            for step in range(round((1.0 - SMALLEST) * 20) + 1):
                font = QFont(base)
                font.setPointSizeF(base.pointSizeF() * (1.0 - step / 20))
                if self._fits(font, self.text()):
                    fitted = font
                    break
            # cut anyway: its beginning as large as the window's words, not in small type
            font = fitted or base
            if font != self.font():
                self.setFont(font)
            self._shown = "" if fitted is not None else self._beginning(font)
            self.setCursor(Qt.CursorShape.PointingHandCursor if self._shown
                           else Qt.CursorShape.ArrowCursor)
            self.update()
        finally:
            self._fitting = False

    def _beginning(self, font: QFont) -> str:
        """The longest beginning of the text that fits with MORE (ui.window.message_text:
        _cut), found by halving."""
        text = self.text()
        low, high = 0, len(text)  # _cut(text, low) fits; _cut(text, high + 1) does not
        while low < high:
            middle = (low + high + 1) // 2
            if self._fits(font, _cut(text, middle)):
                low = middle
            else:
                high = middle - 1
        return _cut(text, low)


def _cut(text: str, characters: int) -> str:
    """The text's first `characters` and MORE, ending at a word when one ends in the last
    fifth (a long path is cut inside, or nothing of it would show)."""
    head = text[:characters]
    space = head.rfind(" ")
    if space > 0.8 * characters:
        head = head[:space]
    return head.rstrip(" ,;:.") + MORE
