"""A patient's progress: every metric of every trial, as a table and as plot-ready arrays.

A metric only compares between trials done at the same exercise: a larger D or
a shorter duration makes the RMSE worse while the patient improves. So every
trial carries its parameter set (`ParameterSet`: the registry's KEY_PARAMETERS),
every point is marked with it, and `Progress.series` gives one curve per
parameter set on a shared x axis (trial order, or start time).

Metrics come from the registry, so a trial whose file is missing or unreadable
still appears; `file_state` says which ('ok', 'missing', 'unreadable'). The file
check opens each file and reads its 8-byte HDF5 signature (about 4 µs a file on
a local disk); pass check_files=False on a slow network share.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from app.records.registry import KEY_PARAMETERS, TrialSummary, parameter_key
from app.records.store import RecordStore
from app.units import assistance_percent, cm

FILE_OK = "ok"
FILE_MISSING = "missing"
FILE_UNREADABLE = "unreadable"
FILE_UNCHECKED = "unchecked"

_FILE_USABLE = frozenset((FILE_OK, FILE_UNCHECKED))

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"

TABLE_COLUMNS = ("trial_id", "session", "trial", "date", "started_at", "status", "file_state",
                 *(f"set_{name}" for name in KEY_PARAMETERS))
"""The table's leading columns; one column per metric follows, in `metric_names` order.
The parameter set's columns are prefixed `set_`: some metrics repeat a parameter
(duration_s, tolerance_rad) and a table must not have two columns of one name."""


@dataclass(frozen=True, slots=True)
class ParameterSet:
    """The exercise a trial was done at: the values that change what its metrics mean.
    None where a trial's stored parameters lack the field."""

    shape: str | None
    radius_m: float | None
    duration_s: float | None
    tolerance_rad: float | None
    assistance_level: float | None
    controller: str | None

    @classmethod
    def of(cls, parameters: Mapping) -> ParameterSet:
        """From a trial's parameters (TrialParameters.to_dict() or Trial.parameters)."""
        return cls.from_values(tuple(parameters.get(name) for name in KEY_PARAMETERS))

    @classmethod
    def from_values(cls, values: tuple) -> ParameterSet:
        """From the KEY_PARAMETERS values in order (TrialSummary.key_parameters)."""
        return cls(*parameter_key(values))

    def label(self) -> str:
        """Short text for a legend, in the units a therapist reads (degrees at the display)."""
        shape = self.shape or "?"
        parts = [shape.upper() if shape == "d" else shape]  # the thesis writes "the D"
        if self.radius_m is not None:
            parts.append(f"r {cm(self.radius_m)}")
        if self.duration_s is not None:
            parts.append(f"{self.duration_s:g} s")
        if self.tolerance_rad is not None:
            parts.append(f"±{math.degrees(self.tolerance_rad):.0f}°")
        if self.controller is not None:
            parts.append(self.controller.upper())
        if self.assistance_level is not None:
            parts.append(f"assistance {assistance_percent(self.assistance_level)}")
        return ", ".join(parts)


@dataclass(frozen=True, slots=True)
class ProgressRow:
    """One trial in the progress table (built on demand by Progress.rows)."""

    trial: TrialSummary
    parameter_set: ParameterSet
    parameter_set_index: int
    file_state: str

    @property
    def file_ok(self) -> bool:
        return self.file_state in _FILE_USABLE


@dataclass(frozen=True, slots=True)
class Series:
    """One metric at one parameter set: arrays of equal length, in trial order.
    x is `trial_index` (position among all the patient's trials) or `time_s`."""

    metric: str
    parameter_set: ParameterSet
    parameter_set_index: int
    trial_index: np.ndarray
    time_s: np.ndarray
    values: np.ndarray
    session: np.ndarray
    trial: np.ndarray
    trial_id: np.ndarray
    file_ok: np.ndarray


@dataclass(frozen=True, slots=True)
class Progress:
    """Every trial of one patient in registry order (session, then trial number).

    Column-oriented: `trials`, `file_states` and every array have one element
    per trial. time_s is the trial's start in seconds since the Unix epoch
    (UTC), ready for a date axis. values maps each metric to a float array, NaN
    where a trial lacks the metric or it was undefined. Arrays are read-only.
    Per-trial row objects are made only when asked for (`rows`), because every
    object kept alive makes the interpreter's garbage collector pass longer.
    """

    patient_code: str
    trials: tuple[TrialSummary, ...]
    file_states: tuple[str, ...]
    metric_names: tuple[str, ...]
    parameter_sets: tuple[ParameterSet, ...]
    trial_index: np.ndarray
    time_s: np.ndarray
    session: np.ndarray
    trial: np.ndarray
    trial_id: np.ndarray
    parameter_set_index: np.ndarray
    file_ok: np.ndarray
    values: Mapping[str, np.ndarray]

    def __len__(self) -> int:
        return len(self.trials)

    @property
    def rows(self) -> tuple[ProgressRow, ...]:
        sets = self.parameter_sets
        return tuple(
            ProgressRow(trial, sets[index], index, state)
            for trial, index, state in zip(self.trials, self.parameter_set_index.tolist(),
                                           self.file_states, strict=True)
        )

    def series(self, metric: str, *, finite_only: bool = True) -> tuple[Series, ...]:
        """One Series per parameter set that has `metric`, in the sets' order of first
        use; finite_only drops trials where the metric is NaN."""
        if metric not in self.values:
            raise KeyError(
                f"no trial of patient {self.patient_code} has the metric {metric!r}; "
                f"known: {', '.join(self.metric_names) or 'none'}"
            )
        values = self.values[metric]
        out = []
        for index, parameter_set in enumerate(self.parameter_sets):
            mask = self.parameter_set_index == index
            if finite_only:
                mask &= np.isfinite(values)
            if not mask.any():
                continue
            out.append(Series(
                metric, parameter_set, index, _frozen(self.trial_index[mask]),
                _frozen(self.time_s[mask]), _frozen(values[mask]), _frozen(self.session[mask]),
                _frozen(self.trial[mask]), _frozen(self.trial_id[mask]),
                _frozen(self.file_ok[mask]),
            ))
        return tuple(out)

    def table(self) -> tuple[tuple[str, ...], list[tuple]]:
        """(header, rows): TABLE_COLUMNS then one column per metric. Dates and times
        as ISO 8601 text, numbers in SI units, NaN for a missing metric."""
        header = (*TABLE_COLUMNS, *self.metric_names)
        columns = [self.values[name] for name in self.metric_names]
        rows = []
        for i, (t, state, index) in enumerate(zip(self.trials, self.file_states,
                                                  self.parameter_set_index.tolist(),
                                                  strict=True)):
            p = self.parameter_sets[index]
            rows.append((
                t.id, t.session_number, t.number, t.session_date.isoformat(),
                t.started_at.isoformat(), t.status, state,
                p.shape, p.radius_m, p.duration_s, p.tolerance_rad, p.assistance_level,
                p.controller, *(float(c[i]) for c in columns),
            ))
        return header, rows


def progress(registry: RecordStore, code: str, *, check_files: bool = True) -> Progress:
    """The progress of the patient with this code (PatientNotFound if none)."""
    trials = registry.trial_summaries(code)
    n = len(trials)
    root = str(registry.data_dir.root).rstrip("/\\") + os.sep

    sets: dict[ParameterSet, int] = {}
    seen: dict[tuple, ParameterSet] = {}  # raw values -> set: skips re-canonicalising
    set_index = np.empty(n, dtype=np.int64)
    states = []
    metric_names: dict[str, None] = {}
    for i, trial in enumerate(trials):
        raw = trial.key_parameters
        parameter_set = seen.get(raw)
        if parameter_set is None:
            parameter_set = seen[raw] = ParameterSet.from_values(raw)
        index = sets.setdefault(parameter_set, len(sets))
        set_index[i] = index
        metric_names.update(dict.fromkeys(trial.metrics))
        states.append(_file_state(root, trial.file) if check_files else FILE_UNCHECKED)

    names = tuple(metric_names)
    matrix = _metric_matrix(trials, names)
    values = {name: _frozen(matrix[:, j]) for j, name in enumerate(names)}
    return Progress(
        patient_code=code,
        trials=tuple(trials),
        file_states=tuple(states),
        metric_names=names,
        parameter_sets=tuple(sets),
        trial_index=_frozen(np.arange(n, dtype=np.int64)),
        time_s=_frozen(np.fromiter((t.started_at.timestamp() for t in trials),
                                   dtype=np.float64, count=n)),
        session=_frozen(np.fromiter((t.session_number for t in trials), dtype=np.int64,
                                    count=n)),
        trial=_frozen(np.fromiter((t.number for t in trials), dtype=np.int64, count=n)),
        trial_id=_frozen(np.fromiter((t.id for t in trials), dtype=np.int64, count=n)),
        parameter_set_index=_frozen(set_index),
        file_ok=_frozen(np.fromiter((s in _FILE_USABLE for s in states), dtype=bool, count=n)),
        values=values,
    )


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


def _file_state(root: str, file: str) -> str:
    """root ends with a separator. Plain string work: pathlib and os.path.join
    cost more than the open itself, 1,000 times over."""
    if file.startswith("/") or ".." in file.split("/") or ":" in file or "\\" in file:
        return FILE_UNREADABLE  # not a path the registry writes
    try:
        fd = os.open(root + (file if os.sep == "/" else file.replace("/", os.sep)),
                     os.O_RDONLY)
    except FileNotFoundError:
        return FILE_MISSING
    except OSError:  # no permission, a folder
        return FILE_UNREADABLE
    try:
        head = os.read(fd, len(HDF5_SIGNATURE))
    except OSError:
        return FILE_UNREADABLE
    finally:
        os.close(fd)
    # HDF5 files written by h5py without a user block carry the signature at 0.
    return FILE_OK if head == HDF5_SIGNATURE else FILE_UNREADABLE


def _frozen(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array
