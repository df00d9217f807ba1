"""One exercise's progress as a figure, as plain data: the chosen figure over the exercise's
trials, and under it, on the same trial axis, the robot's help as it ran (a staircase: one
step per trial, a change during a trial a step inside its slot) with the pace and the
tolerance written where they are first set and where they change. The Progress tab
(ui.tabs.progress) and the progress PDF (app.reports.progress_pdf) draw the same
`ProgressFigure`, so the screen and the paper cannot disagree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from app.reports.metrics_table import ROW_BY_KEY, ROWS, MetricRow, catalogue_row
from app.reports.progress import Exercise, Progress
from core.assessment.figures import FIGURES, TASKS, task_figures

SLOT_HALF_WIDTH = 0.5
"""Half the width of a trial's slot on the trial axis: a trial's help is drawn across
position ± this, its changes at their share of the exercise's time; the slots touch, so
a step from one trial to the next is a vertical riser between them."""


@dataclass(frozen=True, slots=True)
class SettingMark:
    """The pace and the tolerance written over a trial where either is first set or changes."""

    position: int
    text: str


@dataclass(frozen=True, slots=True, eq=False)
class ProgressFigure:
    """One exercise's series of one figure. `positions` 1…n are the exercise's trials in
    order (the x axis, labelled `ticks`); `values` in the figure's display unit (`row`),
    NaN where a trial has none; `complete` False for a trial that did not run to its end.
    help_x, help_y: the staircase of the robot's help in % (NaN breaks it where a trial's
    level is not known); live_x, live_y: the changes during a trial, marked on it.
    `levels_recorded` False marks trials whose help is the built level (registered before
    the levels were kept)."""

    exercise: Exercise
    row: MetricRow
    positions: np.ndarray
    values: np.ndarray
    complete: np.ndarray
    ticks: tuple[str, ...]
    help_x: np.ndarray
    help_y: np.ndarray
    marks: tuple[SettingMark, ...]
    levels_recorded: np.ndarray
    live_x: np.ndarray  # where the help changed during a trial: x and the new level (%)
    live_y: np.ndarray

    @property
    def title(self) -> str:
        return self.row.label_in_unit


def figure_row(key: str) -> MetricRow:
    """A figure as a row to show: the metrics table's, or an assessment task's figure
    (core.assessment.FIGURES, in the unit the therapist's table shows it: catalogue_row)."""
    if key in ROW_BY_KEY:
        return ROW_BY_KEY[key]
    spec = FIGURES[key]
    return catalogue_row(spec, spec.definition)


def shown_row(key: str) -> MetricRow:
    """`figure_row`, or for a key neither table knows (a record's bookkeeping: duration_s,
    tolerance_rad, game_hits) a bare row named by its key, unscaled and without a unit:
    what every place that shows any figure by its key shows it as."""
    try:
        return figure_row(key)
    except KeyError:
        return MetricRow(key, key, "", 1.0, "")


def figure_rows(progress: Progress, exercise_index: int) -> tuple[MetricRow, ...]:
    """The figures of an exercise's series that its trials have, as the Progress tab
    offers them, its PDF draws them and `rehab progress` prints them. An assessment task's
    series: the task's own figures (core.assessment.task_figures, the catalogue's order),
    not the tracking ones, which mean little there (the reference moves at the task's
    pace, not the patient's: app.reports.plain_language.patient_mode). Any other: the
    metrics table's, the mode's success figure first."""
    members = progress.members(exercise_index)
    exercise = progress.exercises[exercise_index]

    def had(key: str) -> bool:
        return key in progress.values and bool(np.isfinite(progress.values[key][members]).any())

    if exercise.assessment:
        specs = task_figures(exercise.assessment) if exercise.assessment in TASKS else ()
        return tuple(figure_row(spec.key) for spec in specs if had(spec.key))
    have = [row for row in ROWS if had(row.key)]
    first = exercise.success_key
    return tuple(sorted(have, key=lambda row: row.key != first))


def metric_keys(progress: Progress, exercise_index: int) -> tuple[str, ...]:
    """The keys of `figure_rows`."""
    return tuple(row.key for row in figure_rows(progress, exercise_index))


def progress_figure(progress: Progress, exercise_index: int,
                    metric: str | None = None) -> ProgressFigure:
    """The figure of one exercise (Progress.exercises[exercise_index]) for `metric` (a
    metrics table key or an assessment task's figure; None: the first of `figure_rows`,
    the mode's success figure for an exercise)."""
    exercise = progress.exercises[exercise_index]
    members = progress.members(exercise_index)
    if metric is None:
        keys = metric_keys(progress, exercise_index)
        metric = keys[0] if keys else exercise.success_key
    row = figure_row(metric)
    raw = progress.values.get(metric)
    values = (np.full(len(members), math.nan) if raw is None
              else np.asarray(raw[members], dtype=float) * row.scale)
    positions = np.arange(1, len(members) + 1)
    exercised = progress.values.get("duration_s")
    help_x, help_y, live_x, live_y = help_staircase(
        positions, [progress.levels[i] for i in members],
        np.full(len(members), math.nan) if exercised is None else exercised[members])
    return ProgressFigure(
        exercise, row, positions, values, progress.complete[members].copy(),
        tuple(f"S{progress.session[i]} T{progress.trial[i]}" for i in members),
        help_x, help_y,
        # an assessment's pace and tolerance are its protocol's, the same every run, and
        # its duration is no lap's: a strength test's read "3 s a lap · ±20°" (a push)
        () if exercise.assessment else setting_marks(
            positions, progress.duration_s[members], progress.tolerance_rad[members]),
        progress.levels_recorded[members].copy(), live_x, live_y,
    )


def help_staircase(positions: np.ndarray, levels, exercised_s: np.ndarray,
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The staircase of the robot's help, in %: across each trial's slot (position ±
    SLOT_HALF_WIDTH) the level it ran at, a change during it at its share of the trial's
    exercise time (`exercised_s`, s; the changes evenly spaced when it is not known), and
    between one trial and the next a vertical riser, so a series of steps reads as one
    line. Returns the line's x and y, and the changes during trials (x, new level %)."""
    xs: list[float] = []
    ys: list[float] = []
    live: list[tuple[float, float]] = []
    width = 2.0 * SLOT_HALF_WIDTH
    for position, ran, total in zip(positions.tolist(), levels, exercised_s.tolist(),
                                    strict=True):
        left = position - SLOT_HALF_WIDTH
        changes = ran.changes
        if math.isfinite(total) and total > 0.0:
            shares = [min(max(t / total, 0.0), 1.0) for t, _ in changes]
        else:
            shares = [(k + 1) / (len(changes) + 1) for k in range(len(changes))]
        level = ran.at_start
        xs.append(left)
        ys.append(100.0 * level)
        for share, (_, new) in zip(shares, changes, strict=True):
            xs += [left + share * width] * 2
            ys += [100.0 * level, 100.0 * new]
            live.append((left + share * width, 100.0 * new))
            level = new
        xs.append(position + SLOT_HALF_WIDTH)
        ys.append(100.0 * level)
    live_x, live_y = (np.asarray(v, dtype=float) for v in (zip(*live, strict=True) if live
                                                         else ((), ())))
    return np.asarray(xs, dtype=float), np.asarray(ys, dtype=float), live_x, live_y


def setting_marks(positions: np.ndarray, duration_s: np.ndarray,
                  tolerance_rad: np.ndarray) -> tuple[SettingMark, ...]:
    """'4 s a lap · ±20°' over the first trial, and over every trial where the pace or the
    tolerance differs from the trial before (only what changed)."""
    marks = []
    previous: tuple[float, float] | None = None
    for position, pace, tolerance in zip(positions.tolist(), duration_s.tolist(),
                                         tolerance_rad.tolist(), strict=True):
        parts = []
        if previous is None or not _same(pace, previous[0]):
            parts.append(f"{pace:g} s a lap" if math.isfinite(pace) else "pace not stored")
        if previous is None or not _same(tolerance, previous[1]):
            parts.append(f"±{math.degrees(tolerance):.0f}°" if math.isfinite(tolerance)
                         else "tolerance not stored")
        if parts:
            marks.append(SettingMark(position, " · ".join(parts)))
        previous = (pace, tolerance)
    return tuple(marks)


MIN_SPAN = {"%": 10.0, "mm": 2.0, "°": 10.0}
"""The least y span a progress plot shows, by display unit: one trial (or trials that
hardly differ) must not zoom 17.8–18.6 % to the whole height."""


def value_span(values: np.ndarray, unit: str) -> tuple[float, float]:
    """The y range for the plotted values: theirs, widened about its middle to at least
    MIN_SPAN of the unit (percentages kept within 0–100)."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return 0.0, 0.0
    low, high = float(finite.min()), float(finite.max())
    least = MIN_SPAN.get(unit, 0.0) or max(abs(high) * 0.2, 1e-9)
    if high - low < least:
        middle = (high + low) / 2.0
        low, high = middle - least / 2.0, middle + least / 2.0
    if unit == "%":
        low, high = max(0.0, low), min(100.0, high)
        if high - low < least:
            low, high = (0.0, least) if low == 0.0 else (100.0 - least, 100.0)
    return low, high


def trial_limits(n: int, length: float, radius: float) -> tuple[float, float]:
    """The trial axis's ends for trials 1…n drawn along `length` (px on screen, inches on
    paper), so that a marker of `radius` (the same unit) at either end is whole: half a
    slot beyond each end, or more when the slots are narrower than the marker (300
    trials on a laptop's plot left 1.3 px beside the end markers, drawn half cut). A pad
    p (trials) shows n − 1 + 2p over `length`: the marker fits when
    p ≥ radius·(n − 1) / (length − 2·radius)."""
    pad = max(SLOT_HALF_WIDTH, radius * (n - 1) / max(length - 2.0 * radius, 1e-9))
    return 1.0 - pad, n + pad


def _same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or math.isclose(a, b, rel_tol=1e-9)
