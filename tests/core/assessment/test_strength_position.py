"""Isometric strength on constructed force ramps and position sense on constructed
reproductions, against hand computations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from core.assessment import STRENGTH_DIRECTIONS_DEG, strength_key, task_figures
from core.assessment.position_sense import position_figures
from core.assessment.strength import PushWindow, strength_figures, strength_polar
from core.errors import ParameterError

DT = 0.002


def test_force_ramps_in_each_direction():
    # push k: a ramp along its direction from 0 to 5 + k N over 1 s, with a sideways 3 N
    # that must not count, then rest; 2 s per push
    t = np.arange(8 * 1000) * DT
    force = np.zeros((t.size, 2))
    windows = []
    for k, deg in enumerate(STRENGTH_DIRECTIONS_DEG):
        u = np.array([math.cos(math.radians(deg)), math.sin(math.radians(deg))])
        side = np.array([-u[1], u[0]])
        start = 2.0 * k
        ramp = (t >= start) & (t <= start + 1.0)
        force[ramp] = ((5 + k) * (t[ramp] - start))[:, None] * u + 3.0 * side
        windows.append(PushWindow(math.radians(deg), start, start + 1.0))
    figures = strength_figures(t, force, windows)
    assert list(figures) == [spec.key for spec in task_figures("strength")]
    for k, deg in enumerate(STRENGTH_DIRECTIONS_DEG):
        assert figures[strength_key("peak", deg)] == pytest.approx(5 + k, rel=1e-9)
        # the ramp's samples at 0, DT, ..., 1 s: their mean is the ramp's middle
        assert figures[strength_key("mean", deg)] == pytest.approx((5 + k) / 2, rel=1e-6)
    assert figures["strength_peak_force_n"] == pytest.approx(np.mean(np.arange(5, 13)))
    assert figures["strength_mean_force_n"] == pytest.approx(np.mean(np.arange(5, 13)) / 2,
                                                             rel=1e-6)
    assert figures["strength_at_limit_count"] == 0
    polar = strength_polar(figures)
    np.testing.assert_allclose(np.degrees(polar.angles_rad), STRENGTH_DIRECTIONS_DEG)
    np.testing.assert_allclose(polar.peak_n, np.arange(5, 13), rtol=1e-9)
    np.testing.assert_allclose(polar.mean_n, np.arange(5, 13) / 2, rtol=1e-6)


def test_repeated_pushes_missing_directions_a_wrong_way_push_and_the_limit():
    t = np.arange(3000) * DT
    force = np.zeros((t.size, 2))
    force[(t >= 0.0) & (t <= 1.0)] = [4.0, 0.0]
    force[(t > 1.0) & (t <= 2.0)] = [6.0, 0.0]     # a second, stronger try at 0°
    force[(t > 2.0) & (t <= 3.0)] = [0.0, -2.0]    # pushing down when asked to push up
    windows = [PushWindow(0.0, 0.0, 1.0), PushWindow(0.0, 1.002, 2.0, at_limit=True),
               PushWindow(math.pi / 2, 2.002, 3.0)]
    figures = strength_figures(t, force, windows)
    assert figures["strength_peak_force_n_000"] == 6.0  # the best try
    assert figures["strength_mean_force_n_000"] == pytest.approx(5.0)  # the tries' means
    assert figures["strength_peak_force_n_090"] == -2.0
    assert figures["strength_peak_force_n"] == pytest.approx(2.0)  # (6 − 2) / 2 directions
    assert math.isnan(figures["strength_peak_force_n_180"])
    assert figures["strength_at_limit_count"] == 1


def test_push_windows_are_checked():
    with pytest.raises(ParameterError, match="direction_rad"):
        _ = PushWindow(math.radians(30), 0.0, 1.0).direction_deg
    with pytest.raises(ParameterError, match="end_s"):
        PushWindow(0.0, 1.0, 1.0)
    assert PushWindow(-math.pi / 4, 0.0, 1.0).direction_deg == 315
    assert PushWindow(2 * math.pi - 1e-9, 0.0, 1.0).direction_deg == 0


def test_position_errors_by_hand():
    targets = [[0.1, 0.4], [0.1, 0.4], [0.1, 0.4], [-0.1, 0.4], [-0.1, 0.4], [0.0, 0.5]]
    reproduced = [[0.12, 0.4], [0.10, 0.43], [0.11, 0.38],   # target A: mean (0.11, 0.40333)
                  [-0.1, 0.45], [-0.1, 0.41],               # target B: mean (−0.1, 0.43)
                  [0.03, 0.54]]                             # target C: one trial
    figures = position_figures(targets, reproduced)
    assert list(figures) == [spec.key for spec in task_figures("position")]
    distances = [0.02, 0.03, math.hypot(0.01, 0.02), 0.05, 0.01, 0.05]
    assert figures["position_absolute_error_m"] == pytest.approx(np.mean(distances))
    mean_a = np.array([0.11, (0.4 + 0.43 + 0.38) / 3])
    constant = [math.dist(mean_a, [0.1, 0.4]), 0.03, 0.05]
    assert figures["position_constant_error_m"] == pytest.approx(np.mean(constant))
    a = np.array(reproduced[:3])
    squares = float(((a - mean_a) ** 2).sum()) + 2 * 0.02**2  # B: ±0.02 about its mean
    assert figures["position_variable_error_m"] == pytest.approx(math.sqrt(squares / (2 + 1)))


def test_unreproduced_trials_are_left_out_and_one_trial_each_has_no_spread():
    figures = position_figures([[0.0, 0.4], [0.1, 0.4], [0.2, 0.4]],
                               [[0.0, 0.42], [math.nan, math.nan], [0.2, 0.37]])
    assert figures["position_absolute_error_m"] == pytest.approx(0.025)
    assert figures["position_constant_error_m"] == pytest.approx(0.025)
    assert math.isnan(figures["position_variable_error_m"])
    with pytest.raises(ParameterError, match="reproduced_m"):
        position_figures([[0.0, 0.4]], [[0.0, math.nan]])
    with pytest.raises(ParameterError, match="reproduced_m"):
        position_figures([[0.0, 0.4]], [[0.0, 0.4], [0.0, 0.4]])


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-0.02, 0.02), st.floats(-0.02, 0.02)), min_size=2,
                max_size=12),
       st.floats(-math.pi, math.pi), st.tuples(st.floats(-1, 1), st.floats(-1, 1)))
def test_errors_do_not_depend_on_where_the_table_is(errors, turn, shift):
    errors = errors[:len(errors) // 2 * 2]  # as many trials for each of the two targets
    targets = np.array([[0.1, 0.4], [-0.1, 0.45]] * (len(errors) // 2))
    reproduced = targets + np.array(errors)
    rotation = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    plain = position_figures(targets, reproduced)
    moved = position_figures(targets @ rotation.T + shift, reproduced @ rotation.T + shift)
    for key, value in plain.items():
        assert moved[key] == pytest.approx(value, rel=1e-6, abs=1e-9, nan_ok=True), key
    # with as many trials per target, the absolute error is never below the constant
    # error (the triangle inequality)
    assert plain["position_absolute_error_m"] >= plain["position_constant_error_m"] - 1e-12


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(STRENGTH_DIRECTIONS_DEG), st.floats(0.0, 5.0),
                          st.floats(0.1, 2.0)), min_size=1, max_size=10),
       st.integers(0, 2**32 - 1))
def test_a_directions_peak_is_never_below_its_mean(pushes, seed):
    t = np.arange(4000) * DT
    force = np.random.default_rng(seed).normal(0.0, 5.0, (t.size, 2))
    windows = [PushWindow(math.radians(deg), start, start + length)
               for deg, start, length in pushes]
    figures = strength_figures(t, force, windows)
    for deg in STRENGTH_DIRECTIONS_DEG:
        peak, mean = figures[strength_key("peak", deg)], figures[strength_key("mean", deg)]
        assert math.isnan(peak) == math.isnan(mean)
        assert math.isnan(peak) or peak >= mean
        assert math.isnan(peak) == (deg not in {d for d, _, _ in pushes})
