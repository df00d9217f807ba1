"""The isometric strength task's report page draws its polar plot (app.reports.
strength_polar): a polar axes under the figures' table with the peak and mean polygons
equal to the trial's metrics, the line each direction was shown from the trial's
parameters, the directions named from the patient's seat; no polar plot on another task's
page."""

import math

import numpy as np
import pytest

from app.assessments.strength import lines_N
from app.reports.assessment_page import assessment_page, page_figure, patient_page
from core.assessment.protocol import protocol
from core.trial import THESIS_SUBJECT
from tests.core.assessment.test_strength_polar import METRICS

NAN = math.nan


def polar_axes(figure):
    found = [axes for axes in figure.axes if axes.name == "polar"]
    assert len(found) <= 1
    return found[0] if found else None


def test_the_strength_page_draws_peak_and_mean_per_direction_as_polygons():
    page = assessment_page("strength", METRICS, heading="P001")
    figure = page_figure(page)
    axes = polar_axes(figure)
    assert axes is not None
    assert any(a.name != "polar" and a.tables for a in figure.axes)  # the table stays
    peak, mean = axes.get_lines()
    assert peak.get_label() == "peak"
    assert mean.get_label() == "mean"
    theta = np.radians([0, 45, 90, 135, 180, 225, 270, 315, 360])
    for line in (peak, mean):
        np.testing.assert_allclose(line.get_xdata(), theta)
    # the metrics by hand: 180° and 315° not measured (gaps), 270° pushed the wrong way
    # (at the centre), closed back to 0°
    np.testing.assert_array_equal(peak.get_ydata(), [10, 12, 20, 14, NAN, 9, 0, NAN, 10])
    np.testing.assert_array_equal(mean.get_ydata(), [6, 7, 11, 8, NAN, 4, 0, NAN, 6])
    labels = [t.get_text() for t in axes.get_xticklabels()]
    assert labels[0] == "left 0°"
    assert labels[6] == "away 270°"
    assert labels[4] == "right 180°\nnot measured"
    # seen from the patient's seat: 0 rad (their left) on the page's left, away at the top
    assert axes.get_theta_offset() == pytest.approx(math.pi)
    assert axes.get_theta_direction() == 1
    assert axes.get_ylim() == pytest.approx((0.0, 22.0))
    assert [t.get_text() for t in axes.get_legend().get_texts()] == ["peak", "mean"]


def test_another_tasks_page_has_no_polar_plot():
    page = assessment_page("reaching", {"vgr_reaction_time_s": 0.4})
    assert page.polar is None
    assert polar_axes(page_figure(page)) is None
    # a strength trial without a direction measured: the table says so, no empty plot
    empty = assessment_page("strength", {"strength_at_limit_count": 0.0})
    assert empty.polar is None
    assert polar_axes(page_figure(empty)) is None


def test_the_registered_trials_lines_are_drawn_dashed(tmp_path):
    from app.records.datadir import DataDir
    from app.records.registry import Registry
    from tests.app.assessments.registered import register

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Strength", side="right").code
    parameters = protocol("strength").parameters(THESIS_SUBJECT)
    register(registry, code, METRICS, task="strength", parameters=parameters)
    page = patient_page(registry, code, "strength")
    shown = lines_N(parameters.replace(side="right"))
    np.testing.assert_allclose(page.polar.line_n, [shown[d] for d in page.polar.directions_deg])
    axes = polar_axes(page_figure(page))
    peak, _mean, line = axes.get_lines()
    assert line.get_linestyle() == "--"
    np.testing.assert_allclose(line.get_ydata(), [*page.polar.line_n, page.polar.line_n[0]])
    np.testing.assert_array_equal(peak.get_ydata()[:4], [10, 12, 20, 14])
