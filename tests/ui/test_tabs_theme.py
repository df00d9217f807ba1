"""The theme: one font scale for the whole window, the plots included; the within and
outside pens differ in colour and in line style."""

from __future__ import annotations

import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QApplication

from ui import plots, theme


@pytest.fixture
def app(qapp):
    yield qapp
    theme.apply_theme(qapp, 1.0)


def test_font_scale_reaches_text_numbers_and_plot_axes(qtbot, app):
    theme.apply_theme(app, 1.0)
    plot = plots.make_plot("time (s)", "force (N)")
    number = plots.BigNumber("Force range, x", "N")
    qtbot.addWidget(plot)
    qtbot.addWidget(number)
    axis = plot.getPlotItem().getAxis("bottom")
    body = QApplication.font().pointSizeF()
    tick = axis.style["tickFont"].pointSizeF()

    theme.apply_theme(app, 1.5)
    assert QApplication.font().pointSizeF() == pytest.approx(1.5 * body)
    assert axis.style["tickFont"].pointSizeF() == pytest.approx(1.5 * tick)
    number.value.ensurePolished()
    assert number.value.font().pointSizeF() == pytest.approx(theme.point_size("big"))
    assert theme.point_size("big") > 2 * QApplication.font().pointSizeF()
    assert theme.touch_px() == round(1.5 * theme.TOUCH_TARGET_PX)

    with pytest.raises(ValueError, match="font scale"):
        theme.apply_theme(app, 5.0)


def test_within_and_outside_differ_without_colour():
    within, outside = theme.within_pen(), theme.outside_pen()
    assert within.color().name() == theme.BLUE.lower()
    assert outside.color().name() == theme.VERMILLION.lower()
    assert within.style() == Qt.PenStyle.SolidLine
    assert outside.style() == Qt.PenStyle.DashLine
    assert within.isCosmetic()
    assert within.widthF() == 1.0


def _darkest(image, rect) -> int:
    """The darkest grey level (0-255) inside `rect` of a QImage: the text's."""
    from PySide6.QtGui import QColor

    return min(QColor(image.pixel(x, y)).value()
               for x in range(rect.left(), rect.right()) for y in range(rect.top(), rect.bottom()))


def test_what_is_disabled_looks_greyed(qtbot, app):
    """The style sheet's `QWidget { color: … }` painted every disabled menu item, check box
    and label in the enabled text's colour: "Tone at Go and on a hit" without a sound
    player, said greyed by the README, and "Close the patient's screen" with none open
    looked as usable as the rest."""
    from PySide6.QtWidgets import QCheckBox, QMenu

    theme.apply_theme(app, 1.0)
    menu = QMenu()
    qtbot.addWidget(menu)
    usable, greyed = menu.addAction("Mirror left–right"), menu.addAction("Tone at Go")
    greyed.setEnabled(False)
    menu.adjustSize()
    image = menu.grab().toImage()
    assert _darkest(image, menu.actionGeometry(greyed)) > \
        _darkest(image, menu.actionGeometry(usable)) + 60
    for widget in (QCheckBox("Same each trial"),):
        qtbot.addWidget(widget)
        widget.adjustSize()
        on = _darkest(widget.grab().toImage(), widget.rect())
        widget.setEnabled(False)
        off = _darkest(widget.grab().toImage(), widget.rect())
        assert off > on + 60, type(widget).__name__
