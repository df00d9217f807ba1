"""The check that a trial's whole path is reachable, and how it says where it is not.

`check_trial` walks the path of a `core.trial.TrialParameters` and says whether the robot
and the subject's arm can follow it, where they cannot (in `MessageUnits`: SI for the
command line, the screen's for the window), and the joint-angle ranges it will ask for.
See docs/frames.md for the frames and for why the thesis's printed shoulder position is
refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from core.arm import ArmModel
from core.errors import UnreachableError
from core.robot import WORKSPACE_MARGIN_M, RobotModel
from core.trial import TrialParameters

# The arm must stay bent: a straight arm is singular (eq. 3.32 has no inverse)
# and a fully folded elbow meets the upper arm.
ELBOW_FLEXION_RANGE_RAD = (math.radians(10.0), math.radians(140.0))
# Peak speed of the desired path; rehabilitation reaches rarely exceed 0.5 m/s.
MAX_PATH_SPEED_M_S = 0.5
PATH_TRACKING_ALLOWANCE_M = 0.02
"""How far the hand may stray from the path toward the robot's motors or away from them
without the safety supervisor stopping the trial: a path is checked against the
supervisor's reach band (core.robot.WORKSPACE_MARGIN_M inside the reach ring) narrowed by
this on both sides. At centre (-20, -10) cm the old check (the ring and the spread limits
only) said ready and the simulated weak patient's trial stopped 13 cm from the motor axes,
at the band's edge (2026-12-06)."""


def path_band_m(robot: RobotModel) -> tuple[float, float]:
    """The distances from the motor axes a trial's path must keep: the safety supervisor's
    band less the tracking allowance (one formula, RobotModel.reach_band_m)."""
    return robot.reach_band_m(WORKSPACE_MARGIN_M + PATH_TRACKING_ALLOWANCE_M)


@dataclass(frozen=True, slots=True)
class MessageUnits:
    """The units `check_trial` writes its refusals in. SI by default, as the command line
    takes its lengths; the window passes the screen's (app.units.SCREEN: cm and mm/s), so
    a refusal reads in the unit of the field it is about."""

    length: str = "m"
    per_m: float = 1.0
    decimals: int = 2  # a length to about a centimetre
    speed: str = "m/s"
    per_m_s: float = 1.0
    speed_decimals: int = 2

    def of_length(self, length_m: float, extra_decimals: int = 0) -> str:
        return f"{length_m * self.per_m:.{self.decimals + extra_decimals}f} {self.length}"

    def of_point(self, point_m) -> str:
        x, y = (v * self.per_m for v in point_m)
        return f"({x:.{self.decimals}f}, {y:.{self.decimals}f}) {self.length}"

    def of_speed(self, speed_m_s: float) -> str:
        return f"{speed_m_s * self.per_m_s:.{self.speed_decimals}f} {self.speed}"


SI_UNITS = MessageUnits()


@dataclass(frozen=True, slots=True)
class TrialCheck:
    """The outcome of walking a trial's path with the robot and the subject's arm."""

    parameters: TrialParameters
    points_m: np.ndarray  # (N, 2) along the path
    robot_ok: np.ndarray  # (N,) bool
    arm_ok: np.ndarray  # (N,) bool
    problems: tuple[str, ...]
    robot_angles_rad: np.ndarray  # (N, 2), NaN where unreachable
    isb_angles_rad: np.ndarray  # (N, 2) ISB shoulder, elbow; NaN where unreachable
    shoulder_distance_m: np.ndarray  # (N,)
    path_length_m: float
    peak_speed_m_s: float
    arm: ArmModel = field(repr=False)

    @property
    def ok(self) -> bool:
        return not self.problems

    @property
    def reachable(self) -> np.ndarray:
        return self.robot_ok & self.arm_ok

    def range_of(self, values: np.ndarray) -> tuple[float, float]:
        """(min, max) over reachable points, NaN if there are none."""
        good = values[self.reachable]
        if good.size == 0:
            return (math.nan, math.nan)
        return (float(good.min()), float(good.max()))

    def require_ok(self) -> TrialCheck:
        if self.problems:
            raise UnreachableError(self.problems[0])
        return self


def check_trial(
    parameters: TrialParameters, robot: RobotModel | None = None, spacing_m: float = 0.002,
    units: MessageUnits = SI_UNITS,
) -> TrialCheck:
    """Walk the trial's path and report what the robot and the arm can reach; the problems
    are written in `units`."""
    robot = robot or RobotModel()
    u = units
    arm = parameters.arm()
    trajectory = parameters.trajectory()
    points = parameters.path().points(spacing_m)
    problems: list[str] = []

    # Robot: inside its ring and its joint limits at every point.
    q1, q2 = robot.ik_terms(points[:, 0], points[:, 1])
    robot_ok = ~(np.isnan(q1) | np.isnan(q2))
    robot_problem = ""
    for i in range(points.shape[0]):
        if not robot_ok[i]:
            x, y = points[i]
            robot_problem = robot_problem or (
                f"point {u.of_point((x, y))} is {u.of_length(math.hypot(x, y))} from the "
                f"robot's motor axes; the robot reaches {u.of_length(robot.l4_m - robot.l2_m)}–"
                f"{u.of_length(robot.l2_m + robot.l4_m)}. Move the exercise's centre."
            )
            continue
        reason = robot.limit_problem(q1[i], q2[i])
        if reason:
            robot_ok[i] = False
            x, y = points[i]
            robot_problem = robot_problem or f"point {u.of_point((x, y))}: {reason}"
    # ... and far enough inside the ring that the patient's straying from the path does not
    # take the handle out of the safety supervisor's band (a fault mid-trial)
    band_lo, band_hi = path_band_m(robot)
    radius = np.hypot(points[:, 0], points[:, 1])
    outside_band = robot_ok & ((radius < band_lo) | (radius > band_hi))
    if outside_band.any() and not robot_problem:
        i = int(np.argmin(radius)) if radius.min() < band_lo else int(np.argmax(radius))
        shift = band_lo - radius[i] if radius[i] < band_lo else radius[i] - band_hi
        shift = math.ceil(shift * 1000.0) / 1000.0  # to the mm above, never "0.000 m"
        toward = "away from" if radius[i] < band_lo else "toward"
        robot_problem = (
            f"point {u.of_point(points[i])} is {u.of_length(radius[i])} from the robot's "
            f"motor axes; a path must stay {u.of_length(band_lo)}–{u.of_length(band_hi)} "
            f"from them (the safety stop's {u.of_length(WORKSPACE_MARGIN_M)} inside the "
            f"robot's reach, and {u.of_length(PATH_TRACKING_ALLOWANCE_M)} for the hand "
            f"straying from the path). Move the exercise's centre at least "
            f"{u.of_length(shift, 1)} {toward} the robot's motors, or make it "
            "smaller."
        )
    robot_ok &= ~outside_band
    if robot_problem:
        problems.append(robot_problem)

    # Arm: within reach, with the elbow neither straight nor folded.
    dx = points[:, 0] - arm.shoulder_x_m
    dy = points[:, 1] - arm.shoulder_y_m
    distance = np.hypot(dx, dy)
    flex_lo, flex_hi = ELBOW_FLEXION_RANGE_RAD
    far = arm.reach_at_elbow_flexion(flex_lo)
    near = arm.reach_at_elbow_flexion(flex_hi)
    arm_ok = (distance <= far) & (distance >= near)
    if not arm_ok.all():
        worst = int(np.argmax(distance)) if distance.max() > far else int(np.argmin(distance))
        x, y = points[worst]
        d = distance[worst]
        if d > arm.reach_max_m:
            # one decimal more when the two would read the same ("0.61 m … reaches 0.61 m")
            more = int(u.of_length(d) == u.of_length(arm.reach_max_m))
            problems.append(
                f"point {u.of_point((x, y))} is {u.of_length(d, more)} from the shoulder; this "
                f"arm reaches {u.of_length(arm.reach_max_m, more)}. Move the exercise or the "
                "shoulder closer together."
            )
        elif d > far:
            problems.append(
                f"point {u.of_point((x, y))} is {u.of_length(d, 1)} from the shoulder; the arm "
                f"would be almost straight there (elbow bent less than "
                f"{math.degrees(flex_lo):.0f}°, reach {u.of_length(far, 1)}). Move the exercise "
                "or the shoulder closer together."
            )
        else:
            problems.append(
                f"point {u.of_point((x, y))} is only {u.of_length(d)} from the shoulder; the "
                f"elbow would bend more than {math.degrees(flex_hi):.0f}° (closest "
                f"{u.of_length(near)}). "
                "Move the exercise away from the shoulder."
            )

    peak = trajectory.peak_speed_m_s
    if peak > MAX_PATH_SPEED_M_S:
        problems.append(
            f"the path's peak speed would be {u.of_speed(peak)}; keep it at most "
            f"{u.of_speed(MAX_PATH_SPEED_M_S)} by giving one traversal more time or a smaller "
            f"radius (path {u.of_length(trajectory.path.length)} in "
            f"{parameters.duration_s:g} s)."
        )

    ts, te = arm.ik_terms(points[:, 0], points[:, 1])
    isb = np.column_stack(arm.isb_terms(ts, te))
    isb[~arm_ok] = np.nan
    robot_angles = np.column_stack((q1, q2))
    robot_angles[~robot_ok] = np.nan
    return TrialCheck(
        parameters, points, robot_ok, arm_ok, tuple(problems), robot_angles, isb,
        distance, trajectory.path.length, peak, arm,
    )
