"""The performance-based assistance of section 3.5 / Fig. 3.6: reduce only, inside the cone."""

import math

import numpy as np
import pytest
from hypothesis import example, given, strategies as st

from core.control.assistance import (
    DEFAULT_MIN_FORCE_N,
    FORCE_RESOLUTION_N,
    PerformanceAssistance,
)
from core.errors import ParameterError
from core.robot import RobotModel
from core.trial import TOLERANCE_RANGE_RAD

ROBOT = RobotModel()
Q = tuple(ROBOT.ik([-0.30, 0.30]))


def jt_f(q1, q2, fx, fy):
    """J_Rᵀ F from the array-level Jacobian, independent of the component path."""
    return ROBOT.jacobian([q1, q2]).T @ np.array([fx, fy])


def geometric_angle(fx, fy, dx, dy):
    cos = (fx * dx + fy * dy) / (math.hypot(fx, fy) * math.hypot(dx, dy))
    return math.acos(min(1.0, max(-1.0, cos)))


angles = st.floats(-math.pi, math.pi, allow_nan=False)
# No torque or level in (0, 1e-9]: there the product r·τ that decides whether the cut
# applies underflows to zero for one rounding of J_Rᵀ F and not for the other (this
# test's array Jacobian against the kernel's terms), so the two disagree about a torque of
# 1e-45 N·m (hypothesis found τ = -1.4e-45), which no drive can tell from zero.
torques = st.floats(-3.0, 3.0, allow_nan=False).filter(lambda t: t == 0.0 or abs(t) > 1e-9)


@given(
    q1=st.floats(0.5, 3.5), spread=st.floats(0.3, 2.8),
    force=st.floats(0.0, 40.0), force_angle=angles, dir_angle=angles,
    dir_length=st.floats(0.05, 5.0),
    tau1=torques, tau2=torques,
    level=st.floats(0.0, 1.0).filter(lambda v: v == 0.0 or v > 1e-9),
    tolerance=st.floats(*TOLERANCE_RANGE_RAD),
)
@example(q1=1.0, spread=1.0, force=10.0, force_angle=0.0, dir_angle=0.0, dir_length=1.0,
         tau1=1e-9 * 1.5, tau2=-3.0, level=1.0, tolerance=0.5)
def test_reduces_only_inside_the_cone_and_never_adds_torque(
    q1, spread, force, force_angle, dir_angle, dir_length, tau1, tau2, level, tolerance
):
    q2 = q1 - spread
    fx, fy = force * math.cos(force_angle), force * math.sin(force_angle)
    dx, dy = dir_length * math.cos(dir_angle), dir_length * math.sin(dir_angle)
    assist = PerformanceAssistance(ROBOT, tolerance_rad=tolerance, level=level)
    out1, out2, active, angle = assist.apply(q1, q2, tau1, tau2, fx, fy, dx, dy)

    # Never more torque, never the other way.
    for before, after in ((tau1, out1), (tau2, out2)):
        assert abs(after) <= abs(before)
        assert after * before >= 0.0

    if abs(math.hypot(fx, fy) - DEFAULT_MIN_FORCE_N) < 1e-9:
        return  # exactly on the minimum force, rounding may decide either way
    if math.hypot(fx, fy) < DEFAULT_MIN_FORCE_N:
        assert not active
        assert math.isnan(angle)
        assert (out1, out2) == (tau1, tau2)
        return
    expected_angle = geometric_angle(fx, fy, dx, dy)
    assert angle == pytest.approx(expected_angle, abs=1e-6)
    if expected_angle > tolerance + 1e-6:
        assert not active
    if expected_angle < tolerance - 1e-6:
        assert active
    if not active:
        assert (out1, out2) == (tau1, tau2)
        return

    reduction = level * jt_f(q1, q2, fx, fy)
    for before, after, r in ((tau1, out1, reduction[0]), (tau2, out2, reduction[1])):
        if r * before <= 0.0:
            assert after == before  # would add torque: left alone
        elif abs(r) < abs(before):
            assert after == pytest.approx(before - r, abs=1e-12)  # the full J_Rᵀ F fits
        else:
            assert after == 0.0  # capped at the torque's own size


def test_exact_reduction_by_jt_f_along_the_path():
    """A 2 N push along the desired direction takes exactly J_Rᵀ F off a larger torque."""
    d = (0.0, 1.0)
    fx, fy = 0.0, 2.0
    g = jt_f(*Q, fx, fy)
    tau = 3.0 * g  # same sign as the subject's contribution, larger
    assist = PerformanceAssistance(ROBOT)
    out1, out2, active, angle = assist.apply(*Q, *tau, fx, fy, *d)
    assert active
    assert angle == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose([out1, out2], tau - g, rtol=1e-12)


def test_graded_level_scales_the_reduction():
    fx, fy = 1.5, 2.0
    g = jt_f(*Q, fx, fy)
    tau = 4.0 * g
    assist = PerformanceAssistance(ROBOT, level=0.0)
    for level in (0.0, 0.25, 1.0):
        assist.set_level(level)
        out1, out2, active, _ = assist.apply(*Q, *tau, fx, fy, fx, fy)
        assert active  # the cone test does not depend on the level
        np.testing.assert_allclose([out1, out2], tau - level * g, rtol=1e-12, atol=1e-15)
    assert assist.level == 1.0


def test_tolerance_edges_of_the_thesis_20_degree_cone():
    assist = PerformanceAssistance(ROBOT)
    tau = tuple(5.0 * jt_f(*Q, 0.0, 1.0))
    for deg, inside in ((19.0, True), (21.0, False), (-19.0, True), (-21.0, False)):
        a = math.radians(90.0 + deg)
        out1, out2, active, angle = assist.apply(*Q, *tau, math.cos(a), math.sin(a), 0.0, 1.0)
        assert active is inside
        assert math.degrees(angle) == pytest.approx(abs(deg))
        assert ((out1, out2) != tau) is inside
    assist.set_tolerance(math.radians(25.0))
    a = math.radians(90.0 + 21.0)
    assert assist.apply(*Q, *tau, math.cos(a), math.sin(a), 0.0, 1.0)[2]


def test_small_force_has_no_direction():
    assist = PerformanceAssistance(ROBOT)
    small = 0.9 * DEFAULT_MIN_FORCE_N
    out = assist.apply(*Q, 1.0, -1.0, 0.0, small, 0.0, 1.0)
    assert out[:3] == (1.0, -1.0, False)
    assert math.isnan(out[3])
    # the default is a few sensor counts, not below one
    assert 2 * FORCE_RESOLUTION_N <= DEFAULT_MIN_FORCE_N <= 10 * FORCE_RESOLUTION_N


@pytest.mark.parametrize(
    ("fx", "fy", "dx", "dy"),
    [(math.nan, 1.0, 0.0, 1.0), (1.0, math.inf, 0.0, 1.0), (0.0, 1.0, 0.0, 0.0),
     (0.0, 1.0, math.nan, 1.0)],
)
def test_undefined_inputs_leave_torque_alone(fx, fy, dx, dy):
    assist = PerformanceAssistance(ROBOT)
    out1, out2, active, _ = assist.apply(*Q, 0.7, -0.4, fx, fy, dx, dy)
    assert (out1, out2, active) == (0.7, -0.4, False)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"tolerance_rad": math.radians(0.5)}, "tolerance_rad"),
        ({"tolerance_rad": math.radians(95.0)}, "tolerance_rad"),
        ({"tolerance_rad": math.nan}, "tolerance_rad"),
        ({"level": -0.1}, "assistance_level"),
        ({"level": 1.5}, "assistance_level"),
        ({"min_force_N": 0.0}, "min_force_N"),
        ({"min_force_N": 100.0}, "min_force_N"),
    ],
)
def test_bad_parameters_are_refused_by_name(kwargs, field):
    with pytest.raises(ParameterError) as info:
        PerformanceAssistance(ROBOT, **kwargs)
    assert info.value.field == field
    assert field in str(info.value)


def test_runtime_changes_are_validated_and_keep_the_old_value():
    assist = PerformanceAssistance(ROBOT, level=0.5)
    with pytest.raises(ParameterError, match="assistance_level"):
        assist.set_level(2.0)
    assert assist.level == 0.5
    with pytest.raises(ParameterError, match="tolerance_rad"):
        assist.set_tolerance(-1.0)
    assert assist.tolerance_rad == pytest.approx(math.radians(20.0))


def test_robot_without_jacobian_is_refused():
    with pytest.raises(ParameterError, match="robot"):
        PerformanceAssistance(object())


def test_an_estimate_of_the_force_stands_in_for_the_sensor_and_is_dropped_when_stale():
    """The EMG path (chapter 5): the scheme judges the estimate, not the sensor, and an
    estimate older than its limit counts as no push at all (the robot gives full help)."""
    from core.control.assistance import ESTIMATE_MAX_AGE_S, judged_force

    a = PerformanceAssistance(ROBOT)
    assert judged_force(a.constants, 10, 1.0, 2.0) == (1.0, 2.0)  # the sensor's
    a.judge_estimate(0.002)
    assert a.estimated
    # no estimate yet: nothing to judge
    assert all(math.isnan(v) for v in judged_force(a.constants, 10, 1.0, 2.0))
    a.set_estimate(3.0, -1.0, 100)
    assert judged_force(a.constants, 100, 1.0, 2.0) == (3.0, -1.0)
    limit = round(ESTIMATE_MAX_AGE_S / 0.002)
    assert judged_force(a.constants, 100 + limit, 1.0, 2.0) == (3.0, -1.0)
    assert all(math.isnan(v) for v in judged_force(a.constants, 101 + limit, 1.0, 2.0))
    # one made for a later tick (another trial's count) is none either
    assert all(math.isnan(v) for v in judged_force(a.constants, 99, 1.0, 2.0))
    # a lost estimate leaves the scheme inactive and the torque as the controller's
    a.set_estimate(math.nan, math.nan, 200)
    fx, fy = judged_force(a.constants, 200, 1.0, 2.0)
    assert a.apply(*Q, 1.0, -1.0, fx, fy, 1.0, 0.0)[:3] == (1.0, -1.0, False)
    with pytest.raises(ParameterError, match="max_age_s"):
        a.judge_estimate(0.002, max_age_s=0.001)
