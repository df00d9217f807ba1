"""The region the robot and the arm both reach (core.assessment.workspace): every edge point
is reachable and a step beyond it is not, its margins agree with the safety supervisor's and
the live loop's, the box keeps it in the live loop's safety region."""

import math

import pytest

from core.assessment.protocol import protocol
from core.assessment.workspace import (
    RANGE_BOX_MARGIN_M,
    ROBOT_MARGIN_M,
    common_region,
    extent_m,
    range_box,
    reachable,
)
from core.errors import ParameterError
from core.robot import RobotModel
from core.trial import TrialParameters
from device.loop.commands import WORKSPACE_MARGIN_M
from device.safety.limits import SafetyLimits

ROBOT = RobotModel()


def test_the_margins_agree_with_the_safety_supervisor_and_the_loop():
    assert SafetyLimits().workspace_margin_m == ROBOT_MARGIN_M
    assert RANGE_BOX_MARGIN_M < WORKSPACE_MARGIN_M


def test_the_regions_edge_is_reachable_and_a_step_beyond_is_not():
    trial = protocol("range").parameters(TrialParameters())
    box = range_box(trial)
    region = common_region(trial, ROBOT, box_m=box, rays=36)
    cx, cy = trial.centre_m
    for x, y in region:
        assert reachable(trial, ROBOT, x, y, box)
        r = math.hypot(x - cx, y - cy)
        ux, uy = (x - cx) / r, (y - cy) / r
        assert not reachable(trial, ROBOT, x + 0.001 * ux, y + 0.001 * uy, box)
    # the box limits the region: no point beyond it
    assert region[:, 0].min() >= box[0]
    assert region[:, 1].max() <= box[3]


def test_the_arm_limits_the_reach_away_from_the_shoulder():
    trial = TrialParameters()
    # straight away from the shoulder the arm straightens first: the hand's distance to
    # the shoulder at the edge is the arm's reach with the elbow bent 10°
    sx, sy = trial.shoulder_m
    cx, cy = trial.centre_m
    away = math.atan2(cy - sy, cx - sx)
    r = extent_m(trial, ROBOT, away)
    arm = trial.arm()
    edge = math.hypot(cx + r * math.cos(away) - sx, cy + r * math.sin(away) - sy)
    assert edge == pytest.approx(arm.reach_at_elbow_flexion(math.radians(10.0)), abs=1e-4)


def test_a_centre_nobody_reaches_is_refused():
    with pytest.raises(ParameterError) as refused:
        common_region(TrialParameters(centre_m=(-1.2, 1.2)), ROBOT, rays=8)
    assert refused.value.field == "centre_m"


def _reachable_as_it_was(parameters, robot, x, y, box_m):
    """The point test before the region's bounds were worked out once: the arm built
    and the robot's reach taken at every point."""
    from core import robot_terms
    from core.trial_check import ELBOW_FLEXION_RANGE_RAD

    x_min, x_max, y_min, y_max = box_m
    if not (x_min <= x <= x_max and y_min <= y <= y_max):
        return False
    radius = math.hypot(x, y)
    if not (robot.reach_min_m + ROBOT_MARGIN_M <= radius <= robot.reach_max_m - ROBOT_MARGIN_M):
        return False
    q1, q2 = robot.ik_terms(x, y)
    if math.isnan(q1) or math.isnan(q2):
        return False
    if robot_terms.limit_violation(robot.constants, q1, q2) != robot_terms.WITHIN_LIMITS:
        return False
    arm = parameters.arm()
    lo, hi = ELBOW_FLEXION_RANGE_RAD
    distance = math.hypot(x - arm.shoulder_x_m, y - arm.shoulder_y_m)
    return arm.reach_at_elbow_flexion(hi) <= distance <= arm.reach_at_elbow_flexion(lo)


@pytest.mark.parametrize("side", ["right", "left"])
def test_the_region_is_the_one_the_point_by_point_test_found(side):
    """Each ray walks to the same last point, bit for bit, as with the per-point test."""
    trial = protocol("range").parameters(TrialParameters(side=side, upper_arm_m=0.29))
    box = range_box(trial)
    cx, cy = trial.centre_m
    for direction in (0.0, 0.7, 1.9, math.pi, 4.4, 5.8):
        ux, uy = math.cos(direction), math.sin(direction)
        r = 0.0
        while _reachable_as_it_was(trial, ROBOT, cx + (r + 0.005) * ux, cy + (r + 0.005) * uy,
                                   box) and r + 0.005 <= 0.8:
            r += 0.005
        step = 0.005
        for _ in range(10):
            step /= 2.0
            if _reachable_as_it_was(trial, ROBOT, cx + (r + step) * ux, cy + (r + step) * uy,
                                    box):
                r += step
        assert extent_m(trial, ROBOT, direction, box) == r
