"""The patient's screen's text, measured: a text's size that fits its place, a text
rendered into a pixmap, the top band's three texts placed side by side, words cut into two
lines. Pixel sizes come from ui.views.patient_geometry."""

from __future__ import annotations

from PySide6.QtCore import QRectF, Qt
from PySide6.QtGui import QColor, QFont, QFontMetrics, QPainter, QPixmap

from ui.views.patient_geometry import Rect


def fitted_px(font: QFont, rect: QRectF, text: str) -> int:
    """The font's pixel size, or a smaller one at which the text fits the width."""
    width = QFontMetrics(font).horizontalAdvance(text)
    if width <= rect.width() or width == 0:
        return font.pixelSize()
    return max(8, int(font.pixelSize() * rect.width() / width))


def sized(font: QFont, pixel_size: int) -> QFont:
    sized = QFont(font)
    sized.setPixelSize(pixel_size)
    return sized


def text_pixmap(base: QFont, text: str, pixel_size: int, colour: QColor,
                 ratio: float) -> QPixmap:
    font = QFont(base)
    font.setPixelSize(pixel_size)
    font.setBold(True)
    metrics = QFontMetrics(font)
    width, height = max(1, metrics.horizontalAdvance(text)), max(1, metrics.height())
    pixmap = QPixmap(round(width * ratio), round(height * ratio))
    pixmap.setDevicePixelRatio(ratio)
    pixmap.fill(Qt.GlobalColor.transparent)
    painter = QPainter(pixmap)
    painter.setRenderHint(QPainter.RenderHint.TextAntialiasing)
    painter.setFont(font)
    painter.setPen(colour)
    painter.drawText(QRectF(0, 0, width, height), Qt.AlignmentFlag.AlignCenter, text)
    painter.end()
    return pixmap


def qrect(rect: Rect) -> QRectF:
    return QRectF(rect.left, rect.top, rect.width, rect.height)


def margin(rect: Rect) -> float:
    """The band's margin at either side (px): the texts and the plan's bar keep inside it."""
    return 0.03 * rect.width


def top_band(font: QFont, rect: Rect, texts: tuple[str, str, str]
             ) -> tuple[int, tuple[QRectF, QRectF, QRectF]]:
    """The top band's one pixel size and the places of its three texts (the count, the
    score or the lap, the time left): each as wide as it is at that size, the first at the
    left margin, the last at the right, the middle centred, moved aside only if it would
    come within a gap of either; the size lowered from the font's only as far as the three
    side by side need. The band was cut in fixed thirds, each text fitted to its third:
    "Target 12 of 16" came to 63 % of the screen's letter size (13 mm, not 20, full
    screen on 22 inches) beside an empty middle third."""
    pad = margin(rect)
    inner = rect.width - 2 * pad
    gap = 0.03 * inner
    shown = sum(1 for text in texts if text)
    gaps = gap * max(0, shown - 1)

    def widths(pixel_size: int) -> list[float]:
        metrics = QFontMetrics(sized(font, pixel_size))
        return [float(metrics.horizontalAdvance(text)) if text else 0.0 for text in texts]

    size = font.pixelSize()
    natural = sum(widths(size))
    if natural + gaps > inner and natural > 0:
        size = max(8, int(size * max(inner - gaps, 0.0) / natural))
        while size > 8 and sum(widths(size)) + gaps > inner:  # hinting: not quite linear
            size -= 1
    first, middle, last = widths(size)
    left = QRectF(rect.left + pad, rect.top, first, rect.height)
    right = QRectF(rect.left + pad + inner - last, rect.top, last, rect.height)
    x = rect.left + 0.5 * (rect.width - middle)
    lowest = left.right() + gap if first else rect.left + pad
    highest = right.left() - gap - middle if last else rect.left + pad + inner - middle
    x = max(lowest, min(x, highest))
    return size, (left, QRectF(x, rect.top, middle, rect.height), right)


CUT_AFTER = (":", ",", ".", "!", "?")
"""A line is best cut after a phrase: "Relax your arm:" / "the robot moves your hand"."""


def two_lines(font: QFont, width: float, text: str) -> tuple[str, str]:
    """The text cut at a space into two lines, each as wide as `width` at most at the
    font's size if any cut allows: a cut after a phrase's punctuation first (CUT_AFTER),
    then any space; among those the one whose longer line is the shortest. When no cut
    fits, the most even one (the painter then fits each line)."""
    metrics = QFontMetrics(font)
    words = text.split(" ")
    cuts = []
    for k in range(1, len(words)):
        first, second = " ".join(words[:k]), " ".join(words[k:])
        longer = max(metrics.horizontalAdvance(first), metrics.horizontalAdvance(second))
        cuts.append((not words[k - 1].endswith(CUT_AFTER), longer, first, second))
    if not cuts:
        return text, ""
    fitting = [cut for cut in cuts if cut[1] <= width]
    _, _, first, second = min(fitting) if fitting else min(cuts, key=lambda cut: cut[1])
    return first, second
