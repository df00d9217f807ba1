"""The timetables of the tasks the robot leads (core.holdtasks): each stretch where and
when the module notes put it, the reference they make, the held windows and the events."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from core.control.hold import LINE_FRACTION, hold_capacity_N
from core.errors import ParameterError
from core.holdtasks import (
    POSITION_AT_TARGET_S,
    POSITION_HOME_S,
    POSITION_MOVE_S,
    POSITION_PAUSE_S,
    STRENGTH_READY_S,
    STRENGTH_REST_S,
    direction_deg,
    position_trajectory,
    strength_trajectory,
    task_trajectory,
)
from core.robot import RobotModel
from core.trajectory import centre_out_angles

CENTRE = (-0.30, 0.30)


def test_strength_pushes_each_direction_once_a_round_at_its_line():
    traj = strength_trajectory(CENTRE, 0.05, 8, 3.0, 2)
    cycle = STRENGTH_READY_S + 3.0 + STRENGTH_REST_S
    assert traj.total_duration_s == pytest.approx(2 * 8 * cycle)
    pushes = [s for s in traj.stretches if s.phase == "push"]
    assert len(pushes) == 16
    robot = RobotModel()
    q1, q2 = robot.ik_terms(*CENTRE)
    for i, s in enumerate(pushes):
        angle = centre_out_angles(8)[i % 8]
        values = dict(s.values)
        assert s.start_s == pytest.approx((i * cycle) + STRENGTH_READY_S)
        assert s.push == pytest.approx((math.cos(angle), math.sin(angle)))
        assert values["direction_deg"] == direction_deg(angle)
        assert values["line_N"] == pytest.approx(
            LINE_FRACTION * hold_capacity_N(robot, q1, q2, angle))
        assert values["round"] == i // 8
    # the first direction is straight ahead (−y), then counter-clockwise
    assert [dict(s.values)["direction_deg"] for s in pushes[:8]] == [
        270, 315, 0, 45, 90, 135, 180, 225]
    # held at the centre throughout, pushing only in the pushes
    t = np.linspace(0.0, traj.total_duration_s, 5001)
    sample = traj.sample(t)
    assert np.allclose(sample.position_m, CENTRE)
    assert not sample.velocity_m_s.any()
    pushing = np.hypot(*sample.direction.T) > 0
    in_push = np.zeros_like(t, dtype=bool)
    for s in pushes:
        in_push |= (t >= s.start_s) & (t < s.stop_s)
    assert (pushing == in_push).all()
    assert traj.held_windows_s() == ((0.0, traj.total_duration_s),)


def test_position_moves_the_hand_out_and_back_then_lets_go():
    traj = position_trajectory(CENTRE, 0.10, 4, 4.0, 1)
    phases = [s.phase for s in traj.stretches]
    assert phases[:7] == ["centre", "out", "there", "back", "settle", "match", "home"]
    cycle = (2 * POSITION_PAUSE_S + 2 * POSITION_MOVE_S + POSITION_AT_TARGET_S + 4.0
             + POSITION_HOME_S)
    assert traj.total_duration_s == pytest.approx(4 * cycle)
    out = traj.stretches[1]
    target = (CENTRE[0], CENTRE[1] - 0.10)  # the first straight ahead
    assert out.end == pytest.approx(target)
    # minimum jerk: halfway at half time, the peak speed 15/8 of the mean
    mid = traj.sample([out.start_s + 0.5 * out.duration_s])
    assert mid.position_m[0] == pytest.approx(np.mean([CENTRE, target], axis=0))
    assert np.hypot(*mid.velocity_m_s[0]) == pytest.approx(1.875 * 0.10 / POSITION_MOVE_S)
    # the match's reference rests at the target: the record shows what to find
    match = traj.stretches[5]
    assert traj.sample([match.start_s + 1.0]).position_m[0] == pytest.approx(target)
    # the robot leads everything but the match and the way home
    windows = traj.held_windows_s()
    assert len(windows) == 4
    for (a, b), s in zip(windows, [x for x in traj.stretches if x.phase == "centre"],
                         strict=True):
        assert a == pytest.approx(s.start_s)
        assert b == pytest.approx(s.start_s + 2 * POSITION_PAUSE_S + 2 * POSITION_MOVE_S
                                  + POSITION_AT_TARGET_S)
    # blank until the last way home
    blank = [dict(s.values)["blank"] for s in traj.stretches]
    assert blank == [True] * (len(blank) - 1) + [False]
    events = traj.events()
    assert [e[1] for e in events] == phases
    assert events[5][2]["target_m"] == pytest.approx(target)


def test_task_trajectory_from_a_trials_fields_and_its_refusals():
    p = SimpleNamespace(assessment="strength", centre_m=CENTRE, radius_m=0.05, n_targets=8,
                        duration_s=3.0, repetitions=1)
    assert task_trajectory(p).task == "strength"
    p.assessment = "position"
    p.duration_s = 2.0
    with pytest.raises(ParameterError, match="duration_s"):
        task_trajectory(p)
    p.duration_s = 4.0
    assert task_trajectory(p).task == "position"
    p.assessment = "reaching"
    with pytest.raises(ParameterError, match="assessment"):
        task_trajectory(p)
