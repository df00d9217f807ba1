"""A paretic arm's movements made of submovements (device.sim.submovements): how many
pieces, their profile, and a circle walked by them."""

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from core.assessment.protocol import protocol
from core.robot import RobotModel
from core.trajectory import Trajectory, circle
from core.trial import TrialParameters
from device.sim.submovements import (
    STOP_S,
    OwnLaps,
    nominal_shares,
    onset_spacing,
    piece_count,
    profile,
)
from device.sim.tasks import own_movement

ROBOT = RobotModel()


def test_a_healthy_arm_moves_in_one_piece_and_a_weak_one_in_several():
    assert piece_count(0.1, 1.0) == 1
    assert piece_count(10.0, 1.0) == 1
    assert piece_count(0.1, 0.4) == 3  # 3.3 cm pieces
    assert piece_count(2 * math.pi * 0.07, 0.4) == 13
    assert piece_count(0.001, 0.0) == 1  # never none
    # weaker: more pieces, less blended
    assert piece_count(0.1, 0.2) > piece_count(0.1, 0.6)
    assert onset_spacing(0.2) > onset_spacing(0.6) > onset_spacing(1.0) == 0.5


def test_one_piece_is_the_minimum_jerk_profile():
    t = np.linspace(-0.1, 0.7, 801)
    s, sd, sdd = profile(t, 0.6, [1.0], 1.0, 0.1)
    u = np.clip(t / 0.6, 0.0, 1.0)
    assert np.allclose(s, 0.1 * u ** 3 * (10 - 15 * u + 6 * u ** 2), rtol=0, atol=1e-15)
    assert sd.max() == pytest.approx(1.875 * 0.1 / 0.6)
    assert s[-1] == 0.1
    assert sd[-1] == 0.0
    assert sdd[-1] == 0.0


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.05, 2.0), min_size=1, max_size=6), st.floats(0.3, 1.0),
       st.floats(0.2, 3.0), st.floats(0.01, 0.5))
def test_the_pieces_cover_the_distance_within_the_time_and_their_rates_are_derivatives(
        shares, spacing, span, distance):
    dt = span / 4000
    t = np.arange(-50, 4051) * dt
    s, sd, sdd = profile(t, span, shares, spacing, distance)
    assert s[0] == 0.0
    assert s[-1] == pytest.approx(distance, rel=1e-12)
    assert np.all(np.diff(s) >= -1e-15)  # never back
    assert np.all(sd[t >= span] == 0.0)
    assert np.all(sd[t <= 0] == 0.0)
    inner = slice(2, -2)
    assert np.allclose(np.gradient(s, dt)[inner], sd[inner], atol=1e-3 * sd.max())
    assert np.allclose(np.gradient(sd, dt)[inner], sdd[inner], atol=1e-2 * np.abs(sdd).max())


def _maxima(speed):
    return int(np.sum((speed[1:-1] > speed[:-2]) & (speed[1:-1] >= speed[2:])))


def test_the_weak_pieces_each_make_a_speed_peak():
    t = np.linspace(0.0, 0.9, 9001)
    _, sd, _ = profile(t, 0.9, nominal_shares(3), onset_spacing(0.4), 0.1)
    assert _maxima(sd) == 3
    # fully blended pieces make one peak: smoothness comes back with the blending
    _, sd, _ = profile(t, 0.9, nominal_shares(3), 0.2, 0.1)
    assert _maxima(sd) == 1


def test_a_weak_reach_is_planned_in_pieces_and_a_healthy_one_in_one():
    trial = protocol("reaching").parameters(TrialParameters())
    healthy = own_movement(trial, "healthy", {}, 0, ROBOT)
    weak = own_movement(trial, "weak", {}, 0, ROBOT)
    assert all(m.shares == (1.0,) for m in healthy.moves)
    assert all(len(m.shares) == 3 for m in weak.moves)
    # the shares vary from reach to reach around SHARE_RATIO^k
    firsts = [m.shares[0] / sum(m.shares) for m in weak.moves]
    assert 0.3 < np.mean(firsts) < 0.6
    assert np.std(firsts) > 0.01
    move = weak.moves[0]
    t = np.linspace(move.t0_s, move.t1_s, 2001)
    speed = np.hypot(*weak.sample(t).velocity_m_s.T)
    assert _maxima(speed) == 3
    assert weak.sample([move.t1_s]).position_m[0] == pytest.approx(move.end_m, abs=1e-12)


def _derivatives_hold(s, dt):
    inner = slice(2, -2)
    assert np.allclose(np.gradient(s.position_m, dt, axis=0)[inner],
                       s.velocity_m_s[inner], atol=1e-5)
    assert np.allclose(np.gradient(s.velocity_m_s, dt, axis=0)[inner],
                       s.acceleration_m_s2[inner], atol=2e-3)


def test_a_lap_in_pieces_stays_on_the_circle_and_keeps_its_lap_time():
    base = Trajectory(circle((0.0, 0.3), 0.07), 5.0, 3)
    rng = np.random.default_rng(0)
    laps = OwnLaps(base, rng.uniform(0.7, 1.3, (3, 13)), 0.68, stop_s=15.0)
    dt = 5e-4
    t = np.arange(0.0, 16.0, dt)
    s = laps.sample(t)
    radius = np.hypot(s.position_m[:, 0], s.position_m[:, 1] - 0.3)
    assert np.allclose(radius, 0.07, atol=1e-12)
    _derivatives_hold(s, dt)
    speed = np.hypot(*s.velocity_m_s.T)
    for k in range(3):
        # each lap's length in its time, at rest where it starts, 13 peaks in it
        lap = (t >= 5.0 * k) & (t < 5.0 * (k + 1))
        assert np.sum(speed[lap]) * dt == pytest.approx(2 * math.pi * 0.07, rel=1e-3)
        assert laps.sample([5.0 * k]).velocity_m_s[0] == pytest.approx((0.0, 0.0), abs=1e-12)
        assert _maxima(speed[lap]) == 13
    # the pieces differ from lap to lap: the plan is one traversal of the whole trial
    assert not np.allclose(speed[t < 5.0], speed[(t >= 5.0) & (t < 10.0)][:np.sum(t < 5.0)])
    assert laps.duration_s == laps.total_duration_s == 20.0
    assert laps.lap_s == 5.0
    # at rest where it ended, pushing nowhere, to the plan's end
    after = t >= 15.0
    assert np.all(speed[after] == 0.0)
    assert np.all(s.direction[after] == 0.0)
    start = laps.sample([0.0]).position_m[0]
    assert s.position_m[after] == pytest.approx(np.tile(start, (after.sum(), 1)), abs=1e-12)
    assert laps.at(1.0) == pytest.approx(
        (*s.position_m[2000], *s.velocity_m_s[2000], *s.acceleration_m_s2[2000],
         *s.direction[2000]))


def test_a_patient_slower_than_the_dot_stops_when_it_stops():
    """The dot stops at 12 s, mid-lap for a patient lapping in 5 s: by pieces, none begun
    that would end more than STOP_S later; at its own pace, a fall to rest over STOP_S."""
    base = Trajectory(circle((0.0, 0.3), 0.07), 5.0, 3)
    dt = 5e-4
    t = np.arange(0.0, 14.0, dt)
    pace = 2 * math.pi * 0.07 / 5.0
    pieces = OwnLaps(base, np.ones((3, 13)), 0.68, stop_s=12.0)
    paced = OwnLaps(base, None, 1.0, stop_s=12.0)
    for laps in (pieces, paced):
        s = laps.sample(t)
        _derivatives_hold(s, dt)
        speed = np.hypot(*s.velocity_m_s.T)
        assert 12.0 < laps.finished_s <= 12.0 + STOP_S
        assert np.all(speed[t >= laps.finished_s] == 0.0)
        assert np.all(s.direction[t >= laps.finished_s] == 0.0)
        assert speed[(t > 11.0) & (t < 12.0)].max() > 0.0  # still drawing as the dot stops
        rest = s.position_m[t >= laps.finished_s]
        assert np.ptp(rest, axis=0) == pytest.approx((0.0, 0.0), abs=1e-15)
    walked, _, _ = paced.arc([20.0])
    assert walked[0] == pytest.approx(pace * 12.0)  # where the pace would be at the stop
    # the pieces: two whole laps and those of the third begun in time
    piece_s = 5.0 / (1 + 12 * 0.68)
    ends = 10.0 + np.arange(13) * 0.68 * piece_s + piece_s
    begun = int(np.sum(ends <= 12.0 + STOP_S))
    walked, _, _ = pieces.arc([20.0])
    assert walked[0] == pytest.approx(2 * math.pi * 0.07 * (2 + begun / 13))
    assert pieces.finished_s == pytest.approx(ends[begun - 1])


def test_the_weak_patients_circle_is_walked_in_pieces_and_the_healthy_ones_at_the_dots_pace():
    trial = protocol("circle").parameters(TrialParameters())
    weak = own_movement(trial, "weak", {}, 0, ROBOT)
    assert isinstance(weak, OwnLaps)
    assert weak.stop_s == trial.duration_s * trial.repetitions
    # a healthy patient keeps the dot's pace and comes to rest where the dot stops
    healthy = own_movement(trial, "healthy", {}, 0, ROBOT)
    dot = trial.trajectory()
    stop = trial.duration_s * trial.repetitions
    t = np.arange(0.0, stop + 1.0, 0.002)
    ours, theirs = healthy.sample(t), dot.sample(t)
    before = t < stop - STOP_S / 2
    assert ours.position_m[before] == pytest.approx(theirs.position_m[before], abs=1e-12)
    assert ours.velocity_m_s[before] == pytest.approx(theirs.velocity_m_s[before])
    assert ours.position_m[-1] == pytest.approx(theirs.position_m[-1], abs=1e-9)
    assert healthy.finished_s == stop + STOP_S / 2
    # a healthy subject slower than the dot laps at its own pace and stops with the dot
    slow = own_movement(trial, "healthy", {"speed_scale": 0.7}, 0, ROBOT)
    assert isinstance(slow, OwnLaps)
    assert slow.shares is None
    with pytest.raises(ValueError, match="constant-pace"):
        OwnLaps(Trajectory(circle((0.0, 0.3), 0.07), 5.0, 1, "minimum_jerk"), [[1, 1]], 0.7,
                5.0)
    with pytest.raises(ValueError, match="one row"):
        OwnLaps(Trajectory(circle((0.0, 0.3), 0.07), 5.0, 2), [[1, 1]], 0.7, 10.0)
    with pytest.raises(ValueError, match="end before"):
        OwnLaps(Trajectory(circle((0.0, 0.3), 0.07), 5.0, 2), None, 1.0, 11.0)
