"""The hold (core.control.hold): what the drives can hold along a direction, by the
statics τ = J_Rᵀ F; the held windows the pipeline's exercise vector carries; the take-over
from where the patient left the hand."""

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from core.control.gains import built
from core.control.hold import (
    HC_COUNT,
    HC_ON,
    HC_WINDOWS,
    HOLD_GAINS,
    HOLD_INTEGRAL_LIMIT_RAD_S2,
    HS_SIZE,
    TAKEOVER_S,
    held_at,
    hold_capacity_N,
    hold_constants,
    taken_over,
)
from core.control.transparent import TC_SIZE
from core.robot import RobotModel

ROBOT = RobotModel()
PERIOD = 0.002


def jacobian_by_differences(q1, q2, h=1e-7):
    """∂P/∂θ by central differences of the forward kinematics, (2, 2)."""
    out = np.empty((2, 2))
    for j, (d1, d2) in enumerate(((h, 0.0), (0.0, h))):
        plus = np.array(ROBOT.position(q1 + d1, q2 + d2))
        minus = np.array(ROBOT.position(q1 - d1, q2 - d2))
        out[:, j] = (plus - minus) / (2 * h)
    return out


def test_the_capacity_at_the_centre_by_hand():
    """At the thesis's centre: the push along each direction that brings the busier drive
    to its 2.21 N·m, from a Jacobian of finite differences."""
    q1, q2 = ROBOT.ik_terms(-0.30, 0.30)
    jac = jacobian_by_differences(q1, q2)
    limits = np.array(ROBOT.max_joint_torque_Nm)
    for k in range(8):
        angle = math.radians(45 * k)
        u = np.array([math.cos(angle), math.sin(angle)])
        by_hand = float(np.min(limits / np.abs(jac.T @ u)))
        assert math.isclose(hold_capacity_N(ROBOT, q1, q2, angle), by_hand, rel_tol=1e-6)
    # the thesis robot's drives are small: a few newtons, nowhere near a healthy push
    caps = [hold_capacity_N(ROBOT, q1, q2, math.radians(45 * k)) for k in range(8)]
    assert 5.0 < min(caps) < max(caps) < 9.0


@settings(max_examples=60, deadline=None)
@given(x=st.floats(-0.40, -0.15), y=st.floats(0.20, 0.45), angle=st.floats(-math.pi, math.pi))
def test_at_the_capacity_one_drive_is_at_its_limit_and_none_beyond(x, y, angle):
    q1, q2 = ROBOT.ik_terms(x, y)
    cap = hold_capacity_N(ROBOT, q1, q2, angle)
    force = cap * np.array([math.cos(angle), math.sin(angle)])
    tau = np.array(ROBOT.joint_torque_terms(q1, q2, *force))
    share = np.abs(tau) / np.array(ROBOT.max_joint_torque_Nm)
    assert math.isclose(share.max(), 1.0, rel_tol=1e-9)


def test_the_hold_is_the_ctpid_with_an_integral_that_can_hold_the_drives():
    gains = built("ctpid", HOLD_GAINS)
    assert gains.integral_limit_rad_s2 == (HOLD_INTEGRAL_LIMIT_RAD_S2,) * 2
    q1, q2 = ROBOT.ik_terms(-0.30, 0.30)
    m11, _, m22 = ROBOT.mass_terms(q1, q2)
    # the integral alone can ask each joint for more than its drive gives
    limits = ROBOT.max_joint_torque_Nm
    assert m11 * HOLD_INTEGRAL_LIMIT_RAD_S2 > limits[0]
    assert m22 * HOLD_INTEGRAL_LIMIT_RAD_S2 > limits[1]


def test_held_windows_and_their_first_ticks():
    guide = [0.0] * TC_SIZE + hold_constants([(0, 10), (25, 30)])
    assert guide[HC_ON] == 1.0
    assert guide[HC_COUNT] == 2.0
    assert guide[HC_WINDOWS:] == [0.0, 10.0, 25.0, 30.0]
    assert held_at(guide, 0) == (True, True)
    assert held_at(guide, 9) == (True, False)
    assert held_at(guide, 10) == (False, False)
    assert held_at(guide, 24) == (False, False)
    assert held_at(guide, 25) == (True, True)
    assert held_at(guide, 30) == (False, False)


def test_the_take_over_starts_at_the_hand_and_reaches_the_task_s_reference():
    """At a held window's first tick the reference is where the hand is; it glides to the
    task's by minimum jerk over TAKEOVER_S (rate and acceleration its derivatives, zero
    at both ends), and is the task's from then on."""
    z = [0.0] * HS_SIZE
    task = (1.0, 2.0, 0.0, 0.0, 0.0, 0.0)  # held still
    hand = (1.02, 1.99)
    start = 700
    ticks = round(TAKEOVER_S / PERIOD)
    first = taken_over(z, True, start, PERIOD, *hand, *task)
    assert first[:2] == pytest.approx(hand)
    assert first[2:] == pytest.approx((0.0,) * 4, abs=1e-12)
    out = [first] + [taken_over(z, False, start + k, PERIOD, *hand, *task)
                     for k in range(1, ticks + 3)]
    r1 = np.array([o[0] for o in out])
    rd1 = np.array([o[2] for o in out])
    rdd1 = np.array([o[4] for o in out])
    # the rate and the acceleration are the angle's derivatives (central differences)
    np.testing.assert_allclose(rd1[1:-1], (r1[2:] - r1[:-2]) / (2 * PERIOD), atol=2e-4)
    np.testing.assert_allclose(rdd1[1:-1], (rd1[2:] - rd1[:-2]) / (2 * PERIOD), atol=2e-2)
    assert out[ticks // 2][0] == pytest.approx(1.01)  # halfway at half time
    assert out[ticks] == task
    assert out[-1] == task
