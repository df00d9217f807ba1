"""The arrays and captions of the report's figures (thesis section 3.6): the hand's path
against the target (Fig. 3.7), the force on the handle in blue/red runs (Fig. 3.9),
the ISB joint angles (Fig. 3.11) and the joint torques (Fig. 3.12), as plain data
over the exercise phase (part of app.reports.content.ReportContent), which the PDF
draws (app.reports.pdf_plots).

Fig. 3.9's blue and red runs: every sample is within (the push points within
the tolerance of the path's direction) or outside; sensor noise flips a sample
now and then, which would draw thousands of specks. Runs shorter than
`min_run_s` (50 ms, or 1/400 of the exercise when that is longer, about the
width of a dash on the page) are merged into the runs around them, shortest
first, for the drawing only: the percentage is computed from every sample.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np

from app.errors import AppError
from app.reports.compare import metric_text
from app.reports.metrics_table import ROW_BY_KEY
from app.reports.plain_language import own_pace_task
from app.trials.analysis import help_torque
from app.trials.reader import TrialData
from core.errors import CoreError
from core.metrics import (
    DEFAULT_FILTER_ORDER,
    DEFAULT_MIN_FORCE_N,
    DEFAULT_TORQUE_CUTOFF_HZ,
    TrialMetrics,
    directional_performance,
)
from core.signal import lowpass
from core.trial import TrialParameters
from core.work import helped_samples

MIN_RUN_S = 0.05
OUTLINE_SPACING_M = 0.002
RUNS_PER_AXIS = 400


@dataclass(frozen=True, slots=True)
class Run:
    """Samples start…stop (inclusive; the next run starts at this one's stop, so the
    drawn lines join) all within the tolerance, or all outside it."""

    within: bool
    start: int
    stop: int


@dataclass(frozen=True, slots=True, eq=False)
class PathFigure:
    """Fig. 3.7: the hand's path against the target, in the global frame (m), for the
    patient's page, which draws it as the patient sees it (docs/frames.md: the patient
    sits on +y facing −y, so both axes reversed, as the thesis's Fig. 3.7 shows it).

    runs: the stretches of the hand's path in the mode's own terms, `run_labels` saying
    what a run `within` and one outside mean: in the thesis mode the push within the
    tolerance of the path's direction (Fig. 3.9's runs); in the as-needed mode where the
    patient led and where the robot helped along the path (core.metrics.led_pct)."""

    position_m: np.ndarray
    desired_m: np.ndarray
    outline_m: np.ndarray  # the whole exercise's path, also where the trial did not reach
    runs: tuple[Run, ...]
    run_labels: tuple[str, str]


@dataclass(frozen=True, slots=True, eq=False)
class ForceFigure:
    """Fig. 3.9: the hand's force Fx, Fy (N) over the exercise, in blue/red runs."""

    t_s: np.ndarray
    force_N: np.ndarray
    runs: tuple[Run, ...]
    titles: tuple[str, str]
    within_label: str
    outside_label: str
    caption: str


@dataclass(frozen=True, slots=True, eq=False)
class AnglesFigure:
    """Fig. 3.11: ISB shoulder and elbow angles (rad, eq. 3.37–3.38) with their ROM."""

    t_s: np.ndarray
    isb_rad: np.ndarray
    labels: tuple[str, str]


@dataclass(frozen=True, slots=True, eq=False)
class TorquesFigure:
    """Fig. 3.12: shoulder and elbow torques (N·m), raw and low-passed, with ranges."""

    t_s: np.ndarray
    raw_Nm: np.ndarray
    smoothed_Nm: np.ndarray
    labels: tuple[str, str]
    caption: str


@dataclass(frozen=True, slots=True, eq=False)
class EmgFigure:
    """Chapter 5: each muscle's RMS envelope in % MVC over the exercise, on the torques' time
    axis, and one line per muscle on its MVC's quality."""

    t_s: np.ndarray
    percent: np.ndarray  # (N, muscles)
    muscles: tuple[str, ...]
    quality: tuple[str, ...]
    names: tuple[str, ...] = ()
    """The muscles in words, as the EMG tab names them (app.emg.muscle_words: 'biceps
    brachii', where the page said 'biceps' beside the tab's 'biceps brachii')."""


def emg_figure(trial: TrialData, mask: np.ndarray, start_s: float) -> EmgFigure | None:
    """The EMG figure of a trial with EMG and an MVC per muscle, else None."""
    from app.emg.importing import EmgImportError
    from app.emg.muscle_words import words
    from app.emg.mvc_words import long_flags
    from app.emg.session import trial_envelopes
    from device.errors import DeviceError
    from device.recording.emgfile import read_emg

    try:
        if read_emg(trial.path) is None:
            return None
        env = trial_envelopes(trial.path)
    except (EmgImportError, DeviceError, CoreError):
        return None
    quality = tuple(f"{words(m)}: MVC "
                    + (long_flags(env.flags[m]) if env.flags[m] else "sound")
                    for m in env.muscles)
    t = np.asarray(trial.channels["time"], dtype=float)[mask] - start_s
    return EmgFigure(t, 100.0 * env.values[mask], env.muscles, quality,
                     tuple(words(m) for m in env.muscles))


@dataclass(frozen=True, slots=True, eq=False)
class FeedforwardFigure:
    """The as-needed mode's learned feedforward (core.control.guidance): the force along
    the path it had learned in each bin of one repetition, at the end of each repetition
    (the trial file's /assistance/feedforward_N), and the levels the trial ran at."""

    percent_of_repetition: np.ndarray  # (bins,) the bins' centres, % of one repetition
    force_N: np.ndarray  # (repetitions finished, bins)
    limit_N: float
    levels: str  # '100 % → 60 % at 5.8 s' (app.trials.assistance_timeline)


def feedforward_figure(trial: TrialData) -> FeedforwardFigure | None:
    """The learned feedforward of an as-needed trial that finished a repetition, else None
    (the thesis mode learns none)."""
    assistance = trial.assistance
    history = np.asarray(assistance.get("feedforward_N", np.empty((0, 0))), dtype=float)
    if history.ndim != 2 or history.size == 0:
        return None
    finished = history[np.isfinite(history).all(axis=1)]
    if finished.shape[0] == 0:
        return None
    bins = history.shape[1]
    return FeedforwardFigure((np.arange(bins) + 0.5) / bins * 100.0, finished,
                             float(assistance.get("feedforward_limit_N", math.nan)),
                             trial.assistance_in_effect().summary())


@dataclass(frozen=True, slots=True, eq=False)
class PoseFigure:
    """Thesis Table 3.4 as a figure: the camera's ISB angles beside the equation solver's
    over the exercise, and the shoulder's drift the solver assumes away (the trial file's
    /pose, written by `rehab pose`), with the comparison in words."""

    t_s: np.ndarray
    solver_isb_rad: np.ndarray  # (N, 2)
    camera_isb_rad: np.ndarray  # (N, 2), NaN in the camera's gaps
    drift_m: np.ndarray  # (N,)
    drift_limit_m: float
    lines: tuple[str, ...]


def pose_figure(trial: TrialData, mask: np.ndarray, start_s: float) -> PoseFigure | None:
    """The pose figure of a trial `rehab pose` ran on, else None."""
    from app.pose.store import comparison_lines, read_pose

    if not trial.path.is_file() or "subject_angle_isb" not in trial.channels:
        return None
    try:
        pose = read_pose(trial.path)
    except AppError:
        return None  # the report's notes say why (content)
    if pose is None:
        return None
    t = np.asarray(trial.channels["time"], dtype=float)[mask] - start_s
    return PoseFigure(t, np.asarray(trial.channels["subject_angle_isb"], dtype=float)[mask],
                      np.asarray(pose["angle_isb"], dtype=float)[mask],
                      np.asarray(pose["shoulder_drift"], dtype=float)[mask],
                      float(pose["attrs"].get("shoulder_drift_limit_m", math.nan)),
                      tuple(comparison_lines(pose)))


def merge_short_runs(t_s: np.ndarray, within: np.ndarray, min_run_s: float) -> tuple[Run, ...]:
    """The runs of equal `within`, with every run shorter than `min_run_s` merged into
    its neighbours, shortest first (see the module's doc). Sample k holds over
    [t_k, t_{k+1}), as in core.metrics.directional_performance."""
    within = np.asarray(within, dtype=bool)
    n = within.size
    if n == 0:
        return ()
    change = np.flatnonzero(within[1:] != within[:-1]) + 1
    starts = np.concatenate(([0], change)).tolist()
    ends = np.concatenate((change, [n - 1])).tolist()  # a run's last drawn sample
    t = np.asarray(t_s, dtype=float)
    state = [bool(within[s]) for s in starts]
    duration = [float(t[e] - t[s]) for s, e in zip(starts, ends, strict=True)]
    count = len(starts)
    previous = list(range(-1, count - 1))
    following = [*range(1, count), -1]
    alive = [True] * count
    heap = [(d, i) for i, d in enumerate(duration) if d < min_run_s]
    heapq.heapify(heap)
    while heap:
        d, i = heapq.heappop(heap)
        if not alive[i] or d != duration[i]:
            continue  # merged away, or grown since it was queued
        before, after = previous[i], following[i]
        if before == -1 and after == -1:
            break  # the only run left
        # Flipping the run joins it to both neighbours (they hold the other state).
        keep = before if before != -1 else after
        first = before if before != -1 else i
        last = after if after != -1 else i
        starts[keep], ends[keep] = starts[first], ends[last]
        for gone in {first, i, last} - {keep}:
            alive[gone] = False
        duration[keep] = float(t[ends[keep]] - t[starts[keep]])
        previous[keep] = previous[first]
        following[keep] = following[last]
        if previous[keep] != -1:
            following[previous[keep]] = keep
        if following[keep] != -1:
            previous[following[keep]] = keep
        if duration[keep] < min_run_s:
            heapq.heappush(heap, (duration[keep], keep))
    return tuple(Run(state[i], starts[i], ends[i]) for i in range(count) if alive[i])


@dataclass(frozen=True, slots=True)
class Figures:
    """The report's figures of one trial (None where a channel is missing), the peak
    force and the notes about how they are drawn."""

    path: PathFigure | None = None
    force: ForceFigure | None = None
    angles: AnglesFigure | None = None
    torques: TorquesFigure | None = None
    peak_force_N: float = math.nan
    emg: EmgFigure | None = None
    notes: tuple[str, ...] = ()
    feedforward: FeedforwardFigure | None = None
    pose: PoseFigure | None = None


def report_figures(trial: TrialData, parameters: TrialParameters, mask: np.ndarray,
                   start_s: float, metrics: TrialMetrics) -> Figures:
    """The figures of a trial whose exercise (the samples in `mask`, from `start_s`)
    was analysed into `metrics`."""
    series = _Series(trial, mask, start_s)
    runs, min_run = _runs(series, parameters, metrics)
    own_pace = own_pace_task(parameters)
    notes = ()
    if runs and not own_pace:  # a task the patient paces draws no runs (below)
        # the therapist's page: a sentence in plain words, no figure numbers (it read "the
        # path and Fig. 3.9 draw runs shorter than 51 ms in the colour around them")
        notes = (f"In the drawings of the path and of the force, a colour that lasts less "
                 f"than {min_run * 1000:.0f} ms is drawn in the colour around it, so the "
                 "lines stay readable; the percentage counts every moment.",)
    peak = math.nan
    if series.force is not None:
        peak = float(np.max(np.hypot(series.force[:, 0], series.force[:, 1])))
    path_runs, labels = runs, DIRECTION_RUN_LABELS
    if own_pace:
        # the push's direction along a reference on the task's clock says nothing of a
        # patient moving at their own pace: the hand's path in one line
        path_runs = ()
    elif parameters.assist == "as-needed":
        path_runs, labels = (), LED_RUN_LABELS
        help_torque_Nm = help_torque(trial.channels, mask)
        if help_torque_Nm is not None:
            path_runs = merge_short_runs(series.t, ~helped_samples(help_torque_Nm),
                                         _min_run(series))
    return Figures(
        _path_figure(series, path_runs, labels, parameters),
        _force_figure(series, runs, metrics, own_pace=own_pace),
        _angles_figure(series, metrics),
        _torques_figure(series, metrics, trial.sample_period_s),
        peak,
        notes=notes,
        emg=emg_figure(trial, mask, start_s),
        feedforward=feedforward_figure(trial),
        pose=pose_figure(trial, mask, start_s),
    )


# -- pieces ------------------------------------------------------------------------------

class _Series:
    """The exercise phase's arrays; a channel that is missing is None."""

    def __init__(self, trial: TrialData, mask: np.ndarray, start_s: float) -> None:
        channels = trial.channels

        def take(name: str) -> np.ndarray | None:
            values = channels.get(name)
            return None if values is None else np.asarray(values, dtype=float)[mask]

        self.t = np.asarray(channels["time"], dtype=float)[mask] - start_s
        self.position = take("position")
        self.desired = take("position_desired")
        self.direction = take("direction_desired")
        self.force = take("force")
        self.isb = take("subject_angle_isb")
        self.torque = take("subject_torque")


def _finite(values: np.ndarray | None) -> bool:
    return values is not None and bool(np.isfinite(values).all())


def _runs(series: _Series, parameters: TrialParameters,
          metrics: TrialMetrics) -> tuple[tuple[Run, ...], float]:
    if not (_finite(series.force) and _finite(series.direction)):
        return (), MIN_RUN_S
    min_force = metrics.min_force_N if math.isfinite(metrics.min_force_N) \
        else DEFAULT_MIN_FORCE_N
    within = directional_performance(series.t, series.force, series.direction,
                                     parameters.tolerance_rad, min_force).within
    min_run = _min_run(series)
    return merge_short_runs(series.t, within, min_run), min_run


def _min_run(series: _Series) -> float:
    return max(MIN_RUN_S, float(series.t[-1] - series.t[0]) / RUNS_PER_AXIS)


def _text(key: str, value_si: float) -> str:
    return metric_text(ROW_BY_KEY[key], value_si)


DIRECTION_RUN_LABELS = ("your hand: pushing the right way", "your hand: pushing another way")
LED_RUN_LABELS = ("your hand: you led", "your hand: the robot helped you along")


def _path_figure(series: _Series, runs: tuple[Run, ...],
                 labels: tuple[str, str], parameters: TrialParameters) -> PathFigure | None:
    if series.position is None or series.desired is None:
        return None
    outline = parameters.path().points(OUTLINE_SPACING_M)
    return PathFigure(series.position, series.desired, outline, runs, labels)


OWN_PACE_FORCE = ("the hand's push, in one line: its direction along the task's reference "
                  "(on the task's clock) says nothing of a patient moving at their own pace")
"""Fig. 3.9's caption for a task the patient paces (plain_language.own_pace_task), in place
of the share of time within the tolerance of the reference's direction."""


def _force_figure(series: _Series, runs: tuple[Run, ...], metrics: TrialMetrics, *,
                  own_pace: bool = False) -> ForceFigure | None:
    """Fig. 3.9; for a task the patient paces (`own_pace`) the force in one line, without
    the directional performance (app.reports.task_table: nor in the therapist's table)."""
    if series.force is None:
        return None
    tolerance = f"{math.degrees(metrics.tolerance_rad):.0f}°"
    x_range = _text("force_range_x_N", metrics.force_range_x_N)
    y_range = _text("force_range_y_N", metrics.force_range_y_N)
    titles = (f"Hand's force on the handle, x — range {x_range}",
              f"Hand's force on the handle, y — range {y_range}")
    if own_pace:
        return ForceFigure(series.t, series.force, (), titles, "", "", OWN_PACE_FORCE)
    return ForceFigure(
        series.t, series.force, runs, titles,
        f"push within ±{tolerance} of the path's direction",
        f"outside ±{tolerance}, or weaker than {metrics.min_force_N:.2f} N",
        f"within ±{tolerance} for "
        f"{_text('directional_performance_pct', metrics.directional_performance_pct)} of the "
        "exercise time (directional performance)",
    )


def _angles_figure(series: _Series, metrics: TrialMetrics) -> AnglesFigure | None:
    if series.isb is None or not np.isfinite(series.isb).any():
        return None
    return AnglesFigure(series.t, series.isb, (
        f"Shoulder (ISB), range of motion {_text('shoulder_rom_rad', metrics.shoulder_rom_rad)}",
        f"Elbow (ISB), range of motion {_text('elbow_rom_rad', metrics.elbow_rom_rad)}",
    ))


def _torques_figure(series: _Series, metrics: TrialMetrics,
                    dt_s: float) -> TorquesFigure | None:
    if series.torque is None or not np.isfinite(series.torque).any():
        return None
    try:
        smoothed = lowpass(series.torque, dt_s, DEFAULT_TORQUE_CUTOFF_HZ, DEFAULT_FILTER_ORDER,
                           nan_policy="interpolate", name="subject_torque")
    except CoreError:
        smoothed = np.full_like(series.torque, np.nan)  # too short to filter
    labels = tuple(
        f"{joint.capitalize()} — range {_text(f'{joint}_torque_range_Nm', raw)} raw, "
        f"{_text(f'{joint}_torque_range_smoothed_Nm', smooth)} smoothed"
        for joint, raw, smooth in (
            ("shoulder", metrics.shoulder_torque_range_Nm,
             metrics.shoulder_torque_range_smoothed_Nm),
            ("elbow", metrics.elbow_torque_range_Nm, metrics.elbow_torque_range_smoothed_Nm),
        )
    )
    return TorquesFigure(
        series.t, series.torque, smoothed, labels,
        f"Raw (faint) and low-passed at {DEFAULT_TORQUE_CUTOFF_HZ:g} Hz, zero lag (bold)",
    )
