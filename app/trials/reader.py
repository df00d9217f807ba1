"""Reading a trial file (docs/data-format.md) into memory, also while it is being recorded.

A file that cannot be trusted raises `TrialFileError` naming the file, the problem
and what to do. A file that is sound but incomplete — still being recorded, or
left behind by a crash — is read as far as it goes, and `TrialData.notes` says
what was recovered.

Before h5py reads a value, the file's structure is checked (device.recording.trialfile.
verify: no heap libhdf5 would loop on, no link, no virtual or external dataset, no size
beyond the file's), and what is read is compared with the file's seal
(device.recording.trialfile.seal); `TrialData.seal` says how far it was verified, and a
file written before seals existed says so in its notes (docs/data-format.md, "The seal").
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from app.errors import TrialFileError
from app.trials import checks
from app.trials.assistance_timeline import AssistanceInEffect, assistance_in_effect
from app.trials.opening import (
    RESTORE,
    SEALED,
    check_file,
    one_line,
    open_trial_file,
    seal_of,
)
from core.errors import CoreError
from core.trial import TrialParameters
from core.work import drop_old_share
from device.errors import RecordingError
from device.recording import h5views
from device.recording.trialfile import FORMAT_NAME, FORMAT_VERSION, STATUS_RECORDING, SubjectInfo
from device.recording.trialfile.verify import Damaged, Inventory, held, inventory


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
    seal: str = SEALED
    """How far the file was verified: SEALED, HEADER_ONLY, CLOSE_INTERRUPTED or
    UNSEALED_OLDER (never shown as verified when it was not)."""
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
    check_file(path)
    with held(path):
        return _read_trial(path, None if channels is None else {"tick", "time", *channels})


def _read_trial(path: Path, only: set[str] | None) -> TrialData:
    f = open_trial_file(path)
    try:
        return _read(path, f, only)
    except TrialFileError:
        raise
    except Damaged as exc:
        raise TrialFileError(path, exc.problem, RESTORE + ".") from None
    except (OSError, RuntimeError, ValueError, KeyError, TypeError) as exc:
        raise TrialFileError(
            path, f"is damaged: reading it failed ({one_line(exc)})", RESTORE + "."
        ) from exc
    finally:
        f.close()


# -- reading ----------------------------------------------------------------


def _read(path: Path, f: h5py.File, only: set[str] | None) -> TrialData:
    found = inventory(f, os.path.getsize(path))
    attrs = _plain(found, "/")
    _check_format(path, attrs)
    for name in ("timeseries", "channels", "events"):
        if f"/{name}" not in found.paths:
            raise TrialFileError(path, f"is damaged: it has no /{name}", RESTORE + ".")
    if "/timeseries" not in found.groups or "/channels" not in found.datasets \
            or "/events" not in found.datasets:
        raise Damaged("is damaged: /timeseries is not a group, or /channels or /events not a "
                      "dataset")
    status = str(attrs.get("status", ""))
    seal, mark, notes = seal_of(f, found, attrs)
    if status == STATUS_RECORDING:
        notes.append(
            "the file is not closed: it is still being recorded, or the recorder stopped "
            "without closing it (crash or power cut); every sample flushed before then is here"
        )

    table = f["channels"][()]
    if table.dtype.names is None or not {"name", "width", "dtype"} <= set(table.dtype.names):
        raise Damaged("is damaged: /channels is not the channel table (name, width, dtype, "
                      "units, frame, description)")
    if seal is not None:
        seal.check("/channels", found, table)
        for room in ("/parameters", "/timeseries", "/summary", "/metrics", "/assistance"):
            seal.check_room(found, room, skip={p for p in found.datasets
                                               if p.startswith("/timeseries/")})
    order = [_text(row["name"]) for row in table]
    series = f["timeseries"]
    for name in order:
        if f"/timeseries/{name}" not in found.datasets:
            raise TrialFileError(
                path, f"is damaged: the channel table lists {name} but /timeseries has no such "
                "dataset", RESTORE + ".",
            )
    order += sorted(set(series) - set(order))
    datasets = {name: series[name] for name in order}
    for name in datasets:
        if f"/timeseries/{name}" not in found.datasets:
            raise TrialFileError(path, f"is damaged: /timeseries/{name} is not a dataset",
                                 RESTORE + ".")
    checks.check_channel_datasets(table, datasets, _text)
    channels, trim_notes = _read_channels(path, datasets, only)
    notes += trim_notes
    if seal is not None:
        for name, values in channels.items():
            seal.check(f"/timeseries/{name}", found, values)
    checks.check_samples(channels)

    parameters, note = parameters_from_attributes(attrs)
    notes += note
    subject, note = subject_from_attributes(attrs)
    notes += note
    robot, note = _json_attr(attrs, "robot")
    notes += note
    event_rows = f["events"][()]
    if seal is not None:
        seal.check("/events", found, event_rows)
    events, note = _events(event_rows)
    notes += note

    return TrialData(
        path=path,
        channels=channels,
        units={n: _text(found.attrs[f"/timeseries/{n}"].get("units", "")) for n in datasets},
        frames={n: _text(found.attrs[f"/timeseries/{n}"].get("frame", "")) for n in datasets},
        descriptions={n: _text(found.attrs[f"/timeseries/{n}"].get("description", ""))
                      for n in datasets},
        parameters=parameters,
        subject=subject,
        robot=robot if isinstance(robot, dict) else {},
        backend=str(attrs.get("backend", "")),
        events=events,
        metrics=_metrics(found),
        summary=_plain(found, "/summary"),
        status=status,
        sample_period_s=float(attrs["sample_period_s"]),
        format_version=int(attrs["format_version"]),
        software_version=str(attrs.get("software_version", "")),
        created_utc=str(attrs.get("created_utc", "")),
        attrs=attrs,
        notes=tuple(notes),
        seal=mark,
        assistance=_assistance(f, found),
    )


def _plain(found: Inventory, path: str) -> dict:
    """A group's attributes as plain values (read once by the structure walk), {} when the
    group is absent."""
    return {key: plain_attribute(value) for key, value in found.attrs.get(path, {}).items()}


def _metrics(found: Inventory) -> dict[str, float]:
    values = _plain(found, "/metrics")
    wrong = sorted(k for k, v in values.items()
                   if isinstance(v, bool) or not isinstance(v, int | float))
    if wrong:
        raise Damaged(f"is damaged: /metrics {', '.join(wrong[:3])} is not a number")
    return drop_old_share({k: float(v) for k, v in values.items()})


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
            path, f"has an invalid format_version {version!r}", RESTORE + "."
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
        raise TrialFileError(path, f"has an invalid sample_period_s {period!r}", RESTORE + ".")


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
                "a bit changed on the disk or in a copy", RESTORE + ".") from exc
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
    """A root attribute's JSON object, or None with a note when the file has none; Damaged
    when it is there but not a JSON object."""
    value = checks.json_object_attribute(attrs, key)
    if value is None:
        return None, [f"the file has no '{key}' attribute"]
    return value, []


def _events(rows: np.ndarray) -> tuple[list[dict], list[str]]:
    events, notes = [], []
    if rows.dtype.names is None or not {"time_s", "tick", "kind", "message", "values"} <= set(
            rows.dtype.names):
        raise Damaged("is damaged: /events is not the events table (time_s, tick, kind, "
                      "message, values)")
    for row in rows:
        kind = _text(row["kind"])
        if not kind:
            # Reserved by a resize the writer did not live to fill.
            continue
        raw = _text(row["values"])
        try:
            values = json.loads(raw) if raw else {}
        except ValueError:
            values = None
        if not isinstance(values, dict):
            values = {"raw": raw}
            notes.append(f"the values of the {kind!r} event at tick {int(row['tick'])} are not "
                         "a JSON object; kept as text under 'raw'")
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
    with held(path):
        return _read_groups(path, names)


def _read_groups(path: Path, names: Iterable[str]) -> dict:
    f = open_trial_file(path)
    try:
        found = inventory(f, os.path.getsize(path))
        attrs = {key: plain_attribute(value) for key, value in h5views.items(f.attrs)}
        _check_format(path, attrs)
        seal, _, _ = seal_of(f, found, attrs)
        chosen = [name for name in names if f"/{name}" in found.groups]
        if seal is not None:
            for name in chosen:
                seal.check_room(found, f"/{name}")
        return {name: _group_dict(f[name]) for name in chosen}
    except Damaged as exc:
        raise TrialFileError(path, exc.problem, RESTORE + ".") from None
    except (OSError, RuntimeError, ValueError, KeyError, TypeError) as exc:
        raise TrialFileError(path, f"is damaged: reading its groups failed "
                             f"({one_line(exc)})", RESTORE + ".") from exc
    finally:
        f.close()


def _group_dict(group: h5py.Group) -> dict:
    out = {key: plain_attribute(value) for key, value in h5views.items(group.attrs)}
    for name, item in h5views.items(group):
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


def _assistance(f: h5py.File, found: Inventory) -> dict:
    if "/assistance" not in found.groups:
        return {}
    arrays = {name[len("/assistance/"):]: np.asarray(item[()], dtype=float)
              for name, item in found.datasets.items() if name.startswith("/assistance/")}
    return {**_plain(found, "/assistance"), **arrays}


def group_attributes(f: h5py.File, name: str) -> dict:
    """A group's attributes as plain values, {} when the group is absent."""
    if name not in f:
        return {}
    return {key: plain_attribute(value) for key, value in h5views.items(f[name].attrs)}


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
