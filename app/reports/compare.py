"""A trial against an earlier one: which figures went which way, and whether the two
compare at all.

Two trials compare only when both ran the whole exercise at the same settings: a trial
cut short (stopped, faulted, e-stopped) covers only part of the exercise, and another
size, pace, tolerance, mode or help from the robot (the levels the trials ran at,
app.trials.assistance_timeline, not the ones they were built with) changes what the
figures mean.
Otherwise the numbers are shown side by side with the reason, and no verdict: neither
page of the report, nor the window, calls such a change better or worse (issue 27).

Better or worse depends on the figure: a smaller position error is better, a
higher directional performance is better; for ranges of motion, forces and
torques the goal depends on the patient and the exercise (the thesis, section
3.6.3: the goal "may" be to increase them), so they are said to be more or
less, never better or worse.

The patient's lines compare the numbers as the patient sees them, rounded (whole
%, mm, degrees): two numbers that print the same are "the same", so the report
never calls 78 % → 78 % better. The therapist's table compares at its own
precision (two decimals).
"""

from __future__ import annotations

import datetime
import enum
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from app.records.registry import Trial
from app.reports.metrics_table import ROWS, MetricRow, number_text
from app.reports.plain_game import game_cautions
from app.reports.plain_language import (
    change_sentence,
    distance_mm_shown,
    distance_text,
    help_caution,
    parameter_cautions,
    patient_mode,
    position_error_m,
    success_key,
    whole,
)
from app.trials.assistance_timeline import AssistanceInEffect
from app.trials.reader import TrialData
from app.units import MM_PER_M
from core.assessment import FIGURES
from core.errors import capitalised
from core.trial import TrialParameters


class Goal(enum.Enum):
    HIGHER = "higher"
    LOWER = "lower"
    TOWARD_ONE = "toward one"
    NONE = "none"


GOALS: dict[str, Goal] = {
    "rmse_x_m": Goal.LOWER,
    "rmse_y_m": Goal.LOWER,
    "directional_performance_pct": Goal.HIGHER,
    "path_length_ratio": Goal.TOWARD_ONE,
    # Both are negative; closer to 0 is smoother (core.smoothness).
    "sparc": Goal.HIGHER,
    "ldlj": Goal.HIGHER,
    "reaction_time_s": Goal.LOWER,
    "initial_direction_error_rad": Goal.LOWER,
    "led_pct": Goal.HIGHER,
    "rmse": Goal.LOWER,
}
"""Which way is better for a figure (TrialMetrics names); an assessment task's figure
goes the way its catalogue says (core.assessment.FIGURES, `goal_of`); any other figure has
no better or worse, only more or less."""


def goal_of(key: str) -> Goal:
    """Which way is better for figure `key`: GOALS, else the task catalogue's `better`."""
    if key in GOALS:
        return GOALS[key]
    spec = FIGURES.get(key)
    return Goal(spec.better) if spec is not None and spec.better != "none" else Goal.NONE

UP, DOWN, SAME = "↑", "↓", "="
NOISE_ARROW = "≈"


@dataclass(frozen=True, slots=True)
class Baseline:
    """What a trial is compared with: an earlier trial's figures (TrialMetrics.to_dict()
    names, SI) and, when known, its parameters (TrialParameters.to_dict()) and numbers."""

    metrics: Mapping[str, float]
    parameters: Mapping | None = None
    session_number: int | None = None
    trial_number: int | None = None
    date: datetime.date | None = None
    levels: AssistanceInEffect | None = None
    """The assistance levels the earlier trial ran at; None when not known."""

    def describe(self) -> str:
        """'session 2, trial 3, 1 May 2024', from what is known."""
        parts = []
        if self.session_number is not None:
            parts.append(f"session {self.session_number}")
        if self.trial_number is not None:
            parts.append(f"trial {self.trial_number}")
        if self.date is not None:
            parts.append(date_text(self.date))
        return ", ".join(parts)

    def same_trial(self, other: Baseline) -> bool:
        return (self.session_number is not None and self.trial_number is not None
                and (self.session_number, self.trial_number)
                == (other.session_number, other.trial_number))


BaselineSource = Baseline | TrialData | Trial | Mapping


def as_baseline(source: BaselineSource | None) -> Baseline | None:
    """A Baseline from a read trial file, a registry record, or a plain metrics mapping
    (figures only: no parameters, so no caution can be given)."""
    if source is None or isinstance(source, Baseline):
        return source
    if isinstance(source, Trial):
        return Baseline(dict(source.metrics), dict(source.parameters), source.session_number,
                        source.number, source.session_date, source.assistance)
    if isinstance(source, TrialData):
        parameters = source.parameters.to_dict() if source.parameters is not None else None
        return Baseline(dict(source.metrics), parameters, date=_file_date(source),
                        levels=source.assistance_in_effect())
    if isinstance(source, Mapping):
        return Baseline({k: float(v) for k, v in source.items()})
    raise TypeError(
        f"cannot compare with a {type(source).__name__}: give a TrialData, a registry Trial, "
        "a Baseline or a mapping of metric names to values"
    )


def date_text(day: datetime.date) -> str:
    """'1 May 2024' (English month names whatever the locale, like the rest of the report)."""
    return f"{day.day} {_MONTHS[day.month - 1]} {day.year}"


_MONTHS = ("January", "February", "March", "April", "May", "June", "July", "August",
           "September", "October", "November", "December")


def _file_date(trial: TrialData) -> datetime.date | None:
    try:
        return datetime.datetime.fromisoformat(trial.created_utc).astimezone().date()
    except ValueError:
        return None


# -- the patient's lines ----------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class Change:
    """One figure before and after. verdict: better, worse, same, more or less, or ''
    when the trials do not compare (Comparison.comparable); arrow: which way the number
    went (↑, ↓, =), '' likewise."""

    key: str
    name: str
    before: float
    after: float
    before_text: str
    after_text: str
    verdict: str
    arrow: str
    text: str


@dataclass(frozen=True, slots=True)
class Comparison:
    """The change since one earlier trial: `title` names it, `changes` are the patient's
    figures, `cautions` say why the two trials do not compare (this one cut short, a
    setting or the robot's help differed); none when they do."""

    kind: str  # "previous D trial", "previous session's D trial", or both joined by " and "
    title: str
    baseline: Baseline
    changes: tuple[Change, ...]
    cautions: tuple[str, ...]
    label: str = ""  # a column's heading: "Last trial", "Last session"

    @property
    def comparable(self) -> bool:
        return not self.cautions


@dataclass(frozen=True, slots=True)
class _PatientFigure:
    key: str
    name: str
    goal: Goal
    value: Callable[[Mapping[str, float]], float]  # SI, from the metrics
    shown: Callable[[float], float]  # the number the patient reads, rounded
    text: Callable[[float], str]


def _metric(key: str) -> Callable[[Mapping[str, float]], float]:
    return lambda metrics: float(metrics.get(key, math.nan))


def _percent(key: str, name: str) -> _PatientFigure:
    return _PatientFigure(key, name, GOALS[key], _metric(key), lambda v: float(round(v)),
                          lambda v: f"{whole(v)} %")


def _degrees(key: str, name: str) -> _PatientFigure:
    return _PatientFigure(key, name, Goal.NONE, _metric(key),
                          lambda v: float(round(math.degrees(v))),
                          lambda v: f"{whole(math.degrees(v))}°")


_JOINTS = (_degrees("shoulder_rom_rad", "Shoulder movement"),
           _degrees("elbow_rom_rad", "Elbow movement"))
_DISTANCE = _PatientFigure(
    "rmse", "Distance from the path", GOALS["rmse"],
    lambda m: position_error_m(float(m.get("rmse_x_m", math.nan)),
                               float(m.get("rmse_y_m", math.nan))),
    lambda v: float(distance_mm_shown(v)), distance_text)
PATIENT_FIGURES = {
    "as-needed": (_percent("led_pct", "Led the movement"), *_JOINTS),
    "thesis": (_percent("directional_performance_pct", "Pushed in the right direction"),
               *_JOINTS),
    "transparent": (_DISTANCE, *_JOINTS),
    "task": _JOINTS,
}
"""The figures the patient's page compares, per assistance mode: the mode's own success
figure first (plain_language.SUCCESS_KEYS), then the joints' movement. The distance
from the path is not among them in the thesis and as-needed modes: the robot keeps the
hand on the path there, so its change is mostly the robot's (plain_language.position_line).
In the transparent mode it is the patient's own, and comes first: the robot adds no help,
so the push's direction is only what moving the robot takes. An assessment trial
("task": plain_language.patient_mode) compares the joints' movement only: its patient
moves at their own pace, not the reference's."""


def verdict(goal: Goal, before: float, after: float) -> str:
    """better / worse / same for a figure with a goal, more / less / same without."""
    if after == before:
        return "same"
    if goal is Goal.NONE:
        return "more" if after > before else "less"
    if goal is Goal.TOWARD_ONE:
        if abs(after - 1.0) == abs(before - 1.0):
            return "same"
        return "better" if abs(after - 1.0) < abs(before - 1.0) else "worse"
    improved = after > before if goal is Goal.HIGHER else after < before
    return "better" if improved else "worse"


def arrow(before: float, after: float) -> str:
    return SAME if after == before else (UP if after > before else DOWN)


def patient_changes(before: Mapping[str, float], after: Mapping[str, float], *,
                    mode: str = "thesis", comparable: bool = True) -> tuple[Change, ...]:
    """The patient's figures that both trials have, compared as the patient reads them;
    without a verdict or an arrow when the trials do not compare."""
    changes = []
    for figure in PATIENT_FIGURES.get(mode, PATIENT_FIGURES["thesis"]):
        a, b = figure.value(before), figure.value(after)
        if not (math.isfinite(a) and math.isfinite(b)):
            continue
        shown_a, shown_b = figure.shown(a), figure.shown(b)
        text_a, text_b = figure.text(a), figure.text(b)
        if comparable:
            word = verdict(figure.goal, shown_a, shown_b)
            changes.append(Change(figure.key, figure.name, a, b, text_a, text_b, word,
                                  arrow(shown_a, shown_b),
                                  change_sentence(figure.name, text_a, text_b, word)))
        else:
            changes.append(Change(figure.key, figure.name, a, b, text_a, text_b, "", "",
                                  f"{figure.name}: {text_a} then, {text_b} now"))
    return tuple(changes)


PARTIAL_CAUTION = ("This trial did not run to its end, so its figures cover only part of "
                   "the exercise and do not compare with a whole trial.")
UNKNOWN_SETTINGS_CAUTION = ("The settings of the earlier trial are not known, so its figures "
                            "are not compared.")
UNKNOWN_HELP_CAUTION = ("The robot's help in the earlier trial is not known, so its figures "
                        "are not compared.")


def compare(kind: str, baseline: Baseline, metrics: Mapping[str, float],
            parameters: TrialParameters | None, *, partial: bool = False,
            levels: AssistanceInEffect | None = None, label: str = "") -> Comparison:
    """This trial (its metrics, parameters and the levels it ran at) against `baseline`;
    `partial`: this trial did not run to its end. Any caution means the two do not
    compare (module notes)."""
    described = baseline.describe()
    title = f"Since your {kind}" + (f" ({described})" if described else "")
    cautions: tuple[str, ...] = (PARTIAL_CAUTION,) if partial else ()
    if baseline.parameters is not None and parameters is not None:
        cautions += parameter_cautions(baseline.parameters, parameters.to_dict())
        cautions += game_cautions(baseline.parameters, parameters.to_dict())
        if levels is not None:
            if baseline.levels is None:
                cautions += (UNKNOWN_HELP_CAUTION,)
            else:
                cautions += tuple(c for c in (help_caution(baseline.levels, levels),) if c)
    elif baseline.parameters is None:
        cautions += (UNKNOWN_SETTINGS_CAUTION,)
    mode = patient_mode(parameters) if parameters is not None else "thesis"
    return Comparison(kind, title, baseline,
                      patient_changes(baseline.metrics, metrics, mode=mode,
                                      comparable=not cautions),
                      cautions, label or capitalised(kind))


# -- the therapist's table ----------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class TableRow:
    """One figure of the therapist's table in display units: this trial's value and,
    per comparison, the earlier value with the change ('' when there is none)."""

    key: str
    label: str
    unit: str
    meaning: str
    value: float  # display units
    value_text: str
    earlier_texts: tuple[str, ...]
    verdicts: tuple[str, ...]


def metric_text(row: MetricRow, value_si: float) -> str:
    """'8.7 mm', '78 %', '42.2°', '0.84 N': a figure with its display unit, in its
    row's decimals (MetricRow.places)."""
    shown = number_text(value_si * row.scale, row.places)
    if not row.unit:
        return shown
    return f"{shown}{row.unit}" if row.unit == "°" else f"{shown} {row.unit}"


PATIENT_RESOLUTION = {"mm": 1.0, "%": 1.0, "°": 1.0}
"""Display unit → the step a change must reach to count, as the patient's page rounds it
(plain_language: whole mm, whole %, whole degrees)."""


NOISE = "about the same"
"""The verdict on a change too small to mean anything (_within_noise)."""


def _within_noise(row: MetricRow, before: float, after: float,
                  least_si: float | None) -> bool:
    """Whether a change of a figure (display units, as _resolved shows them) is noise:
    smaller than its minimal detectable change where the console knows one (`least_si`,
    the norms' MDC95, SI), else, for a figure the patient's page does not round
    (PATIENT_RESOLUTION), no more than one step of its last shown decimal, which two
    readings a hair apart can differ by (0.9149 and 0.9151 show 0.91 and 0.92). The
    table called "LDLJ −16.27, was −16.25" and a circle ratio of 0.92 after 0.91 worse."""
    if least_si is not None and math.isfinite(least_si):
        return abs(after - before) < least_si * row.scale
    if row.unit in PATIENT_RESOLUTION:
        return False  # as the patient's page compares it: whole mm, %, degrees
    return abs(after - before) <= 10.0 ** -row.places * (1.0 + 1e-9)


def _resolved(row: MetricRow, value: float) -> float:
    step = PATIENT_RESOLUTION.get(row.unit)
    if step is None:
        return float(number_text(value, row.places))
    shown = round(value / step) * step
    # the patient reads a distance as at least 1 mm (plain_language.distance_mm_shown)
    return max(shown, 1.0) if row.unit == "mm" else shown


POSITION_ROW = MetricRow("rmse", "Position error, x and y together (RMSE)", "mm", MM_PER_M,
                         "how far the hand was from the path, in any direction (the figure"
                         " on the patient's page)", short="RMSE")
"""The patient's distance from the path (plain_language.position_error_m) as a row of the
therapist's table, so the two pages speak of the same number."""


def _with_position(metrics: Mapping[str, float]) -> dict[str, float]:
    values = dict(metrics)
    values["rmse"] = position_error_m(float(metrics.get("rmse_x_m", math.nan)),
                                      float(metrics.get("rmse_y_m", math.nan)))
    return values


def table_order(mode: str) -> tuple[MetricRow, ...]:
    """The therapist's rows: the mode's success figure first (plain_language.SUCCESS_KEYS),
    then app.reports.metrics_table.ROWS with the combined position error after y's."""
    first = success_key(mode)
    rows: list[MetricRow] = [row for row in ROWS if row.key == first]
    for row in ROWS:
        if row.key != first:
            rows.append(row)
        if row.key == "rmse_y_m":
            rows.append(POSITION_ROW)
    return tuple(rows)


def table_rows(metrics: Mapping[str, float], baselines: tuple[Baseline, ...], *,
               mode: str = "thesis", comparable: tuple[bool, ...] | None = None,
               only_lightened: bool = False,
               order: tuple[MetricRow, ...] | None = None,
               least_change: Mapping[str, float] | None = None) -> tuple[TableRow, ...]:
    """Every row of `order` (default `table_order(mode)`; an assessment task's:
    app.reports.task_table.task_order) this trial has a value for, each earlier trial's
    value beside it, with the change only where the trials compare (`comparable`, one
    flag per baseline; all by default): the same rule as the patient's page.
    `only_lightened` (plain_language.robot_only_lightened): no robot's share of the work,
    whose motors' work went into the robot itself (the net works stay, what was measured).
    `least_change`: a figure's minimal detectable change (SI, the norms' MDC95) by key; a
    change within it, or within the figure's shown precision, is "about the same"
    (_within_noise)."""
    least_change = least_change or {}
    comparable = comparable if comparable is not None else (True,) * len(baselines)
    metrics = _with_position(metrics)
    earlier_metrics = [_with_position(b.metrics) for b in baselines]
    rows = []
    for row in order if order is not None else table_order(mode):
        value = float(metrics.get(row.key, math.nan)) * row.scale
        if not math.isfinite(value) or (only_lightened and row.key == "robot_work_share"):
            continue
        texts, verdicts = [], []
        goal = goal_of(row.key)
        for before, compared in zip(earlier_metrics, comparable, strict=True):
            earlier = float(before.get(row.key, math.nan)) * row.scale
            if not math.isfinite(earlier):
                texts.append("–")
                verdicts.append("")
                continue
            # Compared at the patient's resolution where the patient reads the figure's
            # unit (whole mm, %, degrees), else at the table's: the table never says
            # "worse" where the patient's page says "the same".
            if not compared:
                texts.append(f"was {number_text(earlier, row.places)}")
                verdicts.append("")
                continue
            a, b = _resolved(row, earlier), _resolved(row, value)
            if a != b and _within_noise(row, a, b, least_change.get(row.key)):
                word, way = NOISE, NOISE_ARROW
            else:
                word, way = verdict(goal, a, b), arrow(a, b)
            # the cell reads as the change *to* this trial, not as a verdict on the earlier
            texts.append(f"was {number_text(earlier, row.places)}: now {way} {word}")
            verdicts.append(word)
        rows.append(TableRow(row.key, row.label, row.unit, row.meaning, value,
                             number_text(value, row.places), tuple(texts), tuple(verdicts)))
    return tuple(rows)
