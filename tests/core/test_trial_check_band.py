"""A trial's reach check and the safety supervisor's reach band agree: a path the check
accepts keeps the tracking allowance inside the band the supervisor stops the trial at."""

import math

import numpy as np
import pytest

from core.robot import RobotModel
from core.trial import TrialParameters
from core.trial_check import PATH_TRACKING_ALLOWANCE_M, check_trial, path_band_m
from device.safety.limits import SafetyLimits
from device.safety.supervisor import SafetySupervisor

ROBOT = RobotModel()
SHOULDER_M = (-0.25, 0.30)  # an arm that reaches the low exercises below


def _trial(x: float, y: float, **changes) -> TrialParameters:
    return TrialParameters(assist="as-needed", centre_m=(x, y), shoulder_m=SHOULDER_M,
                           **changes)


def test_the_centre_that_stopped_for_safety_is_refused_with_what_to_change():
    # (-20, -10) cm was "Ready" and the simulated trial stopped 13 cm from the motor axes
    check = check_trial(_trial(-0.20, -0.10))
    assert not check.ok
    problem = check.problems[0]
    assert "from the robot's motor axes" in problem
    assert "away from the robot's motors" in problem
    assert not check.robot_ok.all()  # the preview crosses the points too close


def test_the_checks_band_is_the_supervisors_narrowed_by_the_allowance():
    low, high = SafetySupervisor(ROBOT, SafetyLimits()).reach_band_m
    assert path_band_m(ROBOT) == pytest.approx(
        (low + PATH_TRACKING_ALLOWANCE_M, high - PATH_TRACKING_ALLOWANCE_M))


@pytest.mark.parametrize("shape", ["d", "circle", "reach", "targets", "figure8"])
def test_a_path_the_check_accepts_keeps_the_allowance_inside_the_safety_band(shape):
    low, high = SafetySupervisor(ROBOT, SafetyLimits()).reach_band_m
    accepted = 0
    for x in np.arange(-0.40, 0.05, 0.05):
        for y in np.arange(-0.25, 0.30, 0.05):
            check = check_trial(_trial(float(x), float(y), shape=shape))
            if check.ok:
                accepted += 1
                radius = np.hypot(check.points_m[:, 0], check.points_m[:, 1])
                assert radius.min() >= low + PATH_TRACKING_ALLOWANCE_M - 1e-9
                assert radius.max() <= high - PATH_TRACKING_ALLOWANCE_M + 1e-9
    assert accepted > 0  # the grid holds accepted exercises, so the rule was tried


def test_the_advised_move_away_from_the_motors_is_enough_for_a_circle():
    # a circle's nearest point is straight toward the motors: moving its centre radially
    # by the advised distance makes it pass
    x, y = -0.20, -0.10
    check = check_trial(_trial(x, y, shape="circle", radius_m=0.09))
    assert not check.ok
    words = check.problems[0].split("at least ")[1]
    shift = float(words.split(" m ")[0])
    scale = (math.hypot(x, y) + shift) / math.hypot(x, y)
    assert check_trial(_trial(x * scale, y * scale, shape="circle", radius_m=0.09)).ok
