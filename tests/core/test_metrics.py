"""The trial figures of section 3.6 and beyond, on signals with known answers."""

import itertools
import math
from dataclasses import fields

import numpy as np
import pytest

from core.errors import ParameterError
from core.metrics import (
    DEFAULT_MIN_FORCE_N,
    TrialMetrics,
    compute_metrics,
    directional_performance,
    pearson,
    rmse_xy,
)
from core.trajectory import Trajectory, d_shape

DT = 0.002


def _circle(radius_m=0.1, period_s=4.0, turns=1.0):
    t = np.arange(0.0, turns * period_s + DT / 2, DT)
    w = 2 * math.pi / period_s
    position = np.column_stack((-0.3 + radius_m * np.cos(w * t), 0.3 + radius_m * np.sin(w * t)))
    return t, position, radius_m * w


# ------------------------------------------------------------------ position
def test_straight_line_with_a_constant_offset():
    t = np.arange(0.0, 2.0, DT)
    desired = np.column_stack((np.full(t.size, -0.3), 0.2 + 0.1 * t))
    offset = np.array([0.003, -0.004])
    m = compute_metrics(t, desired + offset, desired_position_m=desired)
    assert m.rmse_x_m == pytest.approx(abs(offset[0]), rel=1e-12)
    assert m.rmse_y_m == pytest.approx(abs(offset[1]), rel=1e-12)
    assert rmse_xy(desired + offset, desired) == pytest.approx(tuple(np.abs(offset)))
    assert m.path_length_ratio == pytest.approx(1.0, abs=1e-5)


def test_rmse_of_a_sinusoidal_error_is_its_amplitude_over_root_two():
    t = np.arange(0.0, 4.0, DT)
    desired = np.column_stack((0.1 * t, 0.05 * t))
    error = np.column_stack((0.006 * np.sin(2 * math.pi * t), 0.002 * np.cos(2 * math.pi * t)))
    rx, ry = rmse_xy(desired + error, desired)
    assert rx == pytest.approx(0.006 / math.sqrt(2), rel=1e-9)
    assert ry == pytest.approx(0.002 / math.sqrt(2), rel=1e-9)


@pytest.mark.parametrize("cutoff_hz", [None, 10.0])
def test_circle_at_constant_speed(cutoff_hz):
    t, position, speed = _circle()
    m = compute_metrics(t, position, desired_position_m=position, speed_cutoff_hz=cutoff_hz)
    # central differences read v·sin(ωh)/(ωh); the filter adds a little at the ends
    tolerance = 1e-5 if cutoff_hz is None else 1e-3
    assert m.peak_speed_m_s == pytest.approx(speed, rel=tolerance)
    assert m.mean_speed_m_s == pytest.approx(speed, rel=tolerance)
    assert m.path_length_ratio == pytest.approx(1.0, abs=tolerance)
    assert m.path_length_m == pytest.approx(2 * math.pi * 0.1, rel=tolerance)
    assert m.desired_path_length_m == pytest.approx(2 * math.pi * 0.1, rel=1e-5)
    assert (m.movement_onset_s, m.movement_offset_s) == (t[0], t[-1])
    assert m.movement_time_s == pytest.approx(4.0, abs=1e-12)
    assert m.duration_s == pytest.approx(4.0, abs=1e-12)
    if cutoff_hz is None:  # velocity turning at ω: LDLJ = −4 ln(ωT) (see test_smoothness);
        # the one-sided stencils at the two ends differentiate three times
        assert m.ldlj == pytest.approx(-4 * math.log(2 * math.pi), abs=2e-3)


def test_a_twice_as_long_path_has_ratio_two():
    t, position, _ = _circle()
    _, double, _ = _circle(turns=2.0, period_s=2.0)
    m = compute_metrics(t, double, desired_position_m=position, speed_cutoff_hz=None)
    assert m.path_length_ratio == pytest.approx(2.0, rel=1e-4)


def test_movement_time_of_a_rest_reach_rest_recording():
    """Rest 1 s, a minimum-jerk reach of T = 1.2 s, rest: the speed crosses 10 % of
    its peak where 30u²(1−u)² = 0.1·30/16, u = (1 − √(1 − √0.1))/2."""
    t = np.arange(0.0, 3.5, DT)
    duration = 1.2
    u = np.clip((t - 1.0) / duration, 0.0, 1.0)
    s = 0.15 * u**3 * (10 - 15 * u + 6 * u * u)
    position = np.column_stack((-0.3 + s * 0.6, 0.3 - s * 0.8))
    m = compute_metrics(t, position, speed_cutoff_hz=None)
    crossing = (1 - math.sqrt(1 - math.sqrt(0.1))) / 2
    assert m.movement_onset_s == pytest.approx(1.0 + crossing * duration, abs=2e-4)
    assert m.movement_time_s == pytest.approx((1 - 2 * crossing) * duration, abs=4e-4)
    assert m.peak_speed_m_s == pytest.approx(1.875 * 0.15 / duration, rel=1e-4)
    assert m.path_length_m == pytest.approx(0.15, rel=1e-4)


# ------------------------------------------------------------------ force direction
def _force_pattern():
    """t = 0 … 1 s in 0.01 s steps along desired direction +x, with the force at
    10° (within), 30° (outside), −15° (within), too weak (outside), −15° again."""
    t = np.arange(101) * 0.01
    angle = np.where(t < 0.295, math.radians(10), math.radians(-15))
    angle[30:55] = math.radians(30)
    magnitude = np.full(t.size, 1.5)
    magnitude[80:90] = 0.5 * DEFAULT_MIN_FORCE_N
    force = magnitude[:, None] * np.column_stack((np.cos(angle), np.sin(angle)))
    direction = np.tile([1.0, 0.0], (t.size, 1))
    return t, force, direction


def test_directional_performance_and_the_intervals_of_fig_3_9():
    t, force, direction = _force_pattern()
    result = directional_performance(t, force, direction)
    assert result.within_intervals_s == ((t[0], t[30]), (t[55], t[80]), (t[90], t[100]))
    assert result.outside_intervals_s == ((t[30], t[55]), (t[80], t[90]))
    within_time = (t[30] - t[0]) + (t[80] - t[55]) + (t[100] - t[90])
    assert result.percent == pytest.approx(100 * within_time / (t[100] - t[0]), rel=1e-12)
    assert result.percent == pytest.approx(65.0, rel=1e-9)
    assert result.within.sum() == 30 + 25 + 11
    # the intervals tile the trial
    spans = sorted(result.within_intervals_s + result.outside_intervals_s)
    assert spans[0][0] == t[0]
    assert spans[-1][1] == t[-1]
    assert all(a[1] == b[0] for a, b in itertools.pairwise(spans))

    m = compute_metrics(t, np.zeros((t.size, 2)), force_N=force, desired_direction=direction,
                        speed_cutoff_hz=None)
    assert m.directional_performance_pct == pytest.approx(result.percent)
    assert m.within_intervals_s == result.within_intervals_s
    assert m.outside_intervals_s == result.outside_intervals_s


def test_tolerance_and_minimum_force_move_the_boundaries():
    t, force, direction = _force_pattern()
    wide = directional_performance(t, force, direction, tolerance_rad=math.radians(35))
    assert wide.outside_intervals_s == ((t[80], t[90]),)
    no_minimum = directional_performance(t, force, direction, min_force_N=0.0)
    assert no_minimum.outside_intervals_s == ((t[30], t[55]),)
    # |F| exactly at the minimum counts as within; a zero-length desired direction does not
    exact = directional_performance(t[:3], np.tile([DEFAULT_MIN_FORCE_N, 0.0], (3, 1)),
                                    np.tile([2.0, 0.0], (3, 1)))
    assert exact.percent == 100.0
    none = directional_performance(t[:3], np.ones((3, 2)), np.zeros((3, 2)))
    assert none.percent == 0.0
    assert none.within_intervals_s == ()


def test_opposite_force_is_outside_whatever_the_tolerance():
    t = np.arange(50) * DT
    result = directional_performance(t, np.tile([-2.0, 0.0], (50, 1)), np.tile([1.0, 0.0], (50, 1)),
                                     tolerance_rad=math.radians(90))
    assert result.percent == 0.0


def test_force_along_the_desired_direction_of_the_d_is_100_percent():
    trajectory = Trajectory(d_shape((-0.3, 0.3), 0.1), 4.0, 2)
    t = np.arange(0.0, 8.0, DT)
    sample = trajectory.sample(t)
    m = compute_metrics(t, sample.position_m, desired_position_m=sample.position_m,
                        desired_direction=sample.direction, force_N=2.0 * sample.direction)
    assert m.directional_performance_pct == pytest.approx(100.0)
    assert m.outside_intervals_s == ()
    assert m.rmse_x_m == 0.0
    assert m.rmse_y_m == 0.0


# ------------------------------------------------------------------ ranges and angles
def test_ranges_rom_and_correlation_of_thesis_sized_signals():
    t = np.arange(0.0, 2.0 + DT / 2, DT)
    wave = np.sin(math.pi * t)  # one period: +1 at 0.5 s, −1 at 1.5 s
    force = np.column_stack((-0.1 - 0.4175 * (1 + wave), 1.264 * wave))
    shoulder = 0.6 + 0.5 * math.radians(42.17) * wave
    elbow = 1.4 - 0.5 * math.radians(30.65) * np.cos(math.pi * t)
    torque = np.column_stack((2.395 * wave, 0.4085 * np.cos(math.pi * t)))
    m = compute_metrics(t, np.zeros((t.size, 2)), force_N=force,
                        isb_angles_rad=np.column_stack((shoulder, elbow)), torque_Nm=torque)
    assert m.force_range_x_N == pytest.approx(0.835, rel=1e-9)
    assert m.force_range_y_N == pytest.approx(2.528, rel=1e-9)
    assert m.shoulder_rom_rad == pytest.approx(math.radians(42.17), rel=1e-9)
    assert m.elbow_rom_rad == pytest.approx(math.radians(30.65), rel=1e-9)
    assert m.shoulder_torque_range_Nm == pytest.approx(4.79, rel=1e-9)
    assert m.elbow_torque_range_Nm == pytest.approx(0.817, rel=1e-9)
    assert m.shoulder_torque_range_smoothed_Nm == pytest.approx(4.79, rel=1e-3)
    assert m.shoulder_elbow_correlation == pytest.approx(0.0, abs=2e-3)  # sine vs cosine


def test_smoothing_removes_differentiation_noise_from_the_torque_range():
    """Section 3.6.3: numerical differentiation adds high-frequency noise that
    inflates the raw range; the smoothed range is the motion's."""
    t = np.arange(0.0, 2.0 + DT / 2, DT)
    clean = 2.395 * np.sin(math.pi * t)
    noise = 0.4 * (-1.0) ** np.arange(t.size)  # tick-to-tick alternation
    torque = np.column_stack((clean + noise, 0.5 * clean))
    m = compute_metrics(t, np.zeros((t.size, 2)), torque_Nm=torque)
    assert m.shoulder_torque_range_Nm == pytest.approx(4.79 + 0.8, rel=1e-3)
    assert m.shoulder_torque_range_smoothed_Nm == pytest.approx(4.79, rel=1e-3)
    off = compute_metrics(t, np.zeros((t.size, 2)), torque_Nm=torque, torque_cutoff_hz=None)
    assert math.isnan(off.shoulder_torque_range_smoothed_Nm)


def test_pearson():
    x = np.sin(np.linspace(0.0, 3.0, 200))
    assert pearson(x, 2 * x + 1) == pytest.approx(1.0)
    assert pearson(x, -x) == pytest.approx(-1.0)
    y = np.cos(np.linspace(0.0, 3.0, 200))
    assert pearson(x, y) == pytest.approx(np.corrcoef(x, y)[0, 1], abs=1e-12)
    assert math.isnan(pearson(x, np.full(200, 0.4)))


# ------------------------------------------------------------------ shape of the result
def test_missing_channels_give_nan_and_to_dict_is_plain_floats():
    t, position, _ = _circle()
    m = compute_metrics(t, position)
    for name in ("rmse_x_m", "directional_performance_pct", "force_range_y_N",
                 "shoulder_rom_rad", "elbow_torque_range_smoothed_Nm", "path_length_ratio",
                 "reaction_time_s", "initial_direction_error_rad",
                 "shoulder_elbow_correlation"):
        assert math.isnan(getattr(m, name)), name
    assert m.n_reaches == 0
    assert m.reaches == ()
    assert m.within_intervals_s == ()
    record = m.to_dict()
    scalar = [f.name for f in fields(TrialMetrics)
              if f.name not in ("within_intervals_s", "outside_intervals_s", "reaches")]
    assert list(record) == scalar
    assert all(type(value) is float for value in record.values())
    with pytest.raises(AttributeError):
        m.rmse_x_m = 0.0


def test_a_still_hand_has_no_movement_figures():
    t = np.arange(0.0, 1.0, DT)
    m = compute_metrics(t, np.tile([-0.3, 0.3], (t.size, 1)))
    assert m.peak_speed_m_s < 1e-9
    assert m.path_length_m < 1e-9
    for name in ("movement_time_s", "mean_speed_m_s", "sparc", "ldlj"):
        assert math.isnan(getattr(m, name)), name


# ------------------------------------------------------------------ bad inputs
@pytest.mark.parametrize(
    ("kwargs", "field", "words"),
    [
        ({"force_N": np.zeros((99, 2))}, "force_N", r"shape \(99, 2\)"),
        ({"desired_position_m": np.zeros((100, 3))}, "desired_position_m", "shape"),
        ({"isb_angles_rad": np.full((100, 2), np.nan)}, "isb_angles_rad", "sample 0"),
        ({"tolerance_rad": math.nan}, "tolerance_rad", "NaN"),
        ({"tolerance_rad": 0.0}, "tolerance_rad", r"\(0, 3.14159\] rad"),
        ({"tolerance_rad": 4.0}, "tolerance_rad", "rad"),
        ({"min_force_N": -0.1}, "min_force_N", ">= 0"),
        ({"movement_fraction": 1.5}, "movement_fraction", ""),
        ({"speed_cutoff_hz": 250.0}, "cutoff_hz", "Nyquist"),
        ({"filter_order": 12}, "order", ""),
    ],
)
def test_bad_inputs_name_their_field(kwargs, field, words):
    t = np.arange(100) * DT
    with pytest.raises(ParameterError, match=words or None) as info:
        compute_metrics(t, np.zeros((100, 2)), **kwargs)
    assert info.value.field == field


def test_bad_time_stamps_and_short_recordings():
    t = np.arange(100) * DT
    with pytest.raises(ParameterError, match="not increasing") as info:
        compute_metrics(t[::-1], np.zeros((100, 2)))
    assert info.value.field == "t_s"
    with pytest.raises(ParameterError) as info:
        compute_metrics(t, np.zeros((101, 2)))
    assert info.value.field == "position_m"
    short = np.arange(10) * DT
    with pytest.raises(ParameterError, match="at least") as info:
        compute_metrics(short, np.zeros((10, 2)))
    assert info.value.field == "position_m"
    with pytest.raises(ParameterError, match="at least") as info:
        compute_metrics(short, np.zeros((10, 2)), torque_Nm=np.zeros((10, 2)),
                        speed_cutoff_hz=None)
    assert info.value.field == "torque_Nm"
