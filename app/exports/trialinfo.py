"""A trial file as the researcher's loader gives it (app.exports.loader, whose doc has the
example and the row keys): its metadata without its samples (`TrialInfo`, `read_info`,
milliseconds a file: attributes only, checked as the console's reader checks them, the
console's reader itself for anything unusual) and the whole trial (`Trial`, `load_trial`:
its channels as named read-only arrays, a read-only mapping).
"""

from __future__ import annotations

import json
import logging
import math
import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import h5py
import numpy as np

from app.errors import TrialFileError
from app.exports.columns import column_values, components, table_columns
from app.trials.opening import UNSEALED_OLDER, seal_of
from app.trials.reader import (
    TrialData,
    parameters_from_attributes,
    plain_attribute,
    read_groups,
    read_trial,
    subject_from_attributes,
)
from core.trial import TrialParameters
from core.work import drop_old_share
from device.loop.pipeline import PHASE_EXERCISE
from device.recording import h5views
from device.recording.trialfile import FORMAT_NAME, FORMAT_VERSION, STATUS_RECORDING, SubjectInfo
from device.recording.trialfile.verify import Damaged, check_heaps, held, inventory

log = logging.getLogger(__name__)

_SUBJECT_KEYS = ("code", "body_mass_kg", "upper_arm_m", "forearm_m", "side")


@dataclass(frozen=True, slots=True)
class TrialInfo:
    """A trial file's metadata, without its samples."""

    path: Path
    status: str
    subject: SubjectInfo | None
    parameters: TrialParameters | None
    parameter_values: Mapping
    metrics: Mapping[str, float]
    summary: Mapping
    attributes: Mapping
    sample_period_s: float
    n_samples: int
    created_utc: str
    backend: str
    software_version: str
    format_version: int
    notes: tuple[str, ...]
    seal: str
    """How far the file was verified (app.trials.reader: SEALED, UNSEALED_OLDER, …)."""

    @property
    def sampling_frequency_hz(self) -> float:
        return 1.0 / self.sample_period_s

    @property
    def recorded_s(self) -> float:
        """Samples × sample period: the time the file covers, s."""
        return self.n_samples * self.sample_period_s

    @property
    def task(self) -> str | None:
        """The exercise's shape (d, circle, reach, targets, figure8), if recorded."""
        shape = self.parameter_values.get("shape")
        return shape if isinstance(shape, str) else None

    def row(self, folder: Path | None = None) -> dict:
        """The trial's metadata as one flat row (keys as in app.exports.loader's doc)."""
        try:
            file = self.path.relative_to(folder).as_posix() if folder else self.path.name
        except ValueError:
            file = self.path.as_posix()
        row = {
            "file": file,
            "status": self.status,
            "seal": self.seal,
            "created_utc": self.created_utc,
            "backend": self.backend,
            "software_version": self.software_version,
            "format_version": self.format_version,
            "n_samples": self.n_samples,
            "sample_period_s": self.sample_period_s,
            "recorded_s": self.recorded_s,
        }
        subject = self.subject.to_dict() if self.subject else {}
        row |= {f"subject_{key}": subject.get(key) for key in _SUBJECT_KEYS}
        row |= flat_parameters(self.parameter_values)
        row |= {f"metric_{name}": value for name, value in self.metrics.items()}
        return row


@dataclass(frozen=True, slots=True, eq=False)
class Trial(TrialInfo):
    """A whole trial: its metadata and its channels, each a read-only array with
    one row per sample. `trial[name]` is the channel; iterating gives the names."""

    arrays: Mapping[str, np.ndarray]
    units: Mapping[str, str]
    frames: Mapping[str, str]
    descriptions: Mapping[str, str]
    events: tuple[dict, ...]

    # Arrays have no single truth value, so equality is identity.
    __eq__ = object.__eq__
    __hash__ = object.__hash__

    @property
    def groups(self) -> Mapping[str, Mapping]:
        """The groups beside the samples that the file has (app.trials.reader.BESIDE_GROUPS:
        `assistance`, `pose`, `emg`), each with its own time base: attributes, arrays and
        subgroups by name (docs/data-format.md). Read from the file when asked (the `.mat`
        export): a CSV or BIDS export of a trial with an hour of EMG need not load it."""
        return MappingProxyType(read_groups(self.path))

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.arrays[name]
        except KeyError:
            raise KeyError(f"the trial has no channel {name!r}; it has "
                           f"{', '.join(self.arrays)}") from None

    def __contains__(self, name: object) -> bool:
        return name in self.arrays

    def __iter__(self) -> Iterator[str]:
        return iter(self.arrays)

    def __len__(self) -> int:
        return len(self.arrays)

    def keys(self):
        return self.arrays.keys()

    def items(self):
        return self.arrays.items()

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.arrays)

    @property
    def time(self) -> np.ndarray:
        """Nominal trial time of each sample, s."""
        return self["time"]

    @property
    def exercise(self) -> np.ndarray:
        """True for the samples of the exercise phase (not the approach, not the hold)."""
        if "phase" not in self.arrays:
            raise TrialFileError(self.path, "has no 'phase' channel, so its exercise phase "
                                 "is unknown", "Use the whole trial (exercise_only=False).")
        mask = np.asarray(self.arrays["phase"]) == PHASE_EXERCISE
        mask.flags.writeable = False
        return mask

    def channel(self, name: str, exercise_only: bool = False) -> np.ndarray:
        """One channel, all samples or only those of the exercise phase."""
        values = self[name]
        return values[self.exercise] if exercise_only else values

    def components(self, name: str) -> tuple[str, ...]:
        """The component labels of a channel ('x', 'y'; '1', '2'; 'shoulder', 'elbow'…)."""
        values = self[name]
        width = 1 if values.ndim == 1 else int(np.prod(values.shape[1:]))
        return components(self.frames.get(name, ""), width)

    def table(self, exercise_only: bool = False) -> dict[str, np.ndarray]:
        """One 1-D array per channel component, named as the CSV export names them."""
        arrays = self.arrays
        if exercise_only:
            mask = self.exercise
            arrays = {name: values[mask] for name, values in arrays.items()}
        columns = table_columns(arrays, self.units, self.frames, self.descriptions)
        return {c.name: column_values(arrays, c) for c in columns}

    def events_of(self, kind: str) -> list[dict]:
        """The events of one kind ('start', 'stop', 'fault', 'mark', 'note'…)."""
        return [e for e in self.events if e["kind"] == kind]


def load_trial(path: str | os.PathLike) -> Trial:
    """Read a whole trial file; raises TrialFileError if it cannot be trusted."""
    return trial_of(read_trial(path))


def read_info(path: str | os.PathLike) -> TrialInfo:
    """Read a trial file's metadata without its samples; raises TrialFileError."""
    path = Path(path)
    try:
        info = _read_info(path)
    except (OSError, RuntimeError, ValueError, KeyError, TypeError, AttributeError,
            IndexError, Damaged) as exc:
        # a damaged layout (a group where a dataset should be, …) surfaces as any of these
        log.debug("%s: quick metadata read failed (%s); reading it whole", path, exc)
        info = None
    if info is None:
        # Anything unusual (not closed, damaged, not a trial file) goes through the
        # console's reader, which recovers what it can or says what is wrong.
        return _info(read_trial(path))
    return info


def flat_parameters(values: Mapping) -> dict:
    """`parameter_<name>` for each value; points (pairs) split into x and y before the
    unit (`centre_m` → `parameter_centre_x_m`, `parameter_centre_y_m`)."""
    row = {}
    for name, value in values.items():
        if isinstance(value, list | tuple) and len(value) == 2 and name.endswith("_m"):
            base = name[:-2]
            row[f"parameter_{base}_x_m"], row[f"parameter_{base}_y_m"] = value
        elif isinstance(value, list | tuple):
            row |= {f"parameter_{name}_{i + 1}": v for i, v in enumerate(value)}
        else:
            row[f"parameter_{name}"] = value
    return row


# -- building ------------------------------------------------------------------


def _info_values(data: TrialData) -> dict:
    return {
        "path": data.path,
        "status": data.status,
        "subject": data.subject,
        "parameters": data.parameters,
        "parameter_values": MappingProxyType(_parameter_values(data.attrs)),
        "metrics": MappingProxyType(dict(data.metrics)),
        "summary": MappingProxyType(dict(data.summary)),
        "attributes": MappingProxyType(dict(data.attrs)),
        "sample_period_s": data.sample_period_s,
        "n_samples": data.n_samples,
        "created_utc": data.created_utc,
        "backend": data.backend,
        "software_version": data.software_version,
        "format_version": data.format_version,
        "notes": data.notes,
        "seal": data.seal,
    }


def _info(data: TrialData) -> TrialInfo:
    return TrialInfo(**_info_values(data))


def trial_of(data: TrialData) -> Trial:
    """A trial already read (app.trials.reader.read_trial, all its channels or some) as the
    loader's Trial."""
    return Trial(
        **_info_values(data),
        arrays=MappingProxyType(dict(data.channels)),
        units=MappingProxyType(dict(data.units)),
        frames=MappingProxyType(dict(data.frames)),
        descriptions=MappingProxyType(dict(data.descriptions)),
        events=tuple(data.events),
    )


def _parameter_values(attrs: Mapping) -> dict:
    try:
        values = json.loads(attrs.get("parameters", "{}"))
    except (TypeError, ValueError):
        return {}
    return values if isinstance(values, dict) else {}


def _read_info(path: Path) -> TrialInfo | None:
    """The quick path: attributes only, checked as the full reader checks them (the file's
    structure, its seal's parts for the root, the parameters, the channel table, the summary
    and the metrics). None when the file needs the full reader, which recovers what it can
    or says what is wrong."""
    with held(path):  # one thread at a time in a trial file (verify.held)
        return _quick_info(path)


def _quick_info(path: Path) -> TrialInfo | None:
    check_heaps(path)  # before libhdf5 reads a text attribute (app.trials.reader)
    with h5py.File(path, "r", locking=False) as f:  # as app.trials.reader opens it
        found = inventory(f, path.stat().st_size)
        attrs = _plain(found, "/")
        version = attrs.get("format_version")
        period = attrs.get("sample_period_s")
        status = attrs.get("status")
        if (attrs.get("format") != FORMAT_NAME or not isinstance(version, int)
                or isinstance(version, bool) or not 1 <= version <= FORMAT_VERSION
                or not isinstance(period, float) or not math.isfinite(period) or period <= 0
                or not isinstance(status, str) or status == STATUS_RECORDING
                or not {"/timeseries", "/channels", "/events"} <= found.paths):
            return None
        seal, mark, notes = seal_of(f, found, attrs)
        if (seal is None and mark != UNSEALED_OLDER) or (notes and seal is not None):
            return None  # the full reader says how far such a file verifies
        if seal is not None:
            seal.check("/channels", found)
            for room in ("/parameters", "/timeseries", "/summary", "/metrics"):
                seal.check_room(found, room, skip={p for p in found.datasets
                                                   if p.startswith("/timeseries/")})
        lengths = {d.shape[0] for d in h5views.values(f["timeseries"])}
        if len(lengths) > 1:
            return None
        n = lengths.pop() if lengths else 0
        if n and "tick" in f["timeseries"] and f["timeseries/tick"][n - 1] == -1:
            return None
        metrics = drop_old_share({k: float(v) for k, v in _plain(found, "/metrics").items()})
        summary = _plain(found, "/summary")
        if seal is not None and summary.get("n_samples") != n:
            return None  # the samples' count is sealed in the summary; they disagree
    values = _parameter_values(attrs)
    parameters, more = parameters_from_attributes(attrs)
    notes += more
    subject, subject_notes = subject_from_attributes(attrs)
    notes += subject_notes
    return TrialInfo(
        path=path, status=status, subject=subject, parameters=parameters,
        parameter_values=MappingProxyType(values), metrics=MappingProxyType(metrics),
        summary=MappingProxyType(summary), attributes=MappingProxyType(attrs),
        sample_period_s=period, n_samples=n, created_utc=str(attrs.get("created_utc", "")),
        backend=str(attrs.get("backend", "")),
        software_version=str(attrs.get("software_version", "")), format_version=version,
        notes=tuple(notes), seal=mark,
    )


def _plain(found, path: str) -> dict:
    return {key: plain_attribute(value) for key, value in found.attrs.get(path, {}).items()}
