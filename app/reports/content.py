"""What a trial's report says and shows, as plain data: the header, the patient's
lines, the change since earlier trials, the therapist's table and the arrays of
the thesis's report figures (section 3.6: Fig. 3.7, 3.9, 3.11, 3.12). The PDF
(app.reports.pdf) and the window's report view draw the same `ReportContent`, so
they cannot disagree.

Only the exercise phase counts (app.trials.analysis): the figures and the plots start
when the exercise starts (time 0 on the plots) and leave out the approach to the
start point and the hold at the end.

Fig. 3.9's blue and red runs: every sample is within (the push points within
the tolerance of the path's direction) or outside; sensor noise flips a sample
now and then, which would draw thousands of specks. Runs shorter than
`min_run_s` (50 ms, or 1/400 of the exercise when that is longer, about the
width of a dash on the page) are merged into the runs around them, shortest
first, for the drawing only: the percentage is computed from every sample.
"""

from __future__ import annotations

import datetime
import heapq
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.errors import AppError, TrialFileError
from app.reports.compare import (
    Baseline,
    BaselineSource,
    Comparison,
    TableRow,
    as_baseline,
    compare,
    date_text,
    metric_text,
    table_rows,
)
from app.reports.metrics_table import ROWS
from app.reports.plain_language import (
    SHAPE_NAMES,
    PlainLine,
    plain_lines,
    status_sentence,
)
from app.trials.analysis import analyse, exercise_mask
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
from device.recording.trialfile import STATUS_RECORDING

MIN_RUN_S = 0.05
OUTLINE_SPACING_M = 0.002
RUNS_PER_AXIS = 400
MIN_EXERCISE_SAMPLES = 64  # app.trials.analysis refuses fewer
_ROW_BY_KEY = {row.key: row for row in ROWS}
_NUMBERS_IN_NAME = re.compile(r"_S(\d{3,})_T(\d{3,})_")

STATUS_WORDS = {
    "complete": "complete",
    "stopped_early": "stopped early (by the therapist or the stop button)",
    "faulted": "ended by a safety fault",
    "recording_lost": "recording lost: the file holds only part of the trial",
    STATUS_RECORDING: "not closed: still being recorded, or the recorder stopped unexpectedly",
}
TIMING_WORDS = {"constant_speed": "steady speed", "minimum_jerk": "smooth start and stop"}


# -- the data ----------------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class HeaderItem:
    label: str
    value: str


@dataclass(frozen=True, slots=True)
class Run:
    """Samples start…stop (inclusive; the next run starts at this one's stop, so the
    drawn lines join) all within the tolerance, or all outside it."""

    within: bool
    start: int
    stop: int


@dataclass(frozen=True, slots=True, eq=False)
class PathFigure:
    """Fig. 3.7: the hand's path against the target, in the global frame (m).
    flip_axes: draw both axes reversed, as the thesis shows them — the view from
    the patient's chair (docs/frames.md: the patient sits on +y facing −y)."""

    position_m: np.ndarray
    desired_m: np.ndarray
    outline_m: np.ndarray  # the whole exercise's path, also where the trial did not reach
    runs: tuple[Run, ...]
    flip_axes: bool
    caption: str


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
class ReportContent:
    """Everything a trial's report shows. Arrays are SI and cover the exercise phase;
    texts are ready to print (display units). Figures are None when the trial has no
    exercise to show (it ended before the exercise began) or lacks the channel."""

    source: Path
    title: str
    patient_code: str
    first_name: str | None
    session_number: int | None
    trial_number: int | None
    started_at: datetime.datetime | None
    status: str
    header: tuple[HeaderItem, ...]
    status_text: str  # for the patient; '' when the trial is complete
    faults: tuple[str, ...]
    simulated: bool
    plain: tuple[PlainLine, ...]
    comparisons: tuple[Comparison, ...]
    table: tuple[TableRow, ...]
    table_columns: tuple[str, ...]  # one per comparison, after "This trial"
    path: PathFigure | None
    force: ForceFigure | None
    angles: AnglesFigure | None
    torques: TorquesFigure | None
    metrics: TrialMetrics | None
    notes: tuple[str, ...]
    exercise_start_s: float
    exercised_s: float  # exercise time recorded
    planned_s: float  # exercise time the parameters asked for
    peak_force_N: float  # largest |F| of the exercise; NaN without a force channel


# -- building it -------------------------------------------------------------------------

def build_report(
    trial: TrialData,
    *,
    previous_trial: BaselineSource | None = None,
    previous_session: BaselineSource | None = None,
    first_name: str | None = None,
    flip_axes: bool = False,
    patient_code: str | None = None,
    session_number: int | None = None,
    trial_number: int | None = None,
    started_at: datetime.datetime | None = None,
    status: str | None = None,
) -> ReportContent:
    """The report of a read trial file.

    previous_trial, previous_session: what to compare with (a TrialData, a registry
    Trial, a Baseline, or a mapping of metric names to SI values); None leaves the
    comparison out. first_name appears only when given here: the report never looks
    a name up by itself. patient_code, session_number, trial_number, started_at and
    status override what the file says (the registry knows them better); the numbers
    default to those in the file's name (app.records.datadir.trial_stem).
    """
    parameters = trial.parameters
    if parameters is None:
        raise TrialFileError(
            trial.path, "has no trial parameters that this console can use "
            f"({'; '.join(trial.notes) or 'none stored'}), and the report needs them",
            "Restore the file from the backup, or re-record the trial",
        )
    channels = trial.channels
    for name in ("time", "phase", "position"):
        if name not in channels:
            raise TrialFileError(trial.path, f"has no '{name}' channel",
                                 "Restore the file from the backup, or re-record the trial")
    status = status or trial.status or "unknown"
    mask = exercise_mask(channels)
    n_exercise = int(mask.sum())
    notes = [f"trial file: {note}" for note in trial.notes]
    metrics: TrialMetrics | None = None
    exercise_start = math.nan
    if n_exercise >= MIN_EXERCISE_SAMPLES:
        try:
            analysis = analyse(channels, parameters)
        except (CoreError, AppError, ValueError) as exc:
            raise TrialFileError(
                trial.path, f"holds data that cannot be analysed ({exc})",
                "Check the recording; restore the file from the backup if it is damaged",
            ) from exc
        metrics = analysis.metrics
        exercise_start = analysis.exercise_start_s
        notes += analysis.notes
    else:
        notes.append(f"only {n_exercise} samples of exercise were recorded (at least "
                     f"{MIN_EXERCISE_SAMPLES} are needed), so the trial has no figures")
    values = metrics.to_dict() if metrics is not None else {}
    figures = _Figures()
    if metrics is not None:
        figures = _figures(trial, parameters, _Series(trial, mask, exercise_start), metrics,
                           flip_axes)
        notes += figures.notes
    comparisons = _comparisons(previous_trial, previous_session, values, parameters,
                               partial=status != "complete")

    numbers = _NUMBERS_IN_NAME.search(trial.path.name)
    if session_number is None and numbers:
        session_number = int(numbers.group(1))
    if trial_number is None and numbers:
        trial_number = int(numbers.group(2))
    started_at = started_at or _file_time(trial)
    if started_at is not None and started_at.tzinfo is not None:
        started_at = started_at.astimezone()  # the clinic's clock, not UTC
    code = patient_code or (trial.subject.code if trial.subject is not None else "unknown")
    faults = tuple(f"{e['time_s']:.2f} s: {e['message']}" for e in trial.events
                   if e.get("kind") == "fault")
    exercised_s = n_exercise * trial.sample_period_s
    planned_s = parameters.duration_s * parameters.repetitions
    simulated = trial.backend.startswith("simulator")

    return ReportContent(
        source=trial.path,
        title="Trial report",
        patient_code=code,
        first_name=first_name,
        session_number=session_number,
        trial_number=trial_number,
        started_at=started_at,
        status=status,
        header=_header(code, first_name, session_number, trial_number, started_at,
                       parameters, status, faults, trial.backend, exercised_s, planned_s),
        status_text=status_sentence(status, exercised_s, planned_s),
        faults=faults,
        simulated=simulated,
        plain=plain_lines(values, peak_force_N=figures.peak_force_N) if values else (),
        comparisons=comparisons,
        table=table_rows(values, tuple(c.baseline for c in comparisons)) if values else (),
        table_columns=tuple(_column_title(c) for c in comparisons),
        path=figures.path,
        force=figures.force,
        angles=figures.angles,
        torques=figures.torques,
        metrics=metrics,
        notes=tuple(notes),
        exercise_start_s=exercise_start,
        exercised_s=exercised_s,
        planned_s=planned_s,
        peak_force_N=figures.peak_force_N,
    )


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


# -- pieces ------------------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class _Figures:
    path: PathFigure | None = None
    force: ForceFigure | None = None
    angles: AnglesFigure | None = None
    torques: TorquesFigure | None = None
    peak_force_N: float = math.nan
    notes: tuple[str, ...] = ()


def _figures(trial: TrialData, parameters: TrialParameters, series: _Series,
             metrics: TrialMetrics, flip_axes: bool) -> _Figures:
    runs, min_run = _runs(series, parameters, metrics)
    notes = ()
    if runs:
        notes = (f"the path and Fig. 3.9 draw runs shorter than {min_run * 1000:.0f} ms in "
                 "the colour around them; the percentage counts every sample",)
    peak = math.nan
    if series.force is not None:
        peak = float(np.max(np.hypot(series.force[:, 0], series.force[:, 1])))
    return _Figures(
        _path_figure(series, runs, metrics, flip_axes, parameters),
        _force_figure(series, runs, metrics),
        _angles_figure(series, metrics),
        _torques_figure(series, metrics, trial.sample_period_s),
        peak,
        notes,
    )


def _comparisons(previous_trial: BaselineSource | None, previous_session: BaselineSource | None,
                 values: dict[str, float], parameters: TrialParameters, *,
                 partial: bool) -> tuple[Comparison, ...]:
    baselines: list[tuple[str, Baseline]] = []
    for kind, source in (("previous trial", previous_trial),
                         ("previous session", previous_session)):
        baseline = as_baseline(source)
        if baseline is not None:
            baselines.append((kind, baseline))
    if len(baselines) == 2 and baselines[0][1].same_trial(baselines[1][1]):
        # Trial 1 of a session: its previous trial is the last of the previous session.
        baselines = [("previous trial, the last of your previous session", baselines[0][1])]
    return tuple(compare(kind, baseline, values, parameters, partial=partial)
                 for kind, baseline in baselines)


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
    min_run = max(MIN_RUN_S, float(series.t[-1] - series.t[0]) / RUNS_PER_AXIS)
    return merge_short_runs(series.t, within, min_run), min_run


def _text(key: str, value_si: float) -> str:
    return metric_text(_ROW_BY_KEY[key], value_si)


def _path_figure(series: _Series, runs: tuple[Run, ...], metrics: TrialMetrics,
                 flip_axes: bool, parameters: TrialParameters) -> PathFigure | None:
    if series.position is None or series.desired is None:
        return None
    parts = [f"Position error (RMSE): x {_text('rmse_x_m', metrics.rmse_x_m)}, "
             f"y {_text('rmse_y_m', metrics.rmse_y_m)}"]
    if math.isfinite(metrics.directional_performance_pct):
        parts.append(f"Directional performance (±{math.degrees(metrics.tolerance_rad):.0f}°): "
                     f"{_text('directional_performance_pct', metrics.directional_performance_pct)}")
    outline = parameters.path().points(OUTLINE_SPACING_M)
    return PathFigure(series.position, series.desired, outline, runs, flip_axes,
                      " · ".join(parts))


def _force_figure(series: _Series, runs: tuple[Run, ...],
                  metrics: TrialMetrics) -> ForceFigure | None:
    if series.force is None:
        return None
    tolerance = f"{math.degrees(metrics.tolerance_rad):.0f}°"
    x_range = _text("force_range_x_N", metrics.force_range_x_N)
    y_range = _text("force_range_y_N", metrics.force_range_y_N)
    return ForceFigure(
        series.t, series.force, runs,
        (f"Hand's force on the handle, x — range {x_range}",
         f"Hand's force on the handle, y — range {y_range}"),
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


def _exercise_text(p: TrialParameters) -> str:
    shape = SHAPE_NAMES.get(p.shape, p.shape)
    radius = f"{p.radius_m * 100:.3g} cm"
    size = {
        "reach": f"straight reach of {p.radius_m * 200:.3g} cm",
        "targets": f"{p.n_targets} targets {radius} from the centre",
        "figure8": f"figure eight of two {radius} loops",
    }.get(p.shape, f"{shape}, radius {radius}")
    laps = "1 repetition" if p.repetitions == 1 else f"{p.repetitions} repetitions"
    turn = "" if p.shape in ("reach", "targets", "figure8") else \
        (", clockwise" if p.clockwise else ", anticlockwise")
    return (f"{size}; {laps} of {p.duration_s:g} s, "
            f"{TIMING_WORDS.get(p.timing, p.timing)}{turn}")


def _settings_text(p: TrialParameters) -> str:
    return (f"{p.controller.upper()} controller, assistance level {p.assistance_level * 100:.0f} %"
            f", direction tolerance ±{math.degrees(p.tolerance_rad):.0f}°; centre "
            f"({p.centre_m[0] * 1000:.0f}, {p.centre_m[1] * 1000:.0f}) mm, shoulder "
            f"({p.shoulder_m[0] * 1000:.0f}, {p.shoulder_m[1] * 1000:.0f}) mm, {p.side} arm")


def _header(code: str, first_name: str | None, session: int | None, number: int | None,
            started_at: datetime.datetime | None, p: TrialParameters, status: str,
            faults: tuple[str, ...], backend: str, exercised_s: float,
            planned_s: float) -> tuple[HeaderItem, ...]:
    who = f"{code} ({first_name})" if first_name else code
    trial_words = ", ".join(part for part in (
        f"session {session}" if session is not None else "",
        f"trial {number}" if number is not None else "",
        (f"{date_text(started_at.date())}, {started_at:%H:%M}"
         if started_at is not None else ""),
    ) if part)
    status_words = STATUS_WORDS.get(status, status)
    if status != "complete":
        status_words += f" — {exercised_s:.1f} s of {planned_s:g} s of exercise recorded"
    items = [
        HeaderItem("Patient", who),
        HeaderItem("Trial", trial_words or "–"),
        HeaderItem("Exercise", _exercise_text(p)),
        HeaderItem("Settings", _settings_text(p)),
        HeaderItem("Robot", backend or "–"),
        HeaderItem("Status", status_words),
    ]
    items += [HeaderItem("Fault", fault) for fault in faults]
    return tuple(items)


def _column_title(comparison: Comparison) -> str:
    described = comparison.baseline.describe()
    title = "Previous session" if comparison.kind == "previous session" else "Previous trial"
    return f"{title} ({described})" if described else title


def _file_time(trial: TrialData) -> datetime.datetime | None:
    try:
        moment = datetime.datetime.fromisoformat(trial.created_utc)
    except ValueError:
        return None
    return moment.astimezone() if moment.tzinfo is not None else moment
