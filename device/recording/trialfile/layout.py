"""The trial file's layout and the rules every writer of it keeps: the format's name and
version, the statuses, the channel and event tables, the subject's data, the checks on
scalars and metrics, and one way to turn a disk's error into a sentence
(docs/data-format.md)."""

from __future__ import annotations

import dataclasses
import datetime
import errno
import importlib.metadata
import json
import math
import re
import shutil
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from core.trial import SIDES, TrialParameters
from device.errors import RecordingError
from device.recording.record import Channel

FORMAT_NAME = "rehab-console-trial"
FORMAT_VERSION = 2
"""2: the seal (root attributes `header_sha256`, `seal`, `seal_sha256`), required of every
file closed by a console of version 2 (docs/data-format.md, "Versioning")."""
SEALED_SINCE_VERSION = 2

STATUS_RECORDING = "recording"
"""Status of a file whose writer has not closed it: still being recorded, or lost in a crash."""

STATUSES = ("complete", "stopped_early", "faulted", "recording_lost")
"""Final statuses `close` accepts (docs/data-format.md says what each means)."""

DISTRIBUTION = "rehab-console"

# v1.10 is the oldest file-format bound that supports SWMR. "latest" would mean
# v2.0 with this HDF5, whose object encodings the HDF5 1.10/1.14 inside MATLAB
# and older h5py builds may not read.
LIBVER = ("v110", "v110")

# About two seconds of samples at 500 Hz per chunk: few chunks per dataset, and a
# chunk of the widest channel stays well under h5py's 1 MiB per-dataset cache.
CHUNK_ROWS = 1024
EVENT_CHUNK_ROWS = 64
CHUNK_CACHE_BYTES = 256 * 2**10
"""HDF5's chunk cache per dataset while writing: a few chunks, enough for the partial chunk
at the end of each batch."""

# Room kept free so that `close` can always finish the file (see `flush`).
MIN_FREE_BYTES = 64 * 2**20

# Fixed-length strings in the events table: SWMR appends of variable-length
# strings go through HDF5's global heap, which SWMR readers do not see safely.
EVENT_KIND_BYTES = 32
EVENT_MESSAGE_BYTES = 512
EVENT_VALUES_BYTES = 2048

_UTF8 = h5py.string_dtype("utf-8")
_CHANNEL_TABLE_DTYPE = np.dtype([
    ("name", _UTF8),
    ("width", "<i4"),
    ("dtype", _UTF8),
    ("units", _UTF8),
    ("frame", _UTF8),
    ("description", _UTF8),
])
EVENT_DTYPE = np.dtype([
    ("time_s", "<f8"),
    ("tick", "<i8"),
    ("kind", h5py.string_dtype("utf-8", EVENT_KIND_BYTES)),
    ("message", h5py.string_dtype("utf-8", EVENT_MESSAGE_BYTES)),
    ("values", h5py.string_dtype("utf-8", EVENT_VALUES_BYTES)),
])

_SUBJECT_CODE = re.compile(r"[A-Za-z0-9_-]{1,32}")
_ATTRIBUTE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}")


@dataclass(frozen=True, slots=True)
class SubjectInfo:
    """What a trial file holds about the subject: a pseudonymous code and the
    anthropometry the arm model needs. Never a name: the registry keeps those."""

    code: str
    body_mass_kg: float
    upper_arm_m: float
    forearm_m: float
    side: str

    def __post_init__(self) -> None:
        if not isinstance(self.code, str) or not _SUBJECT_CODE.fullmatch(self.code):
            raise RecordingError(
                f"subject code {self.code!r} is not a pseudonymous code: use the registry's "
                "code (1-32 letters, digits, '-' or '_'); names never go into trial files"
            )
        for name in ("body_mass_kg", "upper_arm_m", "forearm_m"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float | np.number) or not (
                math.isfinite(value) and value > 0
            ):
                raise RecordingError(f"subject {name} = {value!r}: give a finite number > 0")
            object.__setattr__(self, name, float(value))
        if self.side not in SIDES:
            raise RecordingError(f"subject side = {self.side!r}: give one of {', '.join(SIDES)}")

    @classmethod
    def from_parameters(cls, code: str, parameters: TrialParameters) -> SubjectInfo:
        return cls(code, parameters.body_mass_kg, parameters.upper_arm_m, parameters.forearm_m,
                   parameters.side)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, values: Mapping) -> SubjectInfo:
        names = [f.name for f in dataclasses.fields(cls)]
        missing = [n for n in names if n not in values]
        if missing:
            raise RecordingError(f"subject data lacks {', '.join(missing)}")
        return cls(**{n: values[n] for n in names})


def software_version() -> str:
    try:
        return importlib.metadata.version(DISTRIBUTION)
    except importlib.metadata.PackageNotFoundError:
        # Running from a source tree that was never installed.
        return "unknown"


def utc_now_iso() -> str:
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="microseconds")


ALREADY_OPEN = "already open for read-only"
"""HDF5's words when a file this process has open for reading is opened for writing."""
UPDATE_WAIT_S = 10.0
"""How long an update of a closed trial file waits for a reader in this process."""
UPDATE_RETRY_S = 0.05



def _assistance_parts(values: Mapping) -> tuple[dict, dict]:
    """The `/assistance` group's values as (checked scalars for its attributes, float64
    arrays for its datasets)."""
    arrays = {k: np.asarray(v, dtype=float) for k, v in values.items()
              if isinstance(v, np.ndarray)}
    return _check_scalars("assistance", {k: v for k, v in values.items()
                                         if k not in arrays}), arrays


def _write_assistance(group: h5py.Group, scalars: Mapping, arrays: Mapping) -> None:
    for key, value in scalars.items():
        group.attrs[key] = value
    for key, value in arrays.items():
        group.create_dataset(key, data=value, fletcher32=True)



def _check_channels(channels: tuple[Channel, ...]) -> None:
    names = [c.name for c in channels]
    if len(set(names)) != len(names):
        raise RecordingError(f"channel names repeat: {names}")
    for c in channels:
        if not _ATTRIBUTE_NAME.fullmatch(c.name):
            raise RecordingError(
                f"channel name {c.name!r} cannot be an HDF5 dataset name here: use letters, "
                "digits and '_'"
            )
        if not isinstance(c.width, int) or c.width < 1:
            raise RecordingError(f"channel {c.name}: width {c.width!r} must be >= 1")
        if np.dtype(c.dtype).kind not in "iuf":
            raise RecordingError(f"channel {c.name}: dtype {c.dtype} is not a number type")


def _create_channel_dataset(group: h5py.Group, channel: Channel, chunk_rows: int) -> h5py.Dataset:
    dtype = np.dtype(channel.dtype)
    tail = () if channel.width == 1 else (channel.width,)
    # Fletcher-32 on every chunk: a bit flipped on the disk or in a copy is an error on
    # read (app.trials.reader names the dataset), not a silently wrong number
    dataset = group.create_dataset(
        channel.name, shape=(0, *tail), maxshape=(None, *tail), dtype=dtype,
        chunks=(chunk_rows, *tail), fillvalue=_fill_value(dtype), fletcher32=True,
    )
    dataset.attrs["units"] = channel.units
    dataset.attrs["frame"] = channel.frame
    dataset.attrs["description"] = channel.description
    return dataset


def _fill_value(dtype: np.dtype):
    # What an extended but never written row reads as: NaN shows "missing" in
    # floats, and -1 cannot be a tick index.
    if dtype.kind == "f":
        return np.nan
    if dtype.kind == "i":
        return -1
    return 0


def _write_channel_table(f: h5py.File, channels: tuple[Channel, ...]) -> None:
    table = np.empty(len(channels), dtype=_CHANNEL_TABLE_DTYPE)
    for i, c in enumerate(channels):
        table[i] = (c.name, c.width, np.dtype(c.dtype).str, c.units, c.frame, c.description)
    f.create_dataset("channels", data=table)


def _write_parameter_group(group: h5py.Group, values: Mapping) -> None:
    # A readable copy for MATLAB and HDFView; the JSON root attribute is the one
    # the reader trusts, since it keeps Python's types exactly.
    for key, value in values.items():
        if isinstance(value, bool):
            group.attrs[key] = np.uint8(value)
        elif isinstance(value, int):
            group.attrs[key] = np.int64(value)
        elif isinstance(value, float):
            group.attrs[key] = np.float64(value)
        elif isinstance(value, str):
            group.attrs[key] = value
        elif isinstance(value, list | tuple):
            group.attrs[key] = np.asarray(value, dtype=np.float64)
        else:
            raise RecordingError(f"parameter {key} = {value!r} has no HDF5 form")


def _plain_mapping(value: Mapping | object) -> dict:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.asdict(value)
    if isinstance(value, Mapping):
        return dict(value)
    raise RecordingError(f"robot description must be a mapping or a dataclass, not {value!r}")


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def _to_json(what: str, value) -> str:
    try:
        return json.dumps(value, default=_json_default, ensure_ascii=False)
    except (TypeError, ValueError) as exc:
        raise RecordingError(f"{what} cannot be stored as JSON: {exc}") from exc


def _utf8_fit(text: str, n_bytes: int) -> bytes:
    data = text.encode("utf-8")
    if len(data) <= n_bytes:
        return data
    ellipsis = "…".encode()
    # Cut on a character boundary so the stored text stays valid UTF-8.
    return data[: n_bytes - len(ellipsis)].decode("utf-8", "ignore").encode() + ellipsis


def _event_row(time_s, tick, kind, message, values) -> np.ndarray:
    if not isinstance(kind, str) or not kind or len(kind.encode()) > EVENT_KIND_BYTES:
        raise RecordingError(
            f"event kind {kind!r}: give a short word (1-{EVENT_KIND_BYTES} bytes) such as "
            "'start', 'stop', 'fault', 'mark'"
        )
    values_json = _to_json(f"values of the {kind!r} event", dict(values or {}))
    if len(values_json.encode()) > EVENT_VALUES_BYTES:
        # Keep the event, which matters more than its detail, and say what was cut.
        values_json = _to_json("values", {
            "values_dropped": f"{len(values_json.encode())} bytes of JSON exceed "
                              f"{EVENT_VALUES_BYTES}",
            "keys": sorted(str(k) for k in (values or {}))[:20],
        })
    try:
        time_s, tick = float(time_s), int(tick)
    except (TypeError, ValueError):
        raise RecordingError(
            f"{kind!r} event: time_s = {time_s!r} and tick = {tick!r} must be numbers"
        ) from None
    row = np.zeros((), dtype=EVENT_DTYPE)
    row["time_s"] = time_s
    row["tick"] = tick
    row["kind"] = kind.encode()
    row["message"] = _utf8_fit(str(message), EVENT_MESSAGE_BYTES)
    row["values"] = _utf8_fit(values_json, EVENT_VALUES_BYTES)
    return row


def _check_scalars(what: str, values: Mapping) -> dict:
    out = {}
    for key, value in values.items():
        if not isinstance(key, str) or not _ATTRIBUTE_NAME.fullmatch(key):
            raise RecordingError(f"{what} key {key!r}: use letters, digits and '_'")
        if isinstance(value, bool | np.bool_):
            out[key] = np.uint8(value)
        elif isinstance(value, int | np.integer):
            out[key] = np.int64(value)
        elif isinstance(value, float | np.floating):
            out[key] = np.float64(value)
        elif isinstance(value, str):
            out[key] = value
        else:
            raise RecordingError(
                f"{what} {key} = {value!r}: give a number or a string (one value per key)"
            )
    return out


def _check_records(path: Path, dtype: np.dtype, records: np.ndarray) -> None:
    """Records a writer of `dtype` may append to the file at `path`, or why not."""
    if records.ndim != 1 or records.dtype.names is None:
        raise RecordingError(
            f"records for {path} must be a 1-D structured array, got shape "
            f"{records.shape} of dtype {records.dtype}"
        )
    expected = set(dtype.names)
    given = set(records.dtype.names)
    if given != expected:
        missing = sorted(expected - given)
        unknown = sorted(given - expected)
        raise RecordingError(
            f"records for {path} do not match its channels (missing: "
            f"{', '.join(missing) or 'none'}; unknown: {', '.join(unknown) or 'none'}). "
            "Open the writer with the channels the loop records (device.recording.record)."
        )
    for name in dtype.names:
        if records.dtype[name] != dtype[name]:
            raise RecordingError(
                f"records for {path}: channel {name} is {records.dtype[name]}, "
                f"the file expects {dtype[name]}"
            )


def _check_metrics(values: Mapping) -> dict:
    out = {}
    for key, value in values.items():
        if not isinstance(key, str) or not _ATTRIBUTE_NAME.fullmatch(key):
            raise RecordingError(f"metric name {key!r}: use letters, digits and '_', with units")
        if isinstance(value, bool | np.bool_) or not isinstance(value, int | float | np.number):
            raise RecordingError(f"metric {key} = {value!r}: give a number (NaN if undefined)")
        out[key] = np.float64(value)
    return out


def _free_bytes(folder: Path) -> int | None:
    try:
        return shutil.disk_usage(folder).free
    except OSError:
        return None  # unknown: let the write itself report the problem


_ERRNO_IN_MESSAGE = re.compile(r"errno = (\d+)")


def _disk_error(path: Path, action: str, exc: BaseException) -> RecordingError:
    code = getattr(exc, "errno", None)
    if code is None:
        match = _ERRNO_IN_MESSAGE.search(str(exc))
        code = int(match.group(1)) if match else None
    if ALREADY_OPEN in str(exc):
        advice = (f"it stayed open for reading in this console for over {UPDATE_WAIT_S:g} s "
                  "(a replay, a report or a loader of it): close that, then store again")
    elif code == errno.ENOSPC or code == errno.EDQUOT or code == errno.EFBIG:
        advice = ("the disk (or this user's quota, or the file size limit) is full: free "
                  "space or set the data directory to a larger disk")
    elif code in (errno.EACCES, errno.EPERM, errno.EROFS):
        advice = (f"permission denied: the console cannot write in {path.parent}. Check the "
                  "folder's permissions or set the data directory to a folder you can write to")
    elif code == errno.ENOENT:
        advice = f"{path.parent} does not exist: check the data directory setting"
    elif code == errno.EEXIST:
        advice = "a file of that name already exists; trial files are never overwritten"
    else:
        advice = "check that the disk is connected and has space"
    # HDF5's messages carry line breaks; the window shows one line.
    detail = " ".join(str(exc).split())
    return RecordingError(f"could not {action} trial file {path}: {advice} ({detail})")
