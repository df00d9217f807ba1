"""The region of the table the robot and the patient's arm can both reach: the active range
task's denominator (range_area_ratio) and the virtual patient's limit in that task.

The region is traced by rays from the exercise's centre: along each direction the hand
may go out while every point up to it is
* inside the robot's reach ring with the safety supervisor's radial margin (the handle
  stops before the parallelogram folds flat: device.safety.limits' workspace margin,
  2 cm) and within its software joint limits (core.robot, eq. 3.1 inverted);
* within the arm's reach with the elbow neither straight nor folded (the same range as a
  trial's check, core.trial_check.ELBOW_FLEXION_RANGE_RAD: 10–140°);
* inside an optional box (the live loop's safety region around the exercise, which stops
  the handle beyond it).
The region is then the polygon of those farthest points. A ray stops at the first point
it cannot reach, so the polygon is the part of the common region *seen* from the centre
(star-shaped about it); the robot's and the arm's reach rings seen from a centre inside
both are, so nothing the patient could reach from the centre without leaving the region
is lost.
"""

from __future__ import annotations

import math

import numpy as np

from core import robot_terms
from core.errors import ParameterError
from core.robot import WORKSPACE_MARGIN_M, RobotModel
from core.trial import TrialParameters
from core.trial_check import ELBOW_FLEXION_RANGE_RAD

ROBOT_MARGIN_M = WORKSPACE_MARGIN_M
"""The safety supervisor's radial margin inside the robot's reach ring (core.robot, the
default of device.safety.limits SafetyLimits.workspace_margin_m)."""
RAYS = 180
COARSE_STEP_M = 0.005
FINE_STEPS = 10
"""Each ray is walked 5 mm at a time, then its last step halved 10 times (5 µm)."""
MAX_EXTENT_M = 0.8
RANGE_BOX_MARGIN_M = 0.08
"""The active range task's box: the exercise's path (its direction marks) widened by this,
2 cm inside the live loop's safety region around the path (device.loop.process
WORKSPACE_MARGIN_M, 0.10 m; tests/core/assessment/test_workspace.py checks it stays
inside), so a hand held at the box's edge never stops the robot."""


class _Region:
    """The common region's bounds for one trial (see the module notes): the arm is built
    and the robot's and the arm's reach rings worked out once, not for every point a ray
    tries (building the arm was most of the active range task's figures' time,
    2026-12-04)."""

    __slots__ = ("box_m", "radius_m", "ring_m", "robot", "shoulder_m")

    def __init__(self, parameters: TrialParameters, robot: RobotModel,
                 box_m: tuple[float, float, float, float] | None) -> None:
        arm = parameters.arm()
        lo, hi = ELBOW_FLEXION_RANGE_RAD
        self.robot = robot
        self.box_m = box_m
        self.radius_m = robot.reach_band_m(ROBOT_MARGIN_M)
        self.shoulder_m = (arm.shoulder_x_m, arm.shoulder_y_m)
        self.ring_m = (arm.reach_at_elbow_flexion(hi), arm.reach_at_elbow_flexion(lo))

    def inside(self, x: float, y: float) -> bool:
        robot = self.robot
        if self.box_m is not None:
            x_min, x_max, y_min, y_max = self.box_m
            if not (x_min <= x <= x_max and y_min <= y <= y_max):
                return False
        if not (self.radius_m[0] <= math.hypot(x, y) <= self.radius_m[1]):
            return False
        q1, q2 = robot.ik_terms(x, y)
        if math.isnan(q1) or math.isnan(q2):
            return False
        if robot_terms.limit_violation(robot.constants, q1, q2) != robot_terms.WITHIN_LIMITS:
            return False
        distance = math.hypot(x - self.shoulder_m[0], y - self.shoulder_m[1])
        return self.ring_m[0] <= distance <= self.ring_m[1]


def reachable(parameters: TrialParameters, robot: RobotModel, x: float, y: float,
              box_m: tuple[float, float, float, float] | None = None) -> bool:
    """Whether the hand at (x, y) is inside the common region (see the module notes)."""
    return _Region(parameters, robot, box_m).inside(x, y)


def extent_m(parameters: TrialParameters, robot: RobotModel, direction_rad: float,
             box_m: tuple[float, float, float, float] | None = None) -> float:
    """How far from the centre the hand can go along `direction_rad` (counter-clockwise
    from +x) without leaving the common region; 0 when the centre itself is outside."""
    return _extent(_Region(parameters, robot, box_m), parameters.centre_m, direction_rad)


def _extent(region: _Region, centre_m, direction_rad: float) -> float:
    cx, cy = centre_m
    ux, uy = math.cos(direction_rad), math.sin(direction_rad)

    def inside(r: float) -> bool:
        return region.inside(cx + r * ux, cy + r * uy)

    if not inside(0.0):
        return 0.0
    r = 0.0
    while r + COARSE_STEP_M <= MAX_EXTENT_M and inside(r + COARSE_STEP_M):
        r += COARSE_STEP_M
    step = COARSE_STEP_M
    for _ in range(FINE_STEPS):
        step /= 2.0
        if inside(r + step):
            r += step
    return r


def common_region(parameters: TrialParameters, robot: RobotModel | None = None, *,
                  box_m: tuple[float, float, float, float] | None = None,
                  rays: int = RAYS) -> np.ndarray:
    """The common region as a polygon, (rays, 2) points in m counter-clockwise from +x
    about the trial's centre. Refuses a centre outside it (no region to measure in)."""
    robot = robot or RobotModel()
    angles = 2.0 * math.pi * np.arange(rays) / rays
    cx, cy = parameters.centre_m
    region = _Region(parameters, robot, box_m)
    extents = [_extent(region, parameters.centre_m, float(a)) for a in angles]
    if not any(extents):
        raise ParameterError("centre_m", parameters.centre_m,
                             "a point both the robot and the arm reach",
                             "the active range is measured from there")
    extents_arr = np.asarray(extents)
    return np.column_stack((cx + extents_arr * np.cos(angles), cy + extents_arr * np.sin(angles)))


def range_box(parameters: TrialParameters) -> tuple[float, float, float, float]:
    """(x_min, x_max, y_min, y_max) of the active range task's box (RANGE_BOX_MARGIN_M)."""
    points = parameters.path().points()
    low = points.min(axis=0) - RANGE_BOX_MARGIN_M
    high = points.max(axis=0) + RANGE_BOX_MARGIN_M
    return (float(low[0]), float(high[0]), float(low[1]), float(high[1]))
