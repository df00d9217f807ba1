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
from device.loop.process import WORKSPACE_MARGIN_M
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
