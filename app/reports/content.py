"""What a trial's report says and shows, as plain data: the header, the patient's
lines, the change since earlier trials, the therapist's table and the arrays of
the thesis's report figures (section 3.6: Fig. 3.7, 3.9, 3.11, 3.12). The PDF
(app.reports.pdf) and the window's report view draw the same `ReportContent`, so
they cannot disagree.

Only the exercise phase counts (app.trials.analysis): the figures and the plots start
when the exercise starts (time 0 on the plots) and leave out the approach to the
start point and the hold at the end. The figures' arrays and captions are built
by app.reports.figures; this module adds the texts around them.
"""

from __future__ import annotations

import datetime
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from app.assessments.words import (
    TURN_WORDS,
    laps_words,
    planned_exercise_s,
    robot_doing,
    robot_task_words,
)
from app.errors import AppError, TrialFileError
from app.games.figures import game_line, staircase_text
from app.games.names import game_title
from app.learning.library import learned_label
from app.pose.store import comparison_lines, read_pose
from app.reports.compare import (
    Baseline,
    BaselineSource,
    Comparison,
    TableRow,
    as_baseline,
    compare,
    date_text,
    table_rows,
)
from app.reports.figures import (
    AnglesFigure,
    EmgFigure,
    FeedforwardFigure,
    Figures,
    ForceFigure,
    PathFigure,
    PoseFigure,
    TorquesFigure,
    report_figures,
)
from app.reports.plain_game import game_result_line
from app.reports.plain_language import (
    SHAPE_NAMES,
    PlainLine,
    help_text,
    patient_mode,
    plain_lines,
    robot_only_lightened,
    seconds_text,
    status_sentence,
)
from app.reports.plain_task import task_lines
from app.reports.task_table import task_order
from app.trials.analysis import MIN_EXERCISE, analyse, exercise_mask, too_little_exercise
from app.trials.assistance_timeline import AssistanceInEffect
from app.trials.reader import TrialData
from app.units import CM_PER_M, assistance_percent, point_cm
from core.assessment.figures import TASK_TITLES
from core.errors import CoreError, capitalised
from core.holdtasks import ROBOT_TASKS
from core.metrics import TrialMetrics
from core.trial import TrialParameters
from device.recording.trialfile import STATUS_RECORDING
from device.safety.faults import Fault

ESTOP_CAUSE = Fault.ESTOP.banner().split(" — ")[0]

_NUMBERS_IN_NAME = re.compile(r"_S(\d{3,})_T(\d{3,})_")

PATIENT_STATUS_WORDS = {
    "complete": "at its end",
    "stopped_early": "stopped early",
    "faulted": "stopped by the robot",
    "recording_lost": "recording lost",
    STATUS_RECORDING: "recording not finished",
}
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
    """The patient's header: the trial, the exercise, the robot's help, how it ended, in
    plain words (no coordinates, seeds, instructions or file names)."""
    therapist_header: tuple[HeaderItem, ...]
    """The therapist's: every setting with the positions, the robot (a simulator's seed),
    how the trial ended, each fault with what to do, the file."""
    status_text: str  # for the patient; '' when the trial is complete
    faults: tuple[str, ...]
    simulated: bool
    mode: str  # the assistance mode (core.trial.ASSIST_MODES)
    levels: AssistanceInEffect  # the levels it ran at (app.trials.assistance_timeline)
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
    emg: EmgFigure | None = None  # chapter 5: % MVC envelopes, when the trial has EMG
    feedforward: FeedforwardFigure | None = None  # as-needed: the help learned per repetition
    pose: PoseFigure | None = None  # the camera against the solver, after `rehab pose`
    assessment: object | None = None
    """An assessment trial's task page (app.reports.assessment_page.AssessmentPage: its
    figures, Z-scores and task score), for a registered trial of a task."""


# -- building it -------------------------------------------------------------------------

def build_report(
    trial: TrialData,
    *,
    previous_trial: BaselineSource | None = None,
    previous_session: BaselineSource | None = None,
    first_name: str | None = None,
    patient_code: str | None = None,
    session_number: int | None = None,
    trial_number: int | None = None,
    started_at: datetime.datetime | None = None,
    status: str | None = None,
    end_reason: str = "",
    least_change: Mapping[str, float] | None = None,
) -> ReportContent:
    """The report of a read trial file.

    previous_trial, previous_session: what to compare with (a TrialData, a registry
    Trial, a Baseline, or a mapping of metric names to SI values); None leaves the
    comparison out. first_name appears only when given here: the report never looks
    a name up by itself. patient_code, session_number, trial_number, started_at and
    status override what the file says (the registry knows them better); the numbers
    default to those in the file's name (app.records.datadir.trial_stem). end_reason,
    the registry's words for why the trial ended, is shown as a fault when the file
    does not hold it (a dead recorder, a full disk). least_change: the figures' minimal
    detectable changes (SI, the norms' MDC95), within which the table's comparison says
    "about the same" (compare.table_rows).
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
    game_values: dict[str, float] = {}
    exercise_start = math.nan
    if n_exercise >= MIN_EXERCISE:
        try:
            analysis = analyse(channels, parameters)
        except (CoreError, AppError, ValueError) as exc:
            raise TrialFileError(
                trial.path, f"holds data that cannot be analysed ({exc})",
                "Check the recording; restore the file from the backup if it is damaged",
            ) from exc
        metrics = analysis.metrics
        game_values = analysis.game.to_metrics() if analysis.game else {}
        exercise_start = analysis.exercise_start_s
        notes += analysis.notes
    else:
        notes.append(too_little_exercise(n_exercise))
    values = metrics.to_dict() if metrics is not None else {}
    task_values = (analysis.assessment or {}) if metrics is not None else {}
    figures = Figures()
    if metrics is not None:
        figures = report_figures(trial, parameters, mask, exercise_start, metrics)
        notes += figures.notes
    levels = trial.assistance_in_effect()
    comparisons = _comparisons(previous_trial, previous_session, values, parameters,
                               partial=status != "complete", levels=levels)
    if figures.pose is not None:
        notes += list(figures.pose.lines)  # read once, with the figure
    elif trial.path.is_file():
        try:
            notes += comparison_lines(read_pose(trial.path))  # `rehab pose` ran on its video
        except AppError as exc:
            notes.append(str(exc))

    numbers = _NUMBERS_IN_NAME.search(trial.path.name)
    if session_number is None and numbers:
        session_number = int(numbers.group(1))
    if trial_number is None and numbers:
        trial_number = int(numbers.group(2))
    started_at = started_at or _file_time(trial)
    if started_at is not None and started_at.tzinfo is not None:
        started_at = started_at.astimezone()  # the clinic's clock, not UTC
    code = patient_code or (trial.subject.code if trial.subject is not None else "unknown")
    fault_events = [e for e in trial.events if e.get("kind") == "fault"]
    faults = tuple(f"{e['time_s']:.2f} s: {e['message']}" for e in fault_events)
    if end_reason and not any(fault.endswith(end_reason) for fault in faults):
        faults += (end_reason,)
    emergency_stop = any((e.get("values") or {}).get("fault") == Fault.ESTOP.label
                         for e in fault_events) or end_reason.startswith(ESTOP_CAUSE)
    exercised_s = n_exercise * trial.sample_period_s
    planned_s = planned_exercise_s(parameters)
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
                       parameters, levels, status, emergency_stop, exercised_s, planned_s,
                       game_line(parameters.to_dict(), game_values)),
        therapist_header=_therapist_header(parameters, levels, status, faults, trial.backend,
                                           exercised_s, planned_s, trial.path),
        status_text=status_sentence(status, exercised_s, planned_s,
                                    emergency_stop=emergency_stop),
        faults=faults,
        simulated=simulated,
        mode=parameters.assist,
        levels=levels,
        plain=_plain(values, parameters, task_values, figures.peak_force_N,
                     game_values) if values else (),
        comparisons=comparisons,
        # an assessment task's table: its own figures, none against the reference
        # (app.reports.task_table)
        table=table_rows({**values, **task_values}, tuple(c.baseline for c in comparisons),
                         mode=parameters.assist,
                         comparable=tuple(c.comparable for c in comparisons),
                         only_lightened=robot_only_lightened(parameters),
                         order=task_order(parameters.assessment, parameters.assist)
                         if parameters.assessment else None,
                         least_change=least_change) if values else (),
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
        emg=figures.emg,
        feedforward=figures.feedforward,
        pose=figures.pose,
    )


# -- pieces ------------------------------------------------------------------------------

def _comparisons(previous_trial: BaselineSource | None, previous_session: BaselineSource | None,
                 values: dict[str, float], parameters: TrialParameters, *,
                 partial: bool, levels: AssistanceInEffect) -> tuple[Comparison, ...]:
    baselines: list[tuple[str, str, Baseline]] = []
    # the earlier trials are of the same shape (app.reports.build): say so
    shape = SHAPE_NAMES.get(parameters.shape, parameters.shape)
    for kind, label, source in ((f"previous {shape} trial", "Last trial", previous_trial),
                                (f"previous session's {shape} trial", "Last session",
                                 previous_session)):
        baseline = as_baseline(source)
        if baseline is not None:
            baselines.append((kind, label, baseline))
    if len(baselines) == 2 and baselines[0][2].same_trial(baselines[1][2]):
        # Trial 1 of a session: its previous trial is the last of the previous session.
        baselines = [(f"previous {shape} trial, the last of your previous session",
                      "Last trial (last session)", baselines[0][2])]
    return tuple(compare(kind, baseline, values, parameters, partial=partial, levels=levels,
                         label=label)
                 for kind, label, baseline in baselines)


def _exercise_text(p: TrialParameters) -> str:
    """What the trial was: its shape and size, laps and pace; an assessment task's or a
    game's name first ('Circle drawing (assessment): circle, radius 7 cm; …'), so that a
    report of the battery's circle never reads as the circle exercise."""
    if p.assessment:
        return (f"{TASK_TITLES.get(p.assessment, p.assessment)} (assessment): "
                f"{_movement_text(p)}")
    if p.game:
        return f"{game_title(p.game)}: {_movement_text(p)}"
    return _movement_text(p)


def _movement_text(p: TrialParameters) -> str:
    if p.assessment in ROBOT_TASKS:
        return robot_task_words(p, past=True)
    shape = SHAPE_NAMES.get(p.shape, p.shape)
    radius = f"{p.radius_m * CM_PER_M:.3g} cm"
    size = {
        "reach": f"straight reach of {2 * p.radius_m * CM_PER_M:.3g} cm",
        "targets": f"{p.n_targets} targets {radius} from the centre",
        "figure8": f"figure eight of two {radius} loops",
    }.get(p.shape, f"{shape}, radius {radius}")
    # a task's rounds or laps as the Assessments tab says them; an exercise's repetitions
    # as the Parameters form names them
    laps = laps_words(p) if p.assessment else \
        f"{p.repetitions} repetition{'s' if p.repetitions != 1 else ''} of {p.duration_s:g} s"
    turn = "" if p.shape in ("reach", "targets", "figure8") else f", {TURN_WORDS[p.clockwise]}"
    return f"{size}; {laps}, {TIMING_WORDS.get(p.timing, p.timing)}{turn}"


CONTROLLER_WORDS = {"smc": "SMC", "ctpid": "CT-PID"}


MODE_WORDS = {"as-needed": "as-needed", "thesis": "thesis-mode", "transparent": "transparent"}


def _settings_text(p: TrialParameters, levels: AssistanceInEffect) -> str:
    # positions in the form's unit (app.units): the therapist compares them with it
    controller = learned_label(p.learned_model) if p.learned_model else \
        CONTROLLER_WORDS.get(p.controller, p.controller)
    if p.assist == "transparent":
        # no level to say: nothing acts on one (core.control.transparent)
        help_words = (f"{controller} controller on the approach and hold, transparent "
                      "exercise (no assistance)")
    else:
        help_words = (f"{controller} controller, {MODE_WORDS.get(p.assist, p.assist)} "
                      f"assistance at {levels.summary()} (built at "
                      f"{assistance_percent(p.assistance_level)})")
    return (f"{help_words}, direction tolerance ±{math.degrees(p.tolerance_rad):.0f}°; centre "
            f"{point_cm(p.centre_m)}, shoulder {point_cm(p.shoulder_m)}, {p.side} arm")


def _trial_words(session: int | None, number: int | None,
                 started_at: datetime.datetime | None) -> str:
    return ", ".join(part for part in (
        f"session {session}" if session is not None else "",
        f"trial {number}" if number is not None else "",
        (f"{date_text(started_at.date())}, {started_at:%H:%M}"
         if started_at is not None else ""),
    ) if part) or "–"


def _plain(values: dict[str, float], parameters: TrialParameters,
           task_values: dict[str, float], peak_force_N: float,
           game_values: dict[str, float]) -> tuple[PlainLine, ...]:
    """The patient's lines: an assessment trial's task figures in words first
    (app.reports.plain_task), a game's result (app.reports.plain_game: what the patient
    played for), then what every trial has (plain_language.plain_lines; a strength trial's
    firmest push is its task's line, not said twice)."""
    task = getattr(parameters, "assessment", "") or ""
    own = task_lines(task, task_values) if task else ()
    game = game_result_line(parameters.game, game_values) if parameters.game else None
    own += (game,) if game is not None else ()
    peak = math.nan if task == "strength" else peak_force_N
    lines = plain_lines(values, mode=patient_mode(parameters), peak_force_N=peak,
                        only_lightened=robot_only_lightened(parameters))
    if parameters.game:
        # a game shows its own targets or channel, never the moving ring the distance is
        # measured from (ui.views.patient_screen): a patient read how near they kept to
        # a ring they had not seen; the figure stays on the therapist's page
        lines = tuple(line for line in lines if line.key != "rmse")
    return own + lines


def _header(code: str, first_name: str | None, session: int | None, number: int | None,
            started_at: datetime.datetime | None, p: TrialParameters, levels: AssistanceInEffect,
            status: str, emergency_stop: bool, exercised_s: float,
            planned_s: float, game: str = "") -> tuple[HeaderItem, ...]:
    """The patient's header (ReportContent.header); a game trial's score, hits, misses and
    time (app.games.figures.game_line) after the exercise."""
    who = f"{code} ({first_name})" if first_name else code
    ended = "stopped with the emergency stop" if emergency_stop else \
        PATIENT_STATUS_WORDS.get(status, status)
    if status != "complete":
        ended += f" after {seconds_text(exercised_s)} of {seconds_text(planned_s)} s"
    return (
        HeaderItem("Patient", who),
        HeaderItem("Trial", _trial_words(session, number, started_at)),
        HeaderItem("Exercise", _exercise_text(p)),
        *([HeaderItem("Game", game)] if game else []),
        # a task the robot leads: what it did, not what its mode's help would mean
        HeaderItem("Robot's help", f"{levels.summary()} ({robot_doing(p, past=True)})"
                   if p.assessment in ROBOT_TASKS else help_text(p.assist, levels)),
        HeaderItem("Ended", ended),
    )


def _therapist_header(p: TrialParameters, levels: AssistanceInEffect, status: str,
                      faults: tuple[str, ...], backend: str, exercised_s: float,
                      planned_s: float, source: Path) -> tuple[HeaderItem, ...]:
    """The therapist's header (ReportContent.therapist_header)."""
    status_words = STATUS_WORDS.get(status, status)
    if status != "complete":
        status_words += f" — {exercised_s:.1f} s of {planned_s:g} s of exercise recorded"
    items = [
        HeaderItem("Settings", _settings_text(p, levels)),
        HeaderItem("Robot", backend or "–"),
        HeaderItem("Status", status_words),
    ]
    if p.staircase:
        items.append(HeaderItem("Difficulty", staircase_text(p.staircase)))
    items += [HeaderItem("Fault", fault) for fault in faults]
    items.append(HeaderItem("File", source.name))
    return tuple(items)


def _column_title(comparison: Comparison) -> str:
    """'Previous D shape trial (session 2, trial 1, 9 May 2024)', with '; not compared'
    when the trials do not compare (the patient's page says the same, and why)."""
    details = [comparison.baseline.describe()]
    if not comparison.comparable:
        details.append("not compared")
    detail = "; ".join(d for d in details if d)
    title = capitalised(comparison.kind)
    return f"{title} ({detail})" if detail else title


def _file_time(trial: TrialData) -> datetime.datetime | None:
    try:
        moment = datetime.datetime.fromisoformat(trial.created_utc)
    except ValueError:
        return None
    return moment.astimezone() if moment.tzinfo is not None else moment
