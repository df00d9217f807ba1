"""From a trial's recorded channels to its metrics: which samples count, and how the
recorded arrays map onto `core.metrics.compute_metrics`.

Only the exercise phase counts (not the approach to the start point, not the hold
at the end). Samples where the subject model had no solution (NaN joint angles,
e.g. an arm stretched straight) leave the joint figures out rather than the whole
trial, and the note says so.

`analyse` works on channels held in memory; `analyse_stored` reads them a block at a time
(core.blockwise), for a headless trial too long to hold (issue 13 #21), to the same
figures within rounding.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from functools import cache

import numpy as np

from app.assessments.figures import assessment_figures, assessment_figures_stored
from app.errors import AppError
from app.games.figures import game_figures, game_figures_stored
from app.trials.reader import TrialData
from core import blockwise
from core.blockwise import compute_metrics_blockwise, spans
from core.control.own import own_shares, own_torque
from core.errors import CoreError
from core.games import GameFigures
from core.metrics import TrialMetrics, compute_metrics
from core.reaches import reaches_from_trajectory
from core.robot import RobotModel
from core.robot_record import robot_from_record
from core.trial import TrialParameters
from device.loop.pipeline import PERIOD_S, PHASE_EXERCISE


@dataclass(frozen=True, slots=True)
class Analysis:
    metrics: TrialMetrics
    exercise_start_s: float
    notes: tuple[str, ...]
    game: GameFigures | None = None
    """A game trial's figures (app.games.figures), None for an exercise without a game."""
    assessment: dict[str, float] | None = None
    """An assessment trial's task figures keyed as core.assessment.FIGURES
    (app.assessments.figures), None for an exercise."""

    def to_metrics(self) -> dict[str, float]:
        """The trial's metrics as the file and the registry store them: the movement's
        figures, and a game's 'game_*' or an assessment task's figures beside them."""
        return {**self.metrics.to_dict(), **(self.game.to_metrics() if self.game else {}),
                **(self.assessment or {})}


ANALYSIS = "2026-12-06"
"""Which analysis this is: the date of the last change to what it computes of a trial (a
figure added or defined anew), as a re-analysis's note names it (app.trials.reanalyse).
Changed with the figures. 2026-12-05: the robot's share of the work counts its help alone
(`robot_help_work_J`, core.work); 2026-12-06: the robot's own torque on the model the trial
ran (its file's `robot`, core.robot_record)."""

CHANNELS_USED = ("time", "phase", "position", "position_desired", "direction_desired", "force",
                 "subject_angle",
                 "subject_angle_isb", "subject_torque", "torque_applied", "robot_angle",
                 "torque_commanded", "torque_controller", "robot_rate", "robot_acceleration")
"""The recorded channels `analyse` reads (a long trial's analysis reads only these back)."""


def exercise_mask(channels: Mapping[str, np.ndarray]) -> np.ndarray:
    return np.asarray(channels["phase"]) == PHASE_EXERCISE


MIN_EXERCISE = 64


def too_little_exercise(n_exercise: int) -> str:
    """The one sentence for a trial whose exercise phase is too short to measure (a fault
    in the approach): the analysis refuses it with it, an in-memory task trial
    (app.assessments.runner) and a report (app.reports.content) note it."""
    return (f"the trial has only {n_exercise} samples of exercise; at least {MIN_EXERCISE} "
            f"({MIN_EXERCISE * PERIOD_S:.2f} s) are needed for its figures")


def _no_value(name: str, count: int) -> str:
    return f"{name} has {count} samples without a value; its figures are left out"


def analyse(channels: Mapping[str, np.ndarray], parameters: TrialParameters,
            robot: RobotModel | None = None) -> Analysis:
    """Metrics of the exercise phase of a recorded trial (channels by record name), on the
    robot model it ran (`robot`; None: the default RobotModel, the one the console runs)."""
    mask = exercise_mask(channels)
    notes: list[str] = []
    n_exercise = int(mask.sum())
    if n_exercise < MIN_EXERCISE:
        raise AppError(too_little_exercise(n_exercise))
    mask = _as_slice(mask, n_exercise)
    t = np.asarray(channels["time"])[mask]
    start = float(t[0])

    def take(name: str):
        values = np.asarray(channels[name])[mask]
        if np.isfinite(values).all():
            return values
        notes.append(_no_value(name, int((~np.isfinite(values)).any(axis=-1).sum())))
        return None

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
        robot_own_torque_Nm=robots_own_torque(
            lambda name: np.asarray(channels[name])[mask], channels, parameters, robot),
        help_torque_Nm=help_torque(channels, mask) if parameters.assist == "as-needed" else None,
        tolerance_rad=parameters.tolerance_rad,
        reaches=_reaches(parameters, start),
    )
    task, task_notes = assessment_figures(channels, parameters, mask)
    return Analysis(metrics, start, (*notes, *task_notes), game_figures(channels, parameters),
                    task or None)


def _reaches(parameters: TrialParameters, start_s: float):
    """The reaches of a targets or reach exercise, their onsets in the trial's time."""
    if parameters.shape not in ("targets", "reach"):
        return None
    return [replace(r, onset_s=r.onset_s + start_s)
            for r in reaches_from_trajectory(parameters.trajectory())]


ReadStretch = Callable[[str, int, int], np.ndarray]
"""Samples first…stop−1 of a recorded channel (TrialFileWriter.read_stretch)."""
ROLES = (("desired_position_m", "position_desired"), ("desired_direction", "direction_desired"),
         ("force_N", "force"), ("isb_angles_rad", "subject_angle_isb"),
         ("torque_Nm", "subject_torque"), ("robot_torque_Nm", "torque_applied"),
         ("robot_angle_rad", "robot_angle"))
"""compute_metrics' arguments and the channels `analyse` gives them, in its order."""


def analyse_stored(read: ReadStretch, n_ticks: int, names: Sequence[str],
                   parameters: TrialParameters, *, block: int | None = None,
                   robot: RobotModel | None = None) -> Analysis:
    """`analyse` of a trial of n_ticks whose channels (`names`) are read a block of `block`
    samples at a time, for a trial too long to hold (core.blockwise: the same figures
    to rounding, without Fig. 3.9's intervals; the same notes). An exercise phase with a
    gap is analysed whole, as `analyse` does. `block` None: core.blockwise.BLOCK; `robot`
    as `analyse`'s."""
    block = block or blockwise.BLOCK
    first, n = _exercise_run(read, n_ticks, block)
    if n < 0:
        return analyse({name: read(name, 0, n_ticks) for name in CHANNELS_USED
                        if name in names}, parameters, robot)
    if n < MIN_EXERCISE:
        raise AppError(too_little_exercise(n))

    def stretch(name: str, a: int, b: int) -> np.ndarray:
        return np.asarray(read(name, first + a, first + b), dtype=float)

    notes: list[str] = []
    channel = {"t_s": "time", "position_m": "position"}
    for role, name in ROLES:
        if name not in names:
            continue
        missing = sum(int((~np.isfinite(stretch(name, a, b))).any(axis=-1).sum())
                      for a, b in spans(n, block))
        if missing:
            notes.append(_no_value(name, missing))
        else:
            channel[role] = name
    own = all(name in names for name in OWN_CHANNELS) and all(
        robots_own_torque(lambda name, a=a, b=b: stretch(name, a, b), names, parameters,
                          robot) is not None for a, b in spans(n, block))
    help_channels = ("torque_commanded", "torque_controller")
    helped = parameters.assist == "as-needed" and all(h in names for h in help_channels)
    if helped:
        helped = all(np.isfinite(stretch(help_channels[0], a, b)
                                 - stretch(help_channels[1], a, b)).all()
                     for a, b in spans(n, block))

    def read_role(role: str, a: int, b: int) -> np.ndarray:
        if role == "help_torque_Nm":
            return stretch(help_channels[0], a, b) - stretch(help_channels[1], a, b)
        if role == "robot_own_torque_Nm":
            return robots_own_torque(lambda name: stretch(name, a, b), names, parameters,
                                     robot)
        return stretch(channel[role], a, b)

    start = float(stretch("time", 0, 1)[0])
    given = [*channel, *(["help_torque_Nm"] if helped else []),
             *(["robot_own_torque_Nm"] if own else [])]
    metrics = compute_metrics_blockwise(read_role, n, given,
                                        tolerance_rad=parameters.tolerance_rad,
                                        reaches=_reaches(parameters, start), block=block)
    task, task_notes = assessment_figures_stored(read, n_ticks, names, parameters)
    return Analysis(metrics, start, (*notes, *task_notes),
                    game_figures_stored(read, n_ticks, parameters, block), task or None)


def _exercise_run(read: ReadStretch, n_ticks: int, block: int) -> tuple[int, int]:
    """(first tick, ticks) of the exercise phase read a block at a time; (0, −1) when it
    is not one run of ticks."""
    first, count, last = -1, 0, -1
    for a, b in spans(n_ticks, block):
        ticks = np.flatnonzero(np.asarray(read("phase", a, b)) == PHASE_EXERCISE)
        if len(ticks):
            first = a + int(ticks[0]) if first < 0 else first
            last = a + int(ticks[-1])
            count += len(ticks)
    if count and last - first + 1 != count:
        return 0, -1
    return max(first, 0), count


def _as_slice(mask: np.ndarray, n_true: int) -> np.ndarray | slice:
    """The exercise phase is one run of ticks: taken as a slice, the channels are views,
    not copies (a long trial's analysis held each exercise channel twice, issue 13 #21).
    A mask with gaps stays a mask."""
    first = int(np.argmax(mask))
    if mask[first:first + n_true].all():
        return slice(first, first + n_true)
    return mask


def help_torque(channels: Mapping[str, np.ndarray], mask: np.ndarray):
    """The as-needed robot's help along the path at the joints: what it commanded beyond
    its channel and transparency torques (core.control.guidance), over the exercise."""
    if "torque_commanded" not in channels or "torque_controller" not in channels:
        return None
    helped = (np.asarray(channels["torque_commanded"])[mask]
              - np.asarray(channels["torque_controller"])[mask])
    return helped if np.isfinite(helped).all() else None


OWN_CHANNELS = ("robot_angle", "robot_rate", "robot_acceleration")
"""The recorded channels the robot's own share of its torque is recomputed from."""


@cache  # the live view asks at every batch
def _model_constants(robot: RobotModel | None = None) -> tuple:
    """The constants of the model a trial ran: `robot`, or the default RobotModel (the
    console's, device.loop.plan) for None. The one place the analysis builds its model."""
    return tuple((robot or RobotModel()).constants)


def robots_own_torque(read: Callable[[str], np.ndarray], names, parameters: TrialParameters,
                      robot: RobotModel | None = None):
    """The part of the motors' torque the trial's mode spent on the robot's own dynamics
    (core.control.own) for the samples `read(name)` gives of the channels in `names`, on
    the model the trial ran (`robot`; None: the default RobotModel); None when a channel it
    needs is missing or not finite (the help's work and the robot's share are then NaN)."""
    if not all(name in names for name in OWN_CHANNELS):
        return None
    own = own_torque(_model_constants(robot),
                     own_shares(parameters.assist, parameters.gains),
                     *(read(name) for name in OWN_CHANNELS))
    return own if np.isfinite(own).all() else None


def robot_of(data: TrialData) -> tuple[RobotModel | None, tuple[str, ...]]:
    """The robot model the trial file says it ran (its `robot` description,
    core.robot_record), None for the default one; and a note when the file's description
    is not a model this console reads (then the default is used, and the note says so)."""
    if not data.robot:
        return None, ()
    try:
        robot = robot_from_record(data.robot)
    except CoreError as exc:
        return None, (f"the file's robot description is not a robot model this console reads "
                      f"({exc}); the robot's own torque is that of the default model",)
    return (None if robot == RobotModel() else robot), ()


def analyse_data(data: TrialData) -> Analysis:
    """`analyse` of a trial read from its file (app.trials.reader.read_trial): its
    parameters and the robot model it ran, as the file records them: the analysis a
    finished trial gets (app.trials.finalize), a study's (app.study.rows) and a
    re-analysis's (app.trials.reanalyse). AppError when the file holds no parameters this
    console can use, or too little exercise."""
    if data.parameters is None:
        raise AppError("the file holds no trial parameters this console can use")
    robot, notes = robot_of(data)
    analysis = analyse(data.channels, data.parameters, robot)
    return replace(analysis, notes=(*notes, *analysis.notes)) if notes else analysis
