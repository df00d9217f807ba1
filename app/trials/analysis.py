"""From a trial's recorded channels to its metrics: which samples count, and how the
recorded arrays map onto `core.metrics.compute_metrics`.

Only the exercise phase counts (not the approach to the start point, not the hold
at the end). Samples where the subject model had no solution (NaN joint angles,
e.g. an arm stretched straight) leave the joint figures out rather than the whole
trial, and the note says so.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from app.errors import AppError
from core.metrics import TrialMetrics, compute_metrics
from core.reaches import reaches_from_trajectory
from core.trial import TrialParameters
from device.loop.pipeline import PHASE_EXERCISE


@dataclass(frozen=True, slots=True)
class Analysis:
    metrics: TrialMetrics
    exercise_start_s: float
    notes: tuple[str, ...]


CHANNELS_USED = ("time", "phase", "position", "position_desired", "direction_desired", "force",
                 "subject_angle_isb", "subject_torque", "torque_applied", "robot_angle",
                 "torque_commanded", "torque_controller")
"""The recorded channels `analyse` reads (a long trial's analysis reads only these back)."""


def exercise_mask(channels: Mapping[str, np.ndarray]) -> np.ndarray:
    return np.asarray(channels["phase"]) == PHASE_EXERCISE


def analyse(channels: Mapping[str, np.ndarray], parameters: TrialParameters) -> Analysis:
    """Metrics of the exercise phase of a recorded trial (channels by record name)."""
    mask = exercise_mask(channels)
    notes: list[str] = []
    n_exercise = int(mask.sum())
    if n_exercise < 64:
        raise AppError(
            f"the trial has only {n_exercise} samples of exercise; "
            "at least 64 (0.13 s) are needed for its figures"
        )
    mask = _as_slice(mask, n_exercise)
    t = np.asarray(channels["time"])[mask]
    start = float(t[0])

    def take(name: str):
        values = np.asarray(channels[name])[mask]
        if np.isfinite(values).all():
            return values
        notes.append(f"{name} has {int((~np.isfinite(values)).any(axis=-1).sum())} samples "
                     "without a value; its figures are left out")
        return None

    trajectory = parameters.trajectory()
    reaches = None
    if parameters.shape in ("targets", "reach"):
        reaches = reaches_from_trajectory(trajectory)
        reaches = [replace(r, onset_s=r.onset_s + start) for r in reaches]
    metrics = compute_metrics(
        t,
        np.asarray(channels["position"])[mask],
        desired_position_m=take("position_desired"),
        desired_direction=take("direction_desired"),
        force_N=take("force"),
        isb_angles_rad=take("subject_angle_isb"),
        torque_Nm=take("subject_torque"),
        robot_torque_Nm=take("torque_applied") if "torque_applied" in channels else None,
        robot_angle_rad=take("robot_angle") if "robot_angle" in channels else None,
        help_torque_Nm=_help(channels, mask) if parameters.assist == "as-needed" else None,
        tolerance_rad=parameters.tolerance_rad,
        reaches=reaches,
    )
    return Analysis(metrics, start, tuple(notes))


def _as_slice(mask: np.ndarray, n_true: int) -> np.ndarray | slice:
    """The exercise phase is one run of ticks: taken as a slice, the channels are views,
    not copies (a long trial's analysis held each exercise channel twice, issue 13 #21).
    A mask with gaps stays a mask."""
    first = int(np.argmax(mask))
    if mask[first:first + n_true].all():
        return slice(first, first + n_true)
    return mask


def _help(channels: Mapping[str, np.ndarray], mask: np.ndarray):
    """The as-needed robot's help along the path at the joints: what it commanded beyond
    its channel and transparency torques (core.control.guidance), over the exercise."""
    if "torque_commanded" not in channels or "torque_controller" not in channels:
        return None
    helped = (np.asarray(channels["torque_commanded"])[mask]
              - np.asarray(channels["torque_controller"])[mask])
    return helped if np.isfinite(helped).all() else None
