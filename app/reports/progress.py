"""A patient's progress: every metric of every trial, as a table and as plot-ready series,
one series per exercise.

What makes two trials the same exercise (`Exercise`): the assistance mode, the shape, its
size, the controller, and the assessment task or the game it was a run of (a circle drawn
for the battery's circle task is not the circle exercise at the same size: another
protocol, another instruction; before 2026-12-05 both were one series, named by the shape
alone). A thesis-mode trial and an as-needed one are never in one series:
each mode has its own success figure (app.reports.plain_language.SUCCESS_KEYS) and its own
meaning of the assistance level. The settings the console's progression moves from trial to
trial (app.trials.progression) — the assistance level, the pace (seconds per lap) and the
direction tolerance — do not start a new series: they are the staircase the series is read
against, so every trial carries them (`Progress.levels`, `duration_s`, `tolerance_rad`) and
the views draw them as their own axis or annotations along the series (issue 27 #7: with a
new series at every assistance step, 7 trials made 4 "settings" and no trend ever showed).
The levels are those the trial ran at, changes during it included
(app.trials.assistance_timeline), as the registry keeps them; a trial registered before it
kept them shows the level it was built with (`levels_recorded` False).

Metrics come from the registry, so a trial whose file is missing or unreadable still
appears; `file_state` says where its file is (app.records.trialplace: 'ok' here,
'in_store' the shared trial store's copy, 'at_station' on the station that recorded it and
not yet in the store, 'store_unreachable', 'missing', 'unreadable'). The file check opens
each file and reads its 8-byte HDF5 signature (about 4 µs a file on a local disk), the
store's only for a file not whole here; pass check_files=False on a slow network share.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from app.assessments.words import ROBOT_ROLE
from app.games.names import game_title
from app.records.registry import TrialSummary, key_values, parameter_key
from app.records.store import RecordStore
from app.records.trialplace import (  # noqa: F401 (the file states, named here too)
    FILE_AT_STATION,
    FILE_IN_STORE,
    FILE_MISSING,
    FILE_OF_ANOTHER,
    FILE_OK,
    FILE_STORE_UNREACHABLE,
    FILE_UNCHECKED,
    FILE_UNREADABLE,
    FILE_USABLE,
    HDF5_SIGNATURE,
    TrialPlaces,
)
from app.reports.plain_language import SHAPE_NAMES, success_key
from app.trials.assistance_timeline import AssistanceInEffect
from app.units import cm
from core.assessment.figures import TASK_TITLES

MODE_NAMES = {"as-needed": "As needed", "thesis": "Thesis mode", "transparent": "Transparent"}
# TrialSummary.key_parameters' order (app.records.registry.KEY_PARAMETERS)
_SHAPE, _RADIUS, _DURATION, _TOLERANCE, _LEVEL, _CONTROLLER, _ASSESSMENT, _GAME = range(8)

TABLE_COLUMNS = ("trial_id", "session", "trial", "date", "started_at", "status", "file_state",
                 "station", "exercise", "shape", "radius_m", "controller", "assessment", "game",
                 "set_duration_s", "set_tolerance_rad", "invalid_reason")
"""The table's leading columns; one column per metric follows, in `metric_names` order.
`exercise` numbers the series (1, 2, … in `exercises`' order). The pace and the tolerance
are prefixed `set_`: some metrics repeat them (duration_s, tolerance_rad) and a table must
not have two columns of one name. `station` is the station that recorded the trial (''
before schema v10), `file_state` where its file is (the module's doc). The assistance mode
and the levels each trial ran at are the records' (app.records.outcomes, which `rehab
progress --csv` appends), not repeated here. `assessment` and `game` name the assessment
task or the game a trial was a run of ('' for neither; core.trial.TrialParameters).
`invalid_reason` is '' for a valid trial, why it was marked invalid otherwise (only with
include_invalid: invalid trials are left out by default)."""


@dataclass(frozen=True, slots=True)
class Exercise:
    """What a series is: the assistance mode and the exercise (shape, size, controller,
    and the assessment task or game it was a run of, '' for neither). None where a trial's
    stored parameters lack the field."""

    mode: str
    shape: str | None
    radius_m: float | None
    controller: str | None
    assessment: str = ""
    game: str = ""

    @property
    def success_key(self) -> str:
        """The mode's own success figure, shown first (plain_language.SUCCESS_KEYS)."""
        return success_key(self.mode)

    def label(self) -> str:
        """'As needed · D shape, r 10.0 cm · SMC'; an assessment's or a game's name first:
        'Assessment: Circle drawing · Transparent · circle, r 7.0 cm · SMC'; a task the
        robot leads by what the robot does ('Assessment: Isometric strength · robot holds
        the handle still · CTPID'), its mode and targets being no exercise's."""
        shape = SHAPE_NAMES.get(self.shape, self.shape or "?")
        parts = [MODE_NAMES.get(self.mode, self.mode),
                 shape + (f", r {cm(self.radius_m)}" if self.radius_m is not None else "")]
        if self.assessment in ROBOT_ROLE:
            parts = [ROBOT_ROLE[self.assessment]]
        if self.assessment:
            parts.insert(0, f"Assessment: {TASK_TITLES.get(self.assessment, self.assessment)}")
        elif self.game:
            parts.insert(0, game_title(self.game))
        if self.controller is not None:
            parts.append(self.controller.upper())
        return " · ".join(parts)


@dataclass(frozen=True, slots=True)
class ProgressRow:
    """One trial in the progress table (built on demand by Progress.rows)."""

    trial: TrialSummary
    exercise: Exercise
    exercise_index: int
    file_state: str
    levels: AssistanceInEffect
    levels_recorded: bool

    @property
    def file_ok(self) -> bool:
        return self.file_state in FILE_USABLE


@dataclass(frozen=True, slots=True)
class Series:
    """One metric over one exercise's trials, in order: arrays of equal length. `position`
    is the trial's place among the exercise's trials (1, 2, …: the plots' x), `trial_index`
    its place among all the patient's trials (Progress' arrays)."""

    metric: str
    exercise: Exercise
    exercise_index: int
    position: np.ndarray
    trial_index: np.ndarray
    time_s: np.ndarray
    values: np.ndarray
    session: np.ndarray
    trial: np.ndarray
    trial_id: np.ndarray
    file_ok: np.ndarray
    complete: np.ndarray


@dataclass(frozen=True, slots=True)
class Progress:
    """Every trial of one patient in registry order (session, then trial number).

    Column-oriented: `trials`, `file_states`, `levels` and every array have one element
    per trial. time_s is the trial's start in seconds since the Unix epoch (UTC), ready
    for a date axis. values maps each metric to a float array, NaN where a trial lacks the
    metric or it was undefined. duration_s (s per lap) and tolerance_rad are the pace and
    the tolerance each trial was built with (NaN where not stored); levels the assistance
    levels it ran at. Arrays are read-only. Per-trial row objects are made only when asked
    for (`rows`): every object kept alive makes the garbage collector's passes longer.
    """

    patient_code: str
    trials: tuple[TrialSummary, ...]
    file_states: tuple[str, ...]
    metric_names: tuple[str, ...]
    exercises: tuple[Exercise, ...]
    exercise_index: np.ndarray
    trial_index: np.ndarray
    time_s: np.ndarray
    session: np.ndarray
    trial: np.ndarray
    trial_id: np.ndarray
    file_ok: np.ndarray
    complete: np.ndarray
    duration_s: np.ndarray
    tolerance_rad: np.ndarray
    levels: tuple[AssistanceInEffect, ...]
    levels_recorded: np.ndarray
    values: dict[str, np.ndarray]

    def __len__(self) -> int:
        return len(self.trials)

    @property
    def rows(self) -> tuple[ProgressRow, ...]:
        return tuple(
            ProgressRow(trial, self.exercises[index], index, state, levels, bool(recorded))
            for trial, index, state, levels, recorded in zip(
                self.trials, self.exercise_index.tolist(), self.file_states, self.levels,
                self.levels_recorded.tolist(), strict=True)
        )

    def members(self, exercise_index: int) -> np.ndarray:
        """The trial indexes of one exercise, in order."""
        return np.flatnonzero(self.exercise_index == exercise_index)

    def series(self, metric: str, *, finite_only: bool = True) -> tuple[Series, ...]:
        """One Series per exercise that has `metric`, in the exercises' order of first use;
        finite_only drops trials where the metric is NaN (their positions stay theirs)."""
        if metric not in self.values:
            raise KeyError(
                f"no trial of patient {self.patient_code} has the metric {metric!r}; "
                f"known: {', '.join(self.metric_names) or 'none'}"
            )
        values = self.values[metric]
        out = []
        for index, exercise in enumerate(self.exercises):
            members = self.members(index)
            position = np.arange(1, len(members) + 1)
            if finite_only:
                keep = np.isfinite(values[members])
                members, position = members[keep], position[keep]
            if not len(members):
                continue
            out.append(Series(
                metric, exercise, index, _frozen(position), _frozen(members),
                *(_frozen(array[members]) for array in (
                    self.time_s, values, self.session, self.trial, self.trial_id,
                    self.file_ok, self.complete)),
            ))
        return tuple(out)

    def table(self) -> tuple[tuple[str, ...], list[tuple]]:
        """(header, rows): TABLE_COLUMNS then one column per metric. Dates and times as
        ISO 8601 text, numbers in SI units, NaN for a missing metric."""
        header = (*TABLE_COLUMNS, *self.metric_names)
        columns = [self.values[name] for name in self.metric_names]
        rows = []
        for i, (t, state, index) in enumerate(zip(
                self.trials, self.file_states, self.exercise_index.tolist(), strict=True)):
            exercise = self.exercises[index]
            rows.append((
                t.id, t.session_number, t.number, t.session_date.isoformat(),
                t.started_at.isoformat(), t.status, state, t.station or "", index + 1,
                exercise.shape,
                exercise.radius_m, exercise.controller, exercise.assessment,
                exercise.game, float(self.duration_s[i]),
                float(self.tolerance_rad[i]), t.invalid_reason or "",
                *(float(c[i]) for c in columns),
            ))
        return header, rows


def progress(registry: RecordStore, code: str, *, check_files: bool = True,
             include_invalid: bool = False) -> Progress:
    """The progress of the patient with this code (PatientNotFound if none): trials marked
    invalid are left out unless `include_invalid` (then each says why, its
    `invalid_reason`)."""
    trials = registry.trial_summaries(code, include_invalid=include_invalid)
    n = len(trials)
    places = TrialPlaces(registry) if check_files else None

    exercises: dict[Exercise, int] = {}
    # Most trials share a few settings: each set of raw values is canonicalised once
    seen: dict[tuple, tuple[int, float, float, AssistanceInEffect]] = {}
    exercise_index = np.empty(n, dtype=np.int64)
    duration = np.empty(n)
    tolerance = np.empty(n)
    states, levels = [], []
    recorded = np.empty(n, dtype=bool)
    metric_names: dict[str, None] = {}
    for i, trial in enumerate(trials):
        raw = (trial.assist, trial.key_parameters)
        known = seen.get(raw)
        if known is None:
            key = parameter_key(trial.key_parameters)
            exercise = _exercise(trial.assist, key)
            known = seen[raw] = (
                exercises.setdefault(exercise, len(exercises)), _number(key[_DURATION]),
                _number(key[_TOLERANCE]),
                # a trial registered before the levels were kept: the level it was built with
                AssistanceInEffect(((0.0, _number(key[_LEVEL])),)))
        exercise_index[i], duration[i], tolerance[i], built = known
        recorded[i] = trial.assistance is not None
        levels.append(built if trial.assistance is None else trial.assistance)
        metric_names.update(dict.fromkeys(trial.metrics))
        states.append(FILE_UNCHECKED if places is None else
                      places.trial_state(trial, code))

    names = tuple(metric_names)
    matrix = _metric_matrix(trials, names)
    return Progress(
        patient_code=code,
        trials=tuple(trials),
        file_states=tuple(states),
        metric_names=names,
        exercises=tuple(exercises),
        exercise_index=_frozen(exercise_index),
        trial_index=_frozen(np.arange(n, dtype=np.int64)),
        time_s=_frozen(np.fromiter((t.started_at.timestamp() for t in trials),
                                   dtype=np.float64, count=n)),
        session=_frozen(np.fromiter((t.session_number for t in trials), dtype=np.int64,
                                    count=n)),
        trial=_frozen(np.fromiter((t.number for t in trials), dtype=np.int64, count=n)),
        trial_id=_frozen(np.fromiter((t.id for t in trials), dtype=np.int64, count=n)),
        file_ok=_frozen(np.fromiter((s in FILE_USABLE for s in states), dtype=bool, count=n)),
        complete=_frozen(np.fromiter((t.status == "complete" for t in trials), dtype=bool,
                                     count=n)),
        duration_s=_frozen(duration),
        tolerance_rad=_frozen(tolerance),
        levels=tuple(levels),
        levels_recorded=_frozen(recorded),
        values={name: _frozen(matrix[:, j]) for j, name in enumerate(names)},
    )


_FILE_NOTES = {FILE_IN_STORE: "file in the trial store", FILE_MISSING: "file missing",
               FILE_OF_ANOTHER: "no file of its own: the file of its name is another "
                                "trial's recording",
               FILE_UNREADABLE: "file unreadable",
               FILE_STORE_UNREACHABLE: "file in a trial store not reachable here"}


def file_note(state: str, station: str | None) -> str:
    """Where a trial's file is, as the progress says it after the trial's status (the
    Progress tab, `rehab progress`, its PDF): '' for a file here or not checked; a file on
    the station that recorded it and not yet in the trial store is not "missing"."""
    if state == FILE_AT_STATION:
        return f"on station {station}, not yet in the trial store"
    return _FILE_NOTES.get(state, "")


def exercise_of(assist: str, parameters: Mapping) -> Exercise:
    """The series a trial belongs to, from its mode and its stored parameters (a trial
    file's or the registry's): what makes two trials the same exercise is written once,
    here, for the patient's progress and a study's table (app.study)."""
    return _exercise(assist, parameter_key(key_values(parameters)))


def _exercise(assist: str, key: tuple) -> Exercise:
    """key: KEY_PARAMETERS' values made comparable (parameter_key)."""
    return Exercise(assist, key[_SHAPE], key[_RADIUS], key[_CONTROLLER],
                    key[_ASSESSMENT] or "", key[_GAME] or "")


def _number(value) -> float:
    return math.nan if value is None else float(value)


def _metric_matrix(trials: list[TrialSummary], names: tuple[str, ...]) -> np.ndarray:
    """(n trials, n metrics) floats, NaN where a trial lacks a metric."""
    nan = math.nan
    # Trials computed by one software version list the same metrics in the same
    # order: their values are a row as they stand, without a lookup per metric.
    lists = [
        list(t.metrics.values()) if tuple(t.metrics) == names
        else [t.metrics.get(name, nan) for name in names]
        for t in trials
    ]
    matrix = np.array(lists, dtype=np.float64).reshape(len(trials), len(names))
    matrix.flags.writeable = False
    return matrix


def _frozen(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array
