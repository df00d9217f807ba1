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
