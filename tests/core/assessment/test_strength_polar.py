"""The isometric strength task's polar plot data (core.assessment.strength.strength_polar,
closed_outline) from constructed metrics, against values written by hand: the directions'
convention and names from the patient's seat, a direction not measured left as a gap, a
push the wrong way drawn at the centre, the robot's lines by direction."""

import math

import numpy as np
import pytest

from core.assessment.strength import (
    DIRECTION_NAMES,
    SEEN_FROM_SEAT_RAD,
    closed_outline,
    strength_polar,
)

NAN = math.nan
# a trial's metrics as the registry holds them: 180° (the patient's right) never pushed,
# 270° (away) pushed the wrong way (−1.5 N peak), the summary figures beside them
METRICS = {
    "strength_peak_force_n_000": 10.0, "strength_mean_force_n_000": 6.0,
    "strength_peak_force_n_045": 12.0, "strength_mean_force_n_045": 7.0,
    "strength_peak_force_n_090": 20.0, "strength_mean_force_n_090": 11.0,
    "strength_peak_force_n_135": 14.0, "strength_mean_force_n_135": 8.0,
    "strength_peak_force_n_180": NAN, "strength_mean_force_n_180": NAN,
    "strength_peak_force_n_225": 9.0, "strength_mean_force_n_225": 4.0,
    "strength_peak_force_n_270": -1.5, "strength_mean_force_n_270": -2.5,
    # 315° missing from the metrics altogether (a file from before it was pushed)
    "strength_peak_force_n": 10.6, "strength_mean_force_n": 5.6,
    "strength_at_limit_count": 1.0,
}


def test_the_polar_data_are_the_metrics_per_direction():
    polar = strength_polar(METRICS)
    assert polar.directions_deg == (0, 45, 90, 135, 180, 225, 270, 315)
    np.testing.assert_allclose(polar.angles_rad, [0, math.pi / 4, math.pi / 2,
                                                  3 * math.pi / 4, math.pi, 5 * math.pi / 4,
                                                  3 * math.pi / 2, 7 * math.pi / 4])
    np.testing.assert_array_equal(polar.peak_n, [10, 12, 20, 14, NAN, 9, -1.5, NAN])
    np.testing.assert_array_equal(polar.mean_n, [6, 7, 11, 8, NAN, 4, -2.5, NAN])
    assert polar.line_n is None
    assert polar.not_measured == (180, 315)
    assert polar.largest_n() == 20.0
    assert len(polar.drawn()) == 2


def test_directions_are_named_from_the_patients_seat():
    # the robot's frame: the patient sits on +y facing −y, so +x (0 rad) is their left,
    # +y (π/2) toward them, −x (π) their right, −y (3π/2) away, toward the robot
    # (docs/frames.md); half a turn is the view from the seat
    polar = strength_polar(METRICS)
    assert polar.labels() == ("left 0°", "toward-left 45°", "toward 90°",
                              "toward-right 135°", "right 180°", "away-right 225°",
                              "away 270°", "away-left 315°")
    assert polar.labels("\n")[6] == "away\n270°"
    assert DIRECTION_NAMES[0] == "left"
    assert DIRECTION_NAMES[270] == "away"
    assert math.pi == SEEN_FROM_SEAT_RAD


def test_the_outline_closes_leaves_gaps_and_draws_a_wrong_way_push_at_the_centre():
    polar = strength_polar(METRICS)
    theta, radius = closed_outline(polar.angles_rad, polar.peak_n)
    assert len(theta) == len(radius) == 9
    assert theta[-1] == pytest.approx(2 * math.pi)  # back to the first direction
    np.testing.assert_array_equal(radius, [10, 12, 20, 14, NAN, 9, 0, NAN, 10])
    theta, radius = closed_outline(polar.angles_rad, polar.mean_n)
    np.testing.assert_array_equal(radius, [6, 7, 11, 8, NAN, 4, 0, NAN, 6])


def test_the_lines_shown_come_by_direction_and_count_in_the_extent():
    lines = {0: 5.0, 45: 6.0, 90: 25.0, 135: 6.5, 180: 5.5, 225: 6.0, 270: 7.0}
    polar = strength_polar(METRICS, lines)
    np.testing.assert_array_equal(polar.line_n, [5, 6, 25, 6.5, 5.5, 6, 7, NAN])
    assert polar.largest_n() == 25.0
    assert len(polar.drawn()) == 3


def test_a_trial_without_strength_figures_draws_nothing():
    polar = strength_polar({"vgr_reaction_time_s": 0.4})
    assert polar.not_measured == polar.directions_deg
    assert polar.largest_n() == 0.0
