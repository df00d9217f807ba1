"""The patient's screen's text and bands, painted: a text's size that fits its place, each
text rendered once into a pixmap (the screen redraws the same few words at 60 frames a
second), and the top band cut in three. Pixel sizes come from ui.views.patient_geometry."""

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


def thirds(rect: Rect) -> tuple[QRectF, QRectF, QRectF]:
    """Left, middle and right of a band, inside a margin; the outer two a little wider
    (the round and the time are longer than the score)."""
    pad = 0.03 * rect.width
    inner = rect.width - 2 * pad
    side, middle, gap = 0.34 * inner, 0.26 * inner, 0.03 * inner
    return (QRectF(rect.left + pad, rect.top, side, rect.height),
            QRectF(rect.left + pad + side + gap, rect.top, middle, rect.height),
            QRectF(rect.left + pad + inner - side, rect.top, side, rect.height))
