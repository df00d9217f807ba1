"""The trial file's `/emg` group: surface EMG beside the robot's samples (docs/data-format.md,
"EMG").

EMG has its own rate (about 1926 Hz for a Delsys Trigno, against the loop's 500 Hz), so
it is its own group with its own time stamps, already on the trial's clock:
`/emg/time` is trial time in s (the clock of `/timeseries/time`; negative before the
trial started), `/emg/samples` the raw EMG in V, `/emg/channels` one row per electrode
with the muscle under it, and `/emg/mvc/<muscle>` each muscle's MVC for the session
with its quality flags. Written to a closed trial file (after the recorder closed it,
like `/metrics`), checksummed like every other dataset.
"""

from __future__ import annotations

import itertools
import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from device.errors import RecordingError
from device.recording import h5views
from device.recording.trialfile import open_for_update, refuse_while_recording, utc_now_iso
from device.recording.trialfile.seal import open_room
from device.recording.trialfile.verify import Damaged, held

GROUP = "emg"
CHUNK_ROWS = 4096  # about 2 s at the Trigno's rate
_CHANNEL_DTYPE = np.dtype([
    ("name", h5py.string_dtype()),
    ("muscle", h5py.string_dtype()),
    ("units", h5py.string_dtype()),
])


@dataclass(frozen=True, slots=True, eq=False)
class EmgGroup:
    """A trial file's `/emg` group in memory."""

    names: tuple[str, ...]
    muscles: tuple[str, ...]
    rate_hz: float
    time_s: np.ndarray  # (M,) trial time
    samples: np.ndarray  # (M, C) V
    attrs: dict
    mvc: dict[str, dict]  # muscle -> value_V, flags, reasons, …

    def channel_of(self, muscle: str) -> int:
        return self.muscles.index(muscle)

    @property
    def notes(self) -> tuple[str, ...]:
        """What is wrong with the EMG, as stored with it (none in a file of before they
        were kept; the reader refuses one that is not a JSON list of texts)."""
        value = self.attrs.get("notes", [])  # read as JSON already (`_attr`)
        if not isinstance(value, list):
            return ()
        return tuple(str(note) for note in value)

    @property
    def clock_offsets(self) -> tuple[tuple[float, float], ...]:
        """The clock offsets added to a live LSL capture's stamps to put them on this
        machine's clock, each (trial time it began, offset s), or those LabRecorder
        measured for an XDF recording's EMG stream, through which pyxdf fitted what it
        added, each (trial time measured, offset s): () when none was added (a Trigno, a
        file, a file of before they were kept; the reader checked them)."""
        return tuple((float(t), float(o)) for t, o in self.attrs.get("clock_offsets", []))


def write_emg(
    path: str | os.PathLike,
    *,
    names: Sequence[str],
    muscles: Sequence[str],
    rate_hz: float,
    time_s,
    samples,
    source: str,
    clock: str,
    offset_s: float,
    source_file: str = "",
    replace: bool = False,
    notes: Sequence[str] = (),
    clock_offsets: Sequence[tuple[float, float]] = (),
) -> None:
    """Store EMG in a closed trial file's `/emg` group. `time_s` is already trial time;
    `clock` says in words how it was mapped, `offset_s` the shift applied (trial time =
    source time + offset_s); `notes`, what is wrong with it in words (a capture that ended
    early, samples missing, a hole in a recording, part of the trial not covered), kept
    with it: said on screen or printed only, they were lost with the session;
    `clock_offsets`, (trial time, offset s) of each clock offset a live LSL capture added
    to the sender's stamps, from that time on, or of each that pyxdf fitted its correction
    of an XDF recording's EMG stream through (none: no attribute). Refuses a file being
    recorded, and replacing EMG unless `replace`."""
    t = np.asarray(time_s, dtype=np.float64)
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim != 2 or x.shape != (t.size, len(names)) or len(muscles) != len(names):
        raise RecordingError(f"EMG of shape {x.shape} with {t.size} times, {len(names)} names "
                             f"and {len(muscles)} muscles do not fit together")
    path = Path(path)
    try:
        # room for the arrays, their checksums and the group's metadata
        with open_for_update(path, "/emg", reserve_bytes=t.nbytes + x.nbytes + 2**20) as f:
            refuse_while_recording(f, path.name, "add EMG after it closes")
            if GROUP in f:
                if not replace:
                    raise RecordingError(f"{path.name} already has EMG; replace it explicitly "
                                         "(rehab emg import --replace)")
                del f[GROUP]
            group = f.create_group(GROUP)
            group.attrs.update({
                "sampling_rate_hz": float(rate_hz), "units": "V", "source": source,
                "source_file": source_file, "clock": clock, "offset_s": float(offset_s),
                "imported_utc": utc_now_iso(), "n_samples": np.int64(t.size),
                "notes": json.dumps([str(note) for note in notes]),
            })
            if clock_offsets:
                group.attrs["clock_offsets"] = json.dumps(
                    [[float(t), float(o)] for t, o in clock_offsets])
            rows = max(1, min(CHUNK_ROWS, t.size))
            time_ds = group.create_dataset("time", data=t, chunks=(rows,), fletcher32=True)
            time_ds.attrs["units"] = "s"
            time_ds.attrs["description"] = ("trial time of each EMG sample "
                                            "(clock of /timeseries/time)")
            data = group.create_dataset("samples", data=x, chunks=(rows, x.shape[1]),
                                        fletcher32=True)
            data.attrs["units"] = "V"
            data.attrs["description"] = "raw surface EMG, one column per row of /emg/channels"
            table = np.empty(len(names), dtype=_CHANNEL_DTYPE)
            for i, (name, muscle) in enumerate(zip(names, muscles, strict=True)):
                table[i] = (name, muscle, "V")
            group.create_dataset("channels", data=table)
    except (OSError, ValueError) as exc:
        raise RecordingError(f"cannot store EMG in {path}: {exc}") from exc


def write_mvc(path: str | os.PathLike, values: Mapping[str, Mapping]) -> None:
    """Store (or replace) MVCs in `/emg/mvc/<muscle>`: each a mapping of value_V, flags,
    reasons and whatever else describes it (numbers, strings; lists and dicts as JSON)."""
    path = Path(path)
    try:
        with open_for_update(path, "/emg/mvc") as f:
            refuse_while_recording(f, path.name, "add EMG after it closes")
            if GROUP not in f:
                raise RecordingError(f"{path.name} has no EMG; import the trial's EMG first "
                                     "(rehab emg import)")
            mvc = f[GROUP].require_group("mvc")
            for muscle, entry in values.items():
                if muscle in mvc:
                    del mvc[muscle]
                group = mvc.create_group(muscle)
                for key, value in entry.items():
                    if isinstance(value, list | tuple | dict):
                        group.attrs[key] = json.dumps(value)
                    elif value is None:
                        group.attrs[key] = "null"
                    else:
                        group.attrs[key] = value
    except (OSError, ValueError) as exc:
        raise RecordingError(f"cannot store the MVC in {path}: {exc}") from exc


def read_emg(path: str | os.PathLike) -> EmgGroup | None:
    """The `/emg` group of a trial file, or None when it has none; RecordingError in one line
    naming the file when it is damaged or not what the console writes: compared with the
    file's seal (device.recording.trialfile.seal), and checked whoever wrote it (samples
    one column per channel, time finite and increasing, MVCs with a value, lists of flags
    and reasons)."""
    path = Path(path)
    try:
        with held(path):
            return _read(path)
    except Damaged as exc:
        raise RecordingError(f"trial file {path}: {exc.problem}. Restore it from the backup "
                             "or import its EMG again (rehab emg import --replace)") from None
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as exc:
        detail = " ".join(str(exc).split())
        raise RecordingError(f"cannot read the EMG of {path}: {detail}") from exc


def _read(path: Path) -> EmgGroup | None:
    # the samples are checked against the seal as they are read, not twice
    with open_room(path, f"/{GROUP}", skip={"/emg/time", "/emg/samples"}) as opened:
        if opened is None:
            return None
        _, found, seal = opened
        group = _checked_group(found)
        table = group["channels"][()]
        time_s, samples = group["time"][()], group["samples"][()]
        if seal is not None:
            seal.check("/emg/time", found, time_s)
            seal.check("/emg/samples", found, samples)
        names, muscles = _channel_names(table)
        rate_hz = _rate(group.attrs.get("sampling_rate_hz"))
        _check_samples(time_s, samples, len(names))
        mvc = {muscle: _checked_mvc(muscle, {k: _attr(v) for k, v in h5views.items(entry.attrs)})
               for muscle, entry in h5views.items(group.get("mvc", {}))}
        attrs = {k: _attr(v) for k, v in h5views.items(group.attrs)}
        _check_notes(attrs)
        _check_clock_offsets(attrs)
        return EmgGroup(names, muscles, rate_hz, time_s, samples, attrs, mvc)


def _checked_group(found) -> h5py.Group:
    group = found.groups.get(f"/{GROUP}")
    if group is None:
        raise Damaged("is damaged: /emg is not a group")
    for name in ("time", "samples", "channels"):
        if f"/{GROUP}/{name}" not in found.datasets:
            raise Damaged(f"is damaged: /emg/{name} is missing or not a dataset")
    mvc = group.get("mvc")
    if mvc is not None and not (isinstance(mvc, h5py.Group) and all(
            isinstance(item, h5py.Group) for item in h5views.values(mvc))):
        raise Damaged("is damaged: /emg/mvc is not a group of one group per muscle")
    return group


def _channel_names(table: np.ndarray) -> tuple[tuple[str, ...], tuple[str, ...]]:
    if table.ndim != 1 or table.dtype.names is None or not {"name", "muscle"} <= set(
            table.dtype.names):
        raise Damaged("is damaged: /emg/channels is not the table of channels (name, muscle, "
                      "units)")
    names = tuple(_text(r["name"]) for r in table)
    muscles = tuple(_text(r["muscle"]) for r in table)
    if not names or len(set(names)) != len(names) or len(set(muscles)) != len(muscles):
        raise Damaged("is damaged: /emg/channels names no channel, or a channel or a muscle "
                      "twice")
    return names, muscles


def _rate(value) -> float:
    if isinstance(value, bool) or not isinstance(value, float | np.floating) or not (
            np.isfinite(value) and value > 0):
        raise Damaged(f"is damaged: /emg sampling_rate_hz is {value!r}, not a rate in Hz")
    return float(value)


def _check_samples(time_s: np.ndarray, samples: np.ndarray, channels: int) -> None:
    if time_s.dtype.kind != "f" or time_s.ndim != 1:
        raise Damaged(f"is damaged: /emg/time holds {time_s.dtype} of shape {time_s.shape}, "
                      "not one time in s per sample")
    if samples.dtype.kind != "f" or samples.shape != (time_s.size, channels):
        raise Damaged(f"is damaged: /emg/samples holds {samples.dtype} of shape "
                      f"{samples.shape}, not ({time_s.size}, {channels}): one column per "
                      "channel of /emg/channels, one row per time")
    if not np.isfinite(time_s).all():
        k = int(np.flatnonzero(~np.isfinite(time_s))[0])
        raise Damaged(f"is damaged: /emg/time is {time_s[k]} at sample {k}")
    step = np.diff(time_s)
    if (step <= 0).any():
        k = int(np.flatnonzero(step <= 0)[0]) + 1
        raise Damaged(f"is damaged: /emg/time goes from {time_s[k - 1]} to {time_s[k]} s at "
                      f"sample {k}; it only ever increases")


def _check_notes(attrs: dict) -> None:
    """What is wrong with the EMG is kept with it (`notes`, absent in older files): one that
    is not the JSON list of texts the console writes (cut, an object) was read as no notes,
    so a capture that ended early read as a whole one."""
    notes = attrs.get("notes", [])
    if not isinstance(notes, list) or not all(isinstance(n, str) for n in notes):
        raise Damaged(f"is damaged: /emg notes is {str(notes)[:40]!r}, not the JSON list of "
                      "texts the console writes")


def _check_clock_offsets(attrs: dict) -> None:
    """The clock offsets added to an LSL capture's stamps (absent for other sources and in
    older files): a JSON list of [trial time s, offset s] pairs of finite numbers, in time
    order, as the console writes them."""
    offsets = attrs.get("clock_offsets", [])
    pairs = isinstance(offsets, list) and all(
        isinstance(p, list) and len(p) == 2 and all(
            isinstance(v, int | float) and not isinstance(v, bool) and np.isfinite(v)
            for v in p) for p in offsets)
    if not pairs or any(a[0] > b[0] for a, b in itertools.pairwise(offsets)):
        raise Damaged(f"is damaged: /emg clock_offsets is {str(offsets)[:40]!r}, not the JSON "
                      "list of [time s, offset s] pairs in time order the console writes")


def _checked_mvc(muscle: str, entry: dict) -> dict:
    value = entry.get("value_V")
    if isinstance(value, bool) or not isinstance(value, int | float) or not (
            np.isfinite(value) and value > 0):
        raise Damaged(f"is damaged: /emg/mvc/{muscle} value_V is {value!r}, not a voltage")
    for key in ("flags", "reasons"):
        items = entry.get(key, [])
        if not isinstance(items, list) or not all(isinstance(i, str) for i in items):
            raise Damaged(f"is damaged: /emg/mvc/{muscle} {key} is {str(items)[:40]!r}, not "
                          "the JSON list of words the console writes")
    if "settings" in entry and not isinstance(entry["settings"], dict):
        raise Damaged(f"is damaged: /emg/mvc/{muscle} settings is not a JSON object")
    return entry


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _attr(value):
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, str) and value[:1] in "[{n":
        try:
            return json.loads(value)
        except ValueError:
            return value
    if isinstance(value, np.generic):
        return value.item()
    return value
