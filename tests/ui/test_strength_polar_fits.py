"""The strength polar plot's words inside it at any size the Assessments tab gives it
(ui.tabs.strength_polar): at 1366 px the right-hand direction's "not measured" ran past the
plot's edge and was cut ("not measure"). Each label's box, in the scene's pixels, must lie
within the view box's."""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings, strategies as st
from PySide6.QtWidgets import QApplication

from core.assessment.strength import strength_polar
from tests.core.assessment.test_strength_polar import METRICS
from tests.ui.shown import shown
from ui.tabs.strength_polar import StrengthPolarPlot


def _outside(plot: StrengthPolarPlot) -> list[str]:
    """The labels (their text) whose box leaves the view box, as drawn now."""
    QApplication.processEvents()  # the layout's posted resize, then the repaint
    box = plot.getPlotItem().getViewBox().sceneBoundingRect()
    return [label.toPlainText() for label in plot.labels
            if not box.contains(label.textItem.sceneBoundingRect())]


def test_the_tab_s_size_at_1366_px_keeps_not_measured_whole(qtbot):
    """The size the Assessments tab gives the plot in a 1366 × 768 window (measured in
    the window: 330 × 400 px)."""
    plot = shown(qtbot, StrengthPolarPlot(), 330, 400)
    plot.show_polar(strength_polar(METRICS))
    assert _outside(plot) == []


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(width=st.integers(260, 900), height=st.integers(260, 900))
def test_every_label_is_inside_the_plot_at_any_size(qtbot, width, height):
    plot = shown(qtbot, StrengthPolarPlot(), width, height)
    plot.show_polar(strength_polar(METRICS))
    assert _outside(plot) == [], (width, height)
    plot.resize(height, width)  # resized after it was drawn: fitted again
    assert _outside(plot) == [], (height, width)
