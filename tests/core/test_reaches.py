"""Reaction time, initial direction error and movement time on synthetic reaches."""

import math

import numpy as np
import pytest

from core.errors import ParameterError
from core.metrics import compute_metrics
from core.reaches import Reach, reach_metrics, reaches_from_trajectory
from core.signal import smoothed_derivatives
from core.smoothness import sparc
from core.trajectory import Arc, Line, Trajectory, centre_out, d_shape

DT = 0.002
DURATION_S = 0.8
DISTANCE_M = 0.12
FRACTION = 0.1
# where 30u²(1−u)² = FRACTION·30/16: the minimum-jerk speed at FRACTION of its peak
CROSSING = (1 - math.sqrt(1 - math.sqrt(FRACTION))) / 2


def _min_jerk_distance(u):
    u = np.clip(u, 0.0, 1.0)
    return DISTANCE_M * u**3 * (10 - 15 * u + 6 * u * u)


def _centre_out_recording(reaction_times, errors_rad, directions_rad, period_s=2.0):
    """One reach per period: the target appears at 0.5 s + k·period; the hand rests
    for its reaction time, then moves straight, minimum jerk, at `error` from the
    target direction, and rests where it arrived (the next reach starts there)."""
    t = np.arange(0.0, period_s * len(reaction_times), DT)
    position = np.empty((t.size, 2))
    position[:] = (-0.3, 0.3)
    hand = np.array([-0.3, 0.3])
    reaches = []
    for k, (rt, error, aim) in enumerate(zip(reaction_times, errors_rad, directions_rad,
                                             strict=True)):
        onset = 0.5 + period_s * k
        target = hand + DISTANCE_M * np.array([math.cos(aim), math.sin(aim)])
        reaches.append(Reach(onset, tuple(hand), tuple(target)))
        heading = np.array([math.cos(aim + error), math.sin(aim + error)])
        later = t >= onset
        s = _min_jerk_distance((t[later] - onset - rt) / DURATION_S)
        position[later] = hand + s[:, None] * heading
        hand = hand + DISTANCE_M * heading
    return t, position, reaches


def _expected_direction_error(start, target, error, aim):
    """Angle from (hand at movement onset → target) to the heading: the hand has
    already gone s(CROSSING) along the heading at the 10 % crossing."""
    heading = np.array([math.cos(aim + error), math.sin(aim + error)])
    p0 = np.asarray(start) + _min_jerk_distance(CROSSING) * heading
    line = np.asarray(target) - p0
    return math.atan2(line[0] * heading[1] - line[1] * heading[0], line @ heading)


RTS = (0.2, 0.25, 0.3, 0.35)
ERRORS = tuple(math.radians(d) for d in (10.0, -5.0, 0.0, 20.0))
AIMS = (-0.5 * math.pi, 0.0, 0.5 * math.pi, math.pi)


@pytest.mark.parametrize("cutoff_hz", [None, 10.0])
def test_reaction_time_direction_error_and_movement_time(cutoff_hz):
    t, position, reaches = _centre_out_recording(RTS, ERRORS, AIMS)
    m = compute_metrics(t, position, reaches=reaches, speed_cutoff_hz=cutoff_hz)
    assert m.n_reaches == 4
    rt_tolerance = 1e-4 if cutoff_hz is None else 1e-3
    for result, reach, rt, error, aim in zip(m.reaches, reaches, RTS, ERRORS, AIMS, strict=True):
        assert result.target_onset_s == reach.onset_s
        assert result.reaction_time_s == pytest.approx(rt + CROSSING * DURATION_S,
                                                        abs=rt_tolerance)
        assert result.movement_time_s == pytest.approx((1 - 2 * CROSSING) * DURATION_S,
                                                       abs=2 * rt_tolerance)
        expected = _expected_direction_error(reach.start_m, reach.target_m, error, aim)
        assert result.initial_direction_error_rad == pytest.approx(expected, abs=rt_tolerance / 10)
        assert result.initial_direction_error_rad == pytest.approx(error, abs=0.01 * abs(error))
        assert result.peak_speed_m_s == pytest.approx(1.875 * DISTANCE_M / DURATION_S, rel=1e-3)
    assert m.reaction_time_s == pytest.approx(np.mean(RTS) + CROSSING * DURATION_S,
                                              abs=rt_tolerance)
    mean_abs = np.mean([abs(r.initial_direction_error_rad) for r in m.reaches])
    assert m.initial_direction_error_rad == pytest.approx(mean_abs)


def test_reach_smoothness_equals_that_of_the_isolated_profile():
    t, position, reaches = _centre_out_recording(RTS[:2], ERRORS[:2], AIMS[:2])
    velocity = smoothed_derivatives(position, DT, None).rate
    results = reach_metrics(t, position, velocity, reaches)
    u = np.arange(0.0, DURATION_S + DT / 2, DT) / DURATION_S
    alone = DISTANCE_M / DURATION_S * 30 * u * u * (1 - u) ** 2
    for result in results:
        assert result.sparc == pytest.approx(sparc(alone, DT), abs=5e-3)  # rest = zero padding
    assert results[0].ldlj == pytest.approx(results[1].ldlj, abs=1e-3)
    jerky = position.copy()
    wobble = 0.002 * np.sin(2 * math.pi * 7.0 * t)
    moving = np.linalg.norm(velocity, axis=1) > 0.0
    jerky[moving, 0] += wobble[moving]
    worse = reach_metrics(t, jerky, smoothed_derivatives(jerky, DT, None).rate, reaches)
    assert worse[0].sparc < results[0].sparc
    assert worse[0].ldlj < results[0].ldlj


def test_hand_already_moving_no_movement_and_late_reaches():
    t, position, reaches = _centre_out_recording(RTS[:2], ERRORS[:2], AIMS[:2])
    velocity = smoothed_derivatives(position, DT, None).rate
    # a target shown mid-movement: no onset, so no reaction time or initial direction
    moving = Reach(0.5 + RTS[0] + 0.5 * DURATION_S, reaches[0].start_m, reaches[0].target_m)
    (result,) = reach_metrics(t, position, velocity, [moving])
    assert math.isnan(result.reaction_time_s)
    assert math.isnan(result.movement_time_s)
    assert math.isnan(result.initial_direction_error_rad)
    assert result.peak_speed_m_s > 0.0
    assert math.isfinite(result.movement_offset_s)
    # a still hand, and a target after the recording ended
    still = np.tile([-0.3, 0.3], (t.size, 1))
    (quiet,) = reach_metrics(t, still, np.zeros_like(still), reaches[:1])
    assert quiet.peak_speed_m_s == 0.0
    assert math.isnan(quiet.reaction_time_s)
    assert math.isnan(quiet.sparc)
    late = Reach(t[-1] + 1.0, (0.0, 0.0), (0.1, 0.0))
    (after,) = reach_metrics(t, position, velocity, [late])
    assert math.isnan(after.peak_speed_m_s)
    assert after.target_onset_s == late.onset_s


def test_reaches_from_trajectories():
    trajectory = Trajectory(centre_out((-0.3, 0.3), 0.1, 4), 8.0, 2, timing="minimum_jerk")
    reaches = reaches_from_trajectory(trajectory)
    assert len(reaches) == 2 * 8
    for k, reach in enumerate(reaches):
        rep, index = divmod(k, 8)
        segment = trajectory.path.segments[index]
        assert reach.onset_s == pytest.approx(rep * 8.0 + trajectory.segment_times_s[index])
        assert (reach.start_m, reach.target_m) == (segment.start, segment.end)
    # the D has one straight line per traversal; its arc is not a reach
    d = Trajectory(d_shape((-0.3, 0.3), 0.1), 4.0, 3)
    lines = reaches_from_trajectory(d)
    line = d.path.segments[0]
    assert isinstance(line, Line)
    assert isinstance(d.path.segments[1], Arc)
    assert [(r.onset_s, r.start_m, r.target_m) for r in lines] == [
        (pytest.approx(4.0 * k), line.start, line.end) for k in range(3)
    ]
    # the trajectory's own minimum-jerk motion gives its reaches' reaction times
    t = np.arange(0.0, trajectory.total_duration_s, DT)
    m = compute_metrics(t, trajectory.sample(t).position_m, reaches=reaches,
                        speed_cutoff_hz=None)
    assert m.reaction_time_s == pytest.approx(CROSSING * 1.0, abs=1e-3)  # 1 s per segment
    assert m.initial_direction_error_rad == pytest.approx(0.0, abs=1e-9)


def test_bad_reaches():
    with pytest.raises(ParameterError) as info:
        Reach(0.0, (0.1, 0.2), (0.1, 0.2))
    assert info.value.field == "target_m"
    with pytest.raises(ParameterError) as info:
        Reach(math.nan, (0.1, 0.2), (0.2, 0.2))
    assert info.value.field == "onset_s"
    t, position, reaches = _centre_out_recording(RTS[:2], ERRORS[:2], AIMS[:2])
    with pytest.raises(ParameterError) as info:
        compute_metrics(t, position, reaches=reaches[::-1])
    assert info.value.field == "reaches"
    with pytest.raises(ParameterError) as info:
        compute_metrics(t, position, reaches=reaches, initial_window_s=0.0)
    assert info.value.field == "initial_window_s"
    with pytest.raises(ParameterError) as info:
        Reach(0.0, (0.1, 0.2, 0.3), (0.2, 0.2))
    assert info.value.field == "start_m"


def test_a_recording_of_one_sample_gives_every_reach_nan_without_a_warning():
    # core.blockwise hands reach_metrics a single sample when a target came after the
    # trial's last one (seen in the range task of a virtual subject, board 18:44)
    reach = Reach(2.0, (0.0, 0.0), (0.1, 0.0))
    for n in (0, 1):
        t = np.arange(n) * DT + 1.0
        position = np.zeros((n, 2))
        (result,) = reach_metrics(t, position, position, [reach])
        assert math.isnan(result.peak_speed_m_s)
        assert math.isnan(result.reaction_time_s)
        assert result.target_onset_s == 2.0
