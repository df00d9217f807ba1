"""Reading a trial file (docs/data-format.md) into memory, also while it is being recorded.

A file that cannot be trusted raises `TrialFileError` naming the file, the problem
and what to do. A file that is sound but incomplete — still being recorded, or
left behind by a crash — is read as far as it goes, and `TrialData.notes` says
what was recovered.
"""

from __future__ import annotations

import json
import math
import os
import re
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from app.errors import TrialFileError
from app.trials.assistance_timeline import AssistanceInEffect, assistance_in_effect
from core.errors import CoreError
from core.trial import TrialParameters
from device.errors import RecordingError
from device.recording.trialfile import FORMAT_NAME, FORMAT_VERSION, STATUS_RECORDING, SubjectInfo

# A writer's final reopen (docs/data-format.md, "Closing") takes milliseconds;
# a reader that meets it waits that long rather than failing.
_BUSY_RETRY_S = 2.0
_BUSY_PAUSE_S = 0.1

_RESTORE = "Restore it from the backup or the original"


@dataclass(frozen=True, slots=True)
class TrialData:
    """One trial file in memory. Arrays are read-only; channels keep the file's order."""

    path: Path
    channels: dict[str, np.ndarray]
    units: dict[str, str]
    frames: dict[str, str]
    descriptions: dict[str, str]
    parameters: TrialParameters | None
    subject: SubjectInfo | None
    robot: dict
    backend: str
    events: list[dict]
    metrics: dict[str, float]
    summary: dict
    status: str
    sample_period_s: float
    format_version: int
    software_version: str
    created_utc: str
    attrs: dict
    notes: tuple[str, ...]
    assistance: dict = field(default_factory=dict)
    """The /assistance group (docs/data-format.md): its attributes (the mode, the level,
    the guidance's gains) and its arrays (`feedforward_N`, repetitions × bins); {} in a
    file written before the modes existed."""

    @property
    def time(self) -> np.ndarray:
        """Nominal trial time of each sample, s."""
        return self.channels["time"]

    @property
    def n_samples(self) -> int:
        return next(iter(self.channels.values())).shape[0] if self.channels else 0

    @property
    def closed(self) -> bool:
        """False while recording, or when the recorder stopped without closing the file."""
        return self.status != STATUS_RECORDING

    def assistance_in_effect(self) -> AssistanceInEffect:
        """The assistance levels the trial ran with, from its `assistance_level` channel (or,
        in a file without it, the built level and the `assistance` events): `.at_start`,
        `.at_end` (of the exercise), `.changes`, `.summary()` ('100 % → 60 % at 5.8 s');
        app.trials.assistance_timeline. A partial read needs its CHANNELS_NEEDED."""
        built = (self.parameters.assistance_level if self.parameters is not None
                 else float(self.assistance.get("level", math.nan)))
        return assistance_in_effect(self.channels, self.events, built, self.sample_period_s,
                                    self.summary)

    def assistance_timeline(self) -> tuple[tuple[float, float], ...]:
        """((0.0, level at the exercise's start), (t, new level), …), t in s from the
        exercise's start, levels 0–1: what the trial ran, never the form."""
        return self.assistance_in_effect().timeline


def read_trial(path: str | os.PathLike, channels: Iterable[str] | None = None) -> TrialData:
    """Read a trial file; raise TrialFileError if it cannot be trusted.

    `channels` names the channels to read (with `tick` and `time`, which every read
    checks), for a reader that needs only some of a long trial's samples in memory (the
    metrics); all of them by default."""
    path = Path(path)
    _check_file(path)
    f = _open(path)
    try:
        return _read(path, f, None if channels is None else {"tick", "time", *channels})
    except TrialFileError:
        raise
    except (OSError, RuntimeError, ValueError, KeyError, TypeError) as exc:
        raise TrialFileError(
            path, f"is damaged: reading it failed ({exc})", _RESTORE + "."
        ) from exc
    finally:
        f.close()


# -- opening ----------------------------------------------------------------


def _check_file(path: Path) -> None:
    if not path.exists():
        raise TrialFileError(
            path, "does not exist",
            "Check the path; if the registry lists it, the file was moved or deleted. "
            + _RESTORE + ".",
        )
    if not path.is_file():
        raise TrialFileError(path, "is not a file (a folder?)", "Choose the trial's .h5 file.")
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise TrialFileError(path, f"cannot be examined ({exc})", "Check the disk.") from exc
    if size == 0:
        raise TrialFileError(
            path, "is empty (0 bytes): nothing was ever written to it",
            "No data can be recovered from it; record the trial again or restore the file "
            "from the backup.",
        )
    try:
        is_hdf5 = h5py.is_hdf5(path)
    except OSError as exc:
        raise TrialFileError(path, f"cannot be read ({exc})",
                             "Check its permissions and the disk.") from exc
    if not is_hdf5:
        raise TrialFileError(
            path, f"is not an HDF5 file ({size} bytes without the HDF5 signature): it is "
            "another kind of file or badly damaged",
            "Choose the trial's .h5 file. " + _RESTORE + ".",
        )


def _open(path: Path) -> h5py.File:
    deadline = time.monotonic() + _BUSY_RETRY_S
    while True:
        try:
            # A closed file opens normally. One being recorded (or left behind by a
            # crash) carries HDF5's "open for writing" flag and opens only as an
            # SWMR reader, which sees every flushed sample. Without HDF5's file locks,
            # as every other open of a trial file in the window's process (the metrics,
            # the EMG and the pose written beside it): HDF5 refuses a second open of a
            # file in one process with the other locking flag ("file locking flag values
            # don't match"), which failed a read while the window stored a trial's EMG.
            try:
                return h5py.File(path, "r", locking=False)
            except OSError as exc:
                if not _open_for_write(exc):
                    raise
            return h5py.File(path, "r", swmr=True, locking=False)
        except OSError as exc:
            if _open_for_write(exc) and time.monotonic() < deadline:
                time.sleep(_BUSY_PAUSE_S)
                continue
            raise _open_error(path, exc) from exc


def _open_for_write(exc: OSError) -> bool:
    text = str(exc)
    return "already open for write" in text or "unable to lock file" in text


def _open_error(path: Path, exc: OSError) -> TrialFileError:
    text = str(exc)
    truncated = re.search(r"truncated file: eof = (\d+).*stored_eof = (\d+)", text)
    if truncated:
        have, need = int(truncated.group(1)), int(truncated.group(2))
        return TrialFileError(
            path, f"is truncated: it holds {have} bytes of the {need} its header records, so it "
            "was cut short (an interrupted copy or download, or a full disk)",
            "Copy it again from the original, or restore it from the backup.",
        )
    if _open_for_write(exc):
        return TrialFileError(
            path, "is held open for writing by another program, not in the recorder's "
            "live (SWMR) mode",
            "Close the program that has it open; if none does, it was left so by a crash "
            "while the trial was being closed: run `h5clear -s` on a copy of the file.",
        )
    if isinstance(exc, PermissionError):
        return TrialFileError(path, "cannot be read: permission denied",
                              "Check the file's permissions.")
    return TrialFileError(path, f"cannot be opened as HDF5 ({text}); it is damaged",
                          _RESTORE + ".")


# -- reading ----------------------------------------------------------------


def _read(path: Path, f: h5py.File, only: set[str] | None) -> TrialData:
    attrs = {key: plain_attribute(value) for key, value in f.attrs.items()}
    _check_format(path, attrs)
    notes: list[str] = []
    for name in ("timeseries", "channels", "events"):
        if name not in f:
            raise TrialFileError(path, f"is damaged: it has no /{name}", _RESTORE + ".")

    status = str(attrs.get("status", ""))
    if status == STATUS_RECORDING:
        notes.append(
            "the file is not closed: it is still being recorded, or the recorder stopped "
            "without closing it (crash or power cut); every sample flushed before then is here"
        )

    order = [_text(row["name"]) for row in f["channels"][()]]
    series = f["timeseries"]
    for name in order:
        if name not in series:
            raise TrialFileError(
                path, f"is damaged: the channel table lists {name} but /timeseries has no such "
                "dataset", _RESTORE + ".",
            )
    order += sorted(set(series) - set(order))
    datasets = {name: series[name] for name in order}
    for name, dataset in datasets.items():
        if not isinstance(dataset, h5py.Dataset):
            raise TrialFileError(path, f"is damaged: /timeseries/{name} is not a dataset",
                                 _RESTORE + ".")
    channels, trim_notes = _read_channels(path, datasets, only)
    notes += trim_notes
    _check_samples(path, channels)

    parameters, note = parameters_from_attributes(attrs)
    notes += note
    subject, note = subject_from_attributes(attrs)
    notes += note
    robot, note = _json_attr(attrs, "robot")
    notes += note
    events, note = _events(f["events"])
    notes += note

    return TrialData(
        path=path,
        channels=channels,
        units={n: _text(d.attrs.get("units", "")) for n, d in datasets.items()},
        frames={n: _text(d.attrs.get("frame", "")) for n, d in datasets.items()},
        descriptions={n: _text(d.attrs.get("description", "")) for n, d in datasets.items()},
        parameters=parameters,
        subject=subject,
        robot=robot if isinstance(robot, dict) else {},
        backend=str(attrs.get("backend", "")),
        events=events,
        metrics={k: float(v) for k, v in group_attributes(f, "metrics").items()},
        summary=group_attributes(f, "summary"),
        status=status,
        sample_period_s=float(attrs["sample_period_s"]),
        format_version=int(attrs["format_version"]),
        software_version=str(attrs.get("software_version", "")),
        created_utc=str(attrs.get("created_utc", "")),
        attrs=attrs,
        notes=tuple(notes),
        assistance=_assistance(f),
    )


def _check_format(path: Path, attrs: dict) -> None:
    name = attrs.get("format")
    if name != FORMAT_NAME:
        found = "has no 'format' attribute" if name is None else f"has format {name!r}"
        raise TrialFileError(
            path, f"is an HDF5 file but not a rehab-console trial file (it {found})",
            "Choose a trial file recorded by the console.",
        )
    version = attrs.get("format_version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise TrialFileError(
            path, f"has an invalid format_version {version!r}", _RESTORE + "."
        )
    if version > FORMAT_VERSION:
        raise TrialFileError(
            path, f"was written in trial-file format version {version} (by rehab-console "
            f"{attrs.get('software_version', '?')}); this console reads up to version "
            f"{FORMAT_VERSION}",
            "Update the console to read it.",
        )
    period = attrs.get("sample_period_s")
    if not isinstance(period, float) or not math.isfinite(period) or period <= 0:
        raise TrialFileError(path, f"has an invalid sample_period_s {period!r}", _RESTORE + ".")


def _check_samples(path: Path, channels: dict) -> None:
    """What every trial file's samples satisfy, whoever wrote it: `tick` whole numbers
    from 0 that only increase, and `time` finite seconds that only increase. A file that
    breaks one was damaged (a bit flipped in a
    file written before checksums, an edited file) and is refused, naming the dataset."""
    def refuse(name: str, problem: str) -> None:
        raise TrialFileError(path, f"is damaged: /timeseries/{name} {problem}", _RESTORE + ".")

    for name in ("tick", "time"):
        values = channels.get(name)
        if values is None or values.size == 0:
            continue
        if values.dtype.kind not in ("iu" if name == "tick" else "f"):
            refuse(name, f"holds {values.dtype} values, not "
                   + ("whole numbers" if name == "tick" else "seconds"))
        if name == "time" and not np.isfinite(values).all():
            bad = int(np.flatnonzero(~np.isfinite(values))[0])
            refuse(name, f"is {values[bad]} at sample {bad}")
        if name == "tick" and values[0] < 0:
            refuse(name, f"starts at {values[0]}, below 0")
        step = np.diff(values.astype(float) if name == "time" else values)
        if values.size > 1 and not (step > 0).all():
            bad = int(np.flatnonzero(~(step > 0))[0])
            refuse(name, f"goes from {values[bad]} to {values[bad + 1]} at sample {bad + 1}; "
                   "it only ever increases")


def _read_channels(path: Path, datasets: dict[str, h5py.Dataset],
                   only: set[str] | None = None) -> tuple[dict, list[str]]:
    notes = []
    lengths = {name: d.shape[0] for name, d in datasets.items()}
    n = min(lengths.values(), default=0)
    longest = max(lengths.values(), default=0)
    if n != longest:
        notes.append(
            f"the channels had unequal lengths ({n} to {longest} samples), as when the recorder "
            f"stops between writes; every channel was trimmed to the shortest, {n} samples"
        )
    channels = {}
    for name, dataset in datasets.items():
        if only is not None and name not in only:
            continue  # its length still counts above: every channel is trimmed alike
        try:
            channels[name] = dataset[:n]
        except OSError as exc:
            # Fletcher-32 (and any other filter) fails the read of a damaged chunk
            raise TrialFileError(
                path, f"is damaged: /timeseries/{name} does not match its checksum ({exc}); "
                "a bit changed on the disk or in a copy", _RESTORE + ".") from exc
    # Rows extended but never written read as the fill value; -1 is no tick.
    tick = channels.get("tick")
    if tick is not None and tick.ndim == 1 and n and tick[-1] == -1:
        written = int(np.flatnonzero(tick != -1)[-1]) + 1 if (tick != -1).any() else 0
        notes.append(
            f"the last {n - written} samples were reserved but never written (tick = -1) and "
            "were dropped"
        )
        channels = {name: values[:written] for name, values in channels.items()}
    for values in channels.values():
        values.flags.writeable = False
    return channels, notes


def parameters_from_attributes(attrs: dict) -> tuple[TrialParameters | None, list[str]]:
    """The trial's parameters from a file's root attributes, or None with why."""
    values, notes = _json_attr(attrs, "parameters")
    if values is None:
        return None, notes
    try:
        return TrialParameters.from_dict(values), notes
    except (CoreError, TypeError, ValueError) as exc:
        return None, [f"the trial parameters could not be rebuilt ({exc}); the stored values "
                      "are in attrs['parameters']"]


def subject_from_attributes(attrs: dict) -> tuple[SubjectInfo | None, list[str]]:
    """The subject from a file's root attributes, or None with why."""
    values, notes = _json_attr(attrs, "subject")
    if values is None:
        return None, notes
    try:
        return SubjectInfo.from_dict(values), notes
    except (RecordingError, TypeError, AttributeError) as exc:
        return None, [f"the subject data could not be rebuilt ({exc}); the stored values are "
                      "in attrs['subject']"]


def _json_attr(attrs: dict, key: str):
    if key not in attrs:
        return None, [f"the file has no '{key}' attribute"]
    try:
        return json.loads(attrs[key]), []
    except (TypeError, ValueError) as exc:
        return None, [f"the '{key}' attribute is not valid JSON ({exc})"]


def _events(dataset: h5py.Dataset) -> tuple[list[dict], list[str]]:
    events, notes = [], []
    for row in dataset[()]:
        kind = _text(row["kind"])
        if not kind:
            # Reserved by a resize the writer did not live to fill.
            continue
        raw = _text(row["values"])
        try:
            values = json.loads(raw) if raw else {}
        except ValueError:
            values = {"raw": raw}
            notes.append(f"the values of the {kind!r} event at tick {int(row['tick'])} are not "
                         "valid JSON; kept as text under 'raw'")
        events.append({
            "time_s": float(row["time_s"]),
            "tick": int(row["tick"]),
            "kind": kind,
            "message": _text(row["message"]),
            "values": values,
        })
    return events, notes


BESIDE_GROUPS = ("assistance", "pose", "emg")
"""The groups written beside a trial's samples, each with its own layout and time base
(docs/data-format.md): the assistance's learned feedforward, the camera's pose, the EMG."""


def read_groups(path: str | os.PathLike, names: Iterable[str] = BESIDE_GROUPS) -> dict:
    """The named groups the file has, each as a dict: its attributes, its datasets as
    arrays (a table of columns as a dict of columns, text decoded) and its subgroups as
    dicts, for a researcher's export (app.exports); raises TrialFileError naming the file
    when one cannot be read."""
    path = Path(path)
    f = _open(path)
    try:
        return {name: _group_dict(f[name]) for name in names
                if isinstance(f.get(name), h5py.Group)}
    except (OSError, RuntimeError, ValueError, KeyError, TypeError) as exc:
        raise TrialFileError(path, f"is damaged: reading its groups failed ({exc})",
                             _RESTORE + ".") from exc
    finally:
        f.close()


def _group_dict(group: h5py.Group) -> dict:
    out = {key: plain_attribute(value) for key, value in group.attrs.items()}
    for name, item in group.items():
        if isinstance(item, h5py.Group):
            out[name] = _group_dict(item)
            continue
        values = item[()]
        if isinstance(values, np.ndarray) and values.dtype.names:
            out[name] = {column: _column(values[column]) for column in values.dtype.names}
        else:
            out[name] = _column(values)
    return out


def _column(values):
    """Text (bytes from HDF5) as str, numbers as they are."""
    if isinstance(values, bytes):
        return values.decode("utf-8", "replace")
    if isinstance(values, np.ndarray) and values.dtype.kind in "OS":
        return np.array([_column(v) for v in values.ravel()], dtype=object).reshape(
            values.shape)
    return values


def _assistance(f: h5py.File) -> dict:
    group = f.get("assistance")
    if not isinstance(group, h5py.Group):
        return {}
    arrays = {name: np.asarray(item[()], dtype=float) for name, item in group.items()
              if isinstance(item, h5py.Dataset)}
    return {**group_attributes(f, "assistance"), **arrays}


def group_attributes(f: h5py.File, name: str) -> dict:
    """A group's attributes as plain values, {} when the group is absent."""
    if name not in f:
        return {}
    return {key: plain_attribute(value) for key, value in f[name].attrs.items()}


def _text(value) -> str:
    if isinstance(value, bytes | np.bytes_):
        return bytes(value).rstrip(b"\0").decode("utf-8", "replace")
    return str(value)


def plain_attribute(value):
    """Attribute values as Python scalars and str; arrays stay arrays."""
    if isinstance(value, bytes | np.bytes_ | str):
        return _text(value)
    if isinstance(value, np.ndarray):
        return value
    if isinstance(value, np.generic):
        return value.item()
    return value
