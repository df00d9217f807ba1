"""A trial's check (core.trial_check.check_trial) as the Parameters tab shows it: the picture of
what can be reached, the summary under it, and each problem under the field to change.

The picture is in cm, like the fields: where the robot's handle can go, the
circles the arm reaches comfortably, the path split into what can and cannot be
reached (with a cross about every centimetre where it cannot), its start, and
the range that frames the exercise, the shoulder and the robot's base.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from app.assessments.words import robot_task_words
from app.units import CM_PER_M as CM, MM_S_PER_M_S
from core.holdtasks import ROBOT_TASKS
from core.robot import RobotModel
from core.trial_check import (
    ELBOW_FLEXION_RANGE_RAD,
    MAX_PATH_SPEED_M_S,
    TrialCheck,
    path_band_m,
)
from ui.views.samples import split_by_mask

UNREACHABLE_MARK_EVERY = 5  # path points are 2 mm apart
PREVIEW_MARGIN_CM = 8.0
REACH_CIRCLE_POINTS = 181


@functools.cache
def robot_workspace(robot: RobotModel, step_m: float = 0.005) -> tuple[np.ndarray, tuple]:
    """Where the robot's handle can go, as a mask on a grid (x along axis 0) and the
    rectangle it covers, (x, y, width, height) in m. Computed once per robot: it
    never changes."""
    extent = robot.reach_max_m + step_m
    xs = np.arange(-extent, extent + step_m / 2, step_m)
    x, y = np.meshgrid(xs, xs, indexing="ij")
    q1, q2 = robot.ik_terms(x, y)
    # where a path may lie: inside the reach band the trial check keeps (the safety margin
    # and the room to stray from the path), within the joint limits
    band_lo, band_hi = path_band_m(robot)
    radius = np.hypot(x, y)
    ok = np.isfinite(q1) & np.isfinite(q2) & (radius >= band_lo) & (radius <= band_hi)
    for i in np.flatnonzero(ok):
        if robot.limit_problem(float(q1.flat[i]), float(q2.flat[i])):
            ok.flat[i] = False
    half = step_m / 2
    rect = (xs[0] - half, xs[0] - half, xs.size * step_m, xs.size * step_m)
    return ok, rect


@dataclass(frozen=True, slots=True, eq=False)
class ReachPicture:
    """What the preview draws for one check, in cm; (n, 2) arrays of x, y. The path's
    two lines hold NaN where the other draws (ui.views.samples.split_by_mask)."""

    reach_far_cm: np.ndarray  # the arm's reach with the elbow least flexed
    reach_near_cm: np.ndarray  # ... and most flexed
    reachable_cm: np.ndarray
    unreachable_cm: np.ndarray
    crosses_cm: np.ndarray
    start_cm: np.ndarray  # (2,)
    x_range_cm: tuple[float, float]
    y_range_cm: tuple[float, float]


def reach_picture(check: TrialCheck, shoulder_m: tuple[float, float]) -> ReachPicture:
    sx, sy = (v * CM for v in shoulder_m)
    arm = check.arm
    angles = np.linspace(0.0, 2.0 * math.pi, REACH_CIRCLE_POINTS)
    circles = []
    for flexion in ELBOW_FLEXION_RANGE_RAD:
        r = arm.reach_at_elbow_flexion(flexion) * CM
        circles.append(np.column_stack((sx + r * np.cos(angles), sy + r * np.sin(angles))))
    points = check.points_m * CM
    ok = check.reachable
    # Each line also draws the point after it changes, so the two meet.
    inside, outside = split_by_mask(points, np.repeat(ok[:, None], 2, axis=1))
    # A cross every centimetre or so: at the path's 2 mm spacing they would merge.
    bad = np.flatnonzero(~ok)[::UNREACHABLE_MARK_EVERY]
    # Frame the exercise, the shoulder and the robot's base; the reach circles may
    # run off the edge, the exercise must not.
    box = np.vstack((points, [[sx, sy], [0.0, 0.0]]))
    low, high = box.min(axis=0) - PREVIEW_MARGIN_CM, box.max(axis=0) + PREVIEW_MARGIN_CM
    return ReachPicture(circles[0], circles[1], inside, outside, points[bad], points[0],
                        (low[0], high[0]), (low[1], high[1]))


def check_summary(check: TrialCheck) -> str:
    """The path's length and speed, and the joint ranges it asks for (ISB, degrees); a
    task the robot leads its timetable instead (app.assessments.words: "Path 80 cm per
    traversal, fastest 0 mm/s" was said of a hand held still), with the joints' ranges
    where the robot takes the hand (position sense)."""
    task = check.parameters.assessment
    if task in ROBOT_TASKS:
        words = robot_task_words(check.parameters)
        text = f"{words[0].upper()}{words[1:]}."
        if task == "strength":
            return text
    else:
        text = (f"Path {check.path_length_m * CM:.0f} cm per traversal, fastest "
                f"{check.peak_speed_m_s * MM_S_PER_M_S:.0f} mm/s.")
    if check.reachable.any():
        sh = [math.degrees(v) for v in check.range_of(check.isb_angles_rad[:, 0])]
        el = [math.degrees(v) for v in check.range_of(check.isb_angles_rad[:, 1])]
        text += (f" The shoulder will move {sh[0]:.0f}° to {sh[1]:.0f}°, the elbow "
                 f"{el[0]:.0f}° to {el[1]:.0f}° (ISB).")
    return text


def field_key(field: str) -> str:
    """A TrialParameters field (as ParameterError names it) to the row showing it."""
    name = field.split("[")[0]
    return {
        "centre_m": "centre", "shoulder_m": "shoulder", "radius_m": "radius",
        "duration_s": "duration", "body_mass_kg": "body_mass", "upper_arm_m": "upper_arm",
        "forearm_m": "forearm", "tolerance_rad": "tolerance", "assistance_level": "assistance",
        "force_estimate_sha256": "force_estimate",
    }.get(name, name)


def problem_fields(check: TrialCheck) -> list[tuple[str, str]]:
    """Each of check_trial's problems with the row(s) it belongs under. check_trial lists
    the robot's reach first, then the arm's, then the speed."""
    problems = list(check.problems)
    placed = []
    if problems and not check.robot_ok.all():
        placed.append(("centre", problems.pop(0)))
    if problems and not check.arm_ok.all():
        message = problems.pop(0)
        placed += [("centre", message), ("shoulder", message)]
    if problems and check.peak_speed_m_s > MAX_PATH_SPEED_M_S:
        placed.append(("duration", problems.pop(0)))
    placed += [("shape", message) for message in problems]
    return placed
