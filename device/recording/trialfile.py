"""The trial file: one HDF5 file per trial, written live by the recorder.

The layout is specified in docs/data-format.md; this module is its only writer. (Some 750
lines: the format's rules, HDF5's SWMR constraints and the crash and full-disk handling
below are one job, each rule written next to the writing it governs.)

Crash safety, in brief (the document has the reasoning):

* The file is written in place under its final name, never as a `.part` that is
  renamed at the end: after a kill -9 or a power cut the file the registry points
  to is already there and readable, and a rename would fail on Windows while a
  viewer holds the file open. Whether a trial finished is recorded inside the
  file (`status`), so it survives copies.
* Everything but the samples and events is written before the file switches to
  SWMR mode; from then on only appends happen, which SWMR keeps consistent on disk.
* `flush` pushes HDF5's caches to the file and fsyncs it, so a power cut loses at
  most what was appended since the last flush. `append` flushes by itself when
  the recorder has not done so for `flush_interval_s`.
* `close` ends SWMR (which clears the "open for writing" flag) and reopens the
  file normally to add the status, summary and metrics, because HDF5 does not
  support creating attributes under SWMR.
* A write that fails for want of space leaves HDF5 unable to close the file, so
  the writer stops while `min_free_bytes` are still free.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import errno
import importlib.metadata
import json
import math
import os
import re
import shutil
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from core.blockwise import percentiles_of_blocks
from core.trial import SIDES, TrialParameters
from device.errors import RecordingError
from device.recording.record import CHANNELS, Channel

FORMAT_NAME = "rehab-console-trial"
FORMAT_VERSION = 1

STATUS_RECORDING = "recording"
"""Status of a file whose writer has not closed it: still being recorded, or lost in a crash."""

STATUSES = ("complete", "stopped_early", "faulted", "recording_lost")
"""Final statuses `close` accepts (docs/data-format.md says what each means)."""

DISTRIBUTION = "rehab-console"

# v1.10 is the oldest file-format bound that supports SWMR. "latest" would mean
# v2.0 with this HDF5, whose object encodings the HDF5 1.10/1.14 inside MATLAB
# and older h5py builds may not read.
LIBVER = ("v110", "v110")
SUMMARY_BLOCK = 100_000
"""Samples of a timing channel read at once for the summary `close` computes."""

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


class TrialFileWriter:
    """Writes one trial file while the trial runs. Not thread-safe: one recorder owns it.

    `live=True` switches the file to SWMR after the header so viewers can read it
    during the trial; `write_trial` uses `live=False` for headless runs.
    `durable=True` fsyncs on every flush so a power cut, not only a crash, keeps
    every flushed sample.
    """

    def __init__(
        self,
        path: str | os.PathLike,
        *,
        parameters: TrialParameters,
        subject: SubjectInfo,
        robot: Mapping | object,
        backend: str,
        sample_period_s: float,
        channels: tuple[Channel, ...] = CHANNELS,
        live: bool = True,
        durable: bool = True,
        flush_interval_s: float | None = 0.5,
        chunk_rows: int = CHUNK_ROWS,
        min_free_bytes: int = MIN_FREE_BYTES,
    ) -> None:
        self._path = Path(path)
        self._channels = tuple(channels)
        self._live = live
        self._durable = durable
        self._flush_interval_s = flush_interval_s
        self._min_free_bytes = min_free_bytes
        self._n = 0
        self._n_events = 0
        self._closed = False
        self._failed: str | None = None
        self._file: h5py.File | None = None
        self._last_flush = time.monotonic()

        _check_channels(self._channels)
        if not (isinstance(sample_period_s, int | float) and math.isfinite(sample_period_s)
                and sample_period_s > 0):
            raise RecordingError(
                f"sample_period_s = {sample_period_s!r}: give the loop period in s (> 0)"
            )
        if not isinstance(parameters, TrialParameters):
            raise RecordingError("parameters must be a core.trial.TrialParameters")
        if not isinstance(subject, SubjectInfo):
            raise RecordingError("subject must be a device.recording.trialfile.SubjectInfo")
        if not isinstance(chunk_rows, int) or chunk_rows < 1:
            raise RecordingError(f"chunk_rows = {chunk_rows!r}: give a whole number >= 1")
        self._dtype = np.dtype([c.numpy_field for c in self._channels])
        self._bytes_per_minute = self._dtype.itemsize / sample_period_s * 60.0
        robot_json = _to_json("robot", _plain_mapping(robot))
        header = {
            "format": FORMAT_NAME,
            "format_version": np.int64(FORMAT_VERSION),
            "software_version": software_version(),
            "h5py_version": h5py.version.version,
            "hdf5_version": h5py.version.hdf5_version,
            "created_utc": utc_now_iso(),
            "sample_period_s": float(sample_period_s),
            "backend": str(backend),
            "parameters": _to_json("parameters", parameters.to_dict()),
            "subject": _to_json("subject", subject.to_dict()),
            "robot": robot_json,
            "status": STATUS_RECORDING,
        }

        self._open_new()
        try:
            f = self._file
            for name, value in header.items():
                f.attrs[name] = value
            _write_parameter_group(f.create_group("parameters"), parameters.to_dict())
            _write_channel_table(f, self._channels)
            series = f.create_group("timeseries")
            # Low-level dataset ids: h5py's slicing costs ~40 µs a call in Python, and
            # every batch makes two calls per channel.
            self._datasets = [
                (c.name, _create_channel_dataset(series, c, chunk_rows).id,
                 () if c.width == 1 else (c.width,))
                for c in self._channels
            ]
            self._events = f.create_dataset(
                "events", shape=(0,), maxshape=(None,), dtype=EVENT_DTYPE,
                chunks=(EVENT_CHUNK_ROWS,), fletcher32=True,
            )
            if live:
                f.swmr_mode = True
            self._flush()
        except (RecordingError, OSError, RuntimeError, ValueError) as exc:
            self._abandon()
            # The file is ours and unusable without its header.
            with contextlib.suppress(OSError):
                self._path.unlink(missing_ok=True)
            if isinstance(exc, RecordingError):
                raise
            raise _disk_error(self._path, "write the header of", exc) from exc

    # -- state ---------------------------------------------------------------

    @property
    def path(self) -> Path:
        return self._path

    @property
    def n_samples(self) -> int:
        return self._n

    @property
    def n_events(self) -> int:
        return self._n_events

    @property
    def dtype(self) -> np.dtype:
        return self._dtype

    @property
    def closed(self) -> bool:
        return self._closed

    # -- writing -------------------------------------------------------------

    def append(self, records: np.ndarray) -> None:
        """Append a batch of records (the writer's dtype; field order may differ)."""
        self._check_writable()
        records = np.asarray(records)
        self._check_records(records)
        n = records.shape[0]
        if n == 0:
            return
        start, stop = self._n, self._n + n
        try:
            # One dataset at a time, extent then data: a crash part way leaves the
            # datasets not yet touched shorter, which the reader trims to.
            for name, dataset_id, tail in self._datasets:
                dataset_id.set_extent((stop, *tail))
                file_space = dataset_id.get_space()
                file_space.select_hyperslab((start, *(0 for _ in tail)), (n, *tail))
                dataset_id.write(h5py.h5s.create_simple((n, *tail)), file_space,
                                 np.ascontiguousarray(records[name]))
        except (OSError, RuntimeError, ValueError) as exc:
            self._failed = str(exc)
            raise _disk_error(self._path, f"append samples {start}-{stop - 1} to", exc) from exc
        self._n = stop
        self._maybe_flush()

    def add_event(
        self, time_s: float, tick: int, kind: str, message: str, values: Mapping | None = None
    ) -> None:
        """Record a start, stop, fault, mark... `values` goes in as JSON."""
        self._check_writable()
        row = _event_row(time_s, tick, kind, message, values)
        try:
            self._events.resize(self._n_events + 1, axis=0)
            self._events[self._n_events] = row
        except (OSError, RuntimeError, ValueError) as exc:
            self._failed = str(exc)
            raise _disk_error(self._path, f"add the {kind!r} event to", exc) from exc
        self._n_events += 1
        self._maybe_flush()

    def flush(self) -> None:
        """Make every sample and event so far survive a crash (and, if durable, a power cut).

        Raises RecordingError when the disk is nearly full, after flushing: HDF5 does
        not recover from a write that fails for want of space (the file stays
        readable to the last flush but can no longer be closed properly), so the
        writer stops while `min_free_bytes` remain for `close` to finish the file.
        """
        self._check_writable()
        try:
            self._flush()
        except (OSError, RuntimeError) as exc:
            self._failed = str(exc)
            raise _disk_error(self._path, "flush", exc) from exc
        free = _free_bytes(self._path.parent)
        if free is not None and free < self._min_free_bytes:
            self._failed = self._space_problem(free)
            raise RecordingError(
                f"stopped recording to trial file {self._path} at sample {self._n}: "
                f"{self._failed}. Every sample so far is saved; close it with status "
                "'recording_lost'."
            )

    def close(
        self, status: str, summary: Mapping | None = None, metrics: Mapping | None = None,
        assistance: Mapping | None = None,
    ) -> Path:
        """Finish the file with the trial's status, summary and metrics.

        The summary the writer computes from the samples (duration, counts,
        lateness statistics) is merged with `summary`; the caller's keys win, since
        the recorder may know more (e.g. samples the ring buffer dropped).
        After a write error, close with status "recording_lost": the file handle
        is released and the status written if the disk allows. `assistance` goes to the
        group of that name: numbers and strings as its attributes (the mode, its
        gains), arrays as its datasets (the learned feedforward per repetition).
        """
        if self._closed:
            raise RecordingError(f"{self._path} is already closed")
        if status not in STATUSES:
            raise RecordingError(
                f"status {status!r} for {self._path}: give one of {', '.join(STATUSES)}"
            )
        extra = _check_scalars("summary", summary or {})
        metric_values = _check_metrics(metrics or {})
        assist_values, assist_arrays = _assistance_parts(assistance or {})

        try:
            computed = self._computed_summary()
        except (OSError, RuntimeError, ValueError, KeyError):
            # After a write error the file may not read back; the counts still hold.
            computed = {"n_samples": np.int64(self._n), "n_events": np.int64(self._n_events)}
        try:
            self._flush()
            if self._live:
                # HDF5 does not allow new attributes or groups under SWMR.
                self._file.close()
                self._file = None
                # Without locking: a viewer holding the file open (SWMR readers keep a
                # shared lock) must not stop the status from being written. No other
                # writer can exist, since this writer created the file exclusively.
                self._file = h5py.File(self._path, "r+", libver=LIBVER, locking=False)
            f = self._file
            f.attrs["status"] = status
            f.attrs["closed_utc"] = utc_now_iso()
            group = f.require_group("summary")
            for key, value in {**computed, **extra}.items():
                group.attrs[key] = value
            group = f.require_group("metrics")
            for key, value in metric_values.items():
                group.attrs[key] = value
            if assistance:
                _write_assistance(f.require_group("assistance"), assist_values, assist_arrays)
            self._flush()
        except (OSError, RuntimeError, ValueError) as exc:
            raise _disk_error(self._path, f"close (status {status!r})", exc) from exc
        finally:
            self._closed = True
            self._abandon()
        return self._path

    def channel_names(self) -> tuple[str, ...]:
        """The channels the file has."""
        self._check_writable()
        return tuple(self._file["timeseries"])

    def read_stretch(self, name: str, first: int, stop: int) -> np.ndarray:
        """Samples first…stop−1 (of those written so far) of the channel `name`, read back
        from the open file: a long headless trial's analysis reads its channels a block
        at a time (core.blockwise). Call `flush_for_reading` once before."""
        self._check_writable()
        try:
            return self._file["timeseries"][name][max(0, first):min(stop, self._n)]
        except (OSError, RuntimeError, ValueError) as exc:
            self._failed = str(exc)
            raise _disk_error(self._path, "read back the samples of", exc) from exc

    def flush_for_reading(self) -> None:
        """Write out what is buffered, so that `read_stretch` sees every sample."""
        self._check_writable()
        try:
            self._flush()
        except (OSError, RuntimeError, ValueError) as exc:
            self._failed = str(exc)
            raise _disk_error(self._path, "read back the samples of", exc) from exc

    # -- internals -----------------------------------------------------------

    def _open_new(self) -> None:
        parent = self._path.parent
        if not parent.is_dir():
            raise RecordingError(
                f"cannot create trial file {self._path}: the folder {parent} does not exist. "
                "Check the data directory setting or create the folder."
            )
        free = _free_bytes(parent)
        if free is not None and free < self._min_free_bytes:
            raise RecordingError(
                f"cannot create trial file {self._path}: {self._space_problem(free)}"
            )
        if self._path.exists():
            raise RecordingError(
                f"cannot create trial file {self._path}: a file of that name exists, and trial "
                "files are never overwritten. Choose another name or move the old file."
            )
        try:
            # "w-" fails if the file appeared since the check above.
            # A small chunk cache: HDF5's default (1 MiB a dataset) holds the last MiB of
            # every channel, 30+ MiB that a writer appending in order never reads back.
            self._file = h5py.File(self._path, "w-", libver=LIBVER, rdcc_nbytes=CHUNK_CACHE_BYTES)
            # a trial holds a patient's data: readable by its user only, whatever the umask
            os.chmod(self._path, 0o600)
        except (OSError, RuntimeError) as exc:
            raise _disk_error(self._path, "create", exc) from exc

    def _space_problem(self, free: int) -> str:
        return (
            f"only {free / 2**20:.0f} MiB free on the disk holding {self._path.parent}; the "
            f"recorder keeps {self._min_free_bytes / 2**20:.0f} MiB in reserve and a trial "
            f"takes about {self._bytes_per_minute / 2**20:.0f} MiB per minute. Free space or "
            "set the data directory to a larger disk"
        )

    def _check_writable(self) -> None:
        if self._closed:
            raise RecordingError(f"{self._path} is closed; start a new trial file to record more")
        if self._failed is not None:
            raise RecordingError(
                f"{self._path} had a write error ({self._failed}); nothing more is written. "
                "Close it with status 'recording_lost' and check the disk."
            )

    def _check_records(self, records: np.ndarray) -> None:
        if records.ndim != 1 or records.dtype.names is None:
            raise RecordingError(
                f"records for {self._path} must be a 1-D structured array, got shape "
                f"{records.shape} of dtype {records.dtype}"
            )
        expected = set(self._dtype.names)
        given = set(records.dtype.names)
        if given != expected:
            missing = sorted(expected - given)
            unknown = sorted(given - expected)
            raise RecordingError(
                f"records for {self._path} do not match its channels (missing: "
                f"{', '.join(missing) or 'none'}; unknown: {', '.join(unknown) or 'none'}). "
                "Open the writer with the channels the loop records (device.recording.record)."
            )
        for name in self._dtype.names:
            if records.dtype[name] != self._dtype[name]:
                raise RecordingError(
                    f"records for {self._path}: channel {name} is {records.dtype[name]}, "
                    f"the file expects {self._dtype[name]}"
                )

    def _maybe_flush(self) -> None:
        if self._flush_interval_s is None:
            return
        if time.monotonic() - self._last_flush >= self._flush_interval_s:
            self.flush()

    def _flush(self) -> None:
        self._file.flush()
        if self._durable:
            os.fsync(self._file.id.get_vfd_handle())
        self._last_flush = time.monotonic()

    def _computed_summary(self) -> dict:
        period = float(self._file.attrs["sample_period_s"])
        summary: dict = {
            "n_samples": np.int64(self._n),
            "n_events": np.int64(self._n_events),
            "duration_s": self._n * period,
        }
        series = self._file["timeseries"]
        if self._n and "tick" in series:
            first, last = int(series["tick"][0]), int(series["tick"][self._n - 1])
            summary["first_tick"] = np.int64(first)
            summary["last_tick"] = np.int64(last)
            summary["ticks_missing"] = np.int64(max(0, last - first + 1 - self._n))
        for name in ("lateness", "compute_time"):
            if not self._n or name not in series:
                continue
            summary.update(self._timing_summary(name, series[name], period))
        return summary

    def _timing_summary(self, name: str, channel, period: float) -> dict:
        """A timing channel's mean, p50, p99 and max over its finite samples (and, for the
        lateness, the share of ticks a whole period late), read SUMMARY_BLOCK samples at
        a time: a 100 × 120 s trial's channel is 6 million samples."""

        def blocks():
            for first in range(0, self._n, SUMMARY_BLOCK):
                values = channel[first:min(self._n, first + SUMMARY_BLOCK)]
                yield values[np.isfinite(values)]

        n = total = late = 0
        worst = -math.inf
        for values in blocks():
            if len(values):
                n += len(values)
                total += float(np.sum(values, dtype=np.float64))
                worst = max(worst, float(values.max()))
                late += int(np.count_nonzero(values.astype(np.float64) >= period))
        if n == 0:
            return {}
        p50, p99 = percentiles_of_blocks(blocks, n, (50, 99))
        out = {f"{name}_mean_s": total / n, f"{name}_p50_s": p50, f"{name}_p99_s": p99,
               f"{name}_max_s": worst}
        if name == "lateness":
            # A tick that starts a whole period late has missed its deadline.
            out["late_fraction"] = late / n
        return out

    def _abandon(self) -> None:
        if self._file is not None:
            # Already failing: the caller gets the first error, not this one.
            with contextlib.suppress(OSError, RuntimeError):
                self._file.close()
            self._file = None


ALREADY_OPEN = "already open for read-only"
"""HDF5's words when a file this process has open for reading is opened for writing."""
UPDATE_WAIT_S = 10.0
"""How long an update of a closed trial file waits for a reader in this process."""
UPDATE_RETRY_S = 0.05


@contextlib.contextmanager
def open_for_update(path: str | Path, *, wait_s: float | None = None,
                    sleep=time.sleep, clock=time.monotonic):
    """A closed trial file opened to add to it (metrics, estimates, EMG, pose).

    In one process HDF5 refuses to open a file for writing while it is open for reading,
    whatever the file locking: the window's report or replay, or a researcher's loader in
    the same Python, may hold it at that moment. Such a reader holds it briefly, so the
    update waits for it (up to `wait_s`, by default UPDATE_WAIT_S, trying every
    UPDATE_RETRY_S) instead of failing and losing what it was to store. Any other error
    is raised at once."""
    deadline = clock() + (UPDATE_WAIT_S if wait_s is None else wait_s)
    while True:
        try:
            f = h5py.File(path, "r+", libver=LIBVER, locking=False)
            break
        except OSError as exc:
            if ALREADY_OPEN not in str(exc) or clock() >= deadline:
                raise
        sleep(UPDATE_RETRY_S)
    with f:
        yield f


def write_metrics(path: str | Path, metrics: Mapping) -> None:
    """Store a closed trial's metrics in its `/metrics` group (replacing earlier ones).

    The recorder closes the file as soon as the trial ends; the console computes the
    metrics afterwards and keeps them beside the data with this."""
    values = _check_metrics(metrics)
    try:
        with open_for_update(path) as f:
            if f.attrs.get("status") == STATUS_RECORDING:
                raise RecordingError(f"{path} is still being recorded; add metrics after it "
                                     "closes")
            group = f.require_group("metrics")
            for key in list(group.attrs):
                del group.attrs[key]
            for key, value in values.items():
                group.attrs[key] = value
    except (OSError, RuntimeError, ValueError) as exc:
        raise _disk_error(Path(path), "store the metrics in", exc) from exc


def add_assistance(path: str | Path, values: Mapping) -> None:
    """Add to a closed trial's `/assistance` group what the console learnt beside the loop
    (a live trial's estimates of the patient's force, app.emg.live_feed): numbers and
    strings as attributes, arrays as checksummed float64 datasets, as `close` writes them.
    A name the group already holds is refused: nothing there is overwritten."""
    scalars, arrays = _assistance_parts(values)
    try:
        with open_for_update(path) as f:
            if f.attrs.get("status") == STATUS_RECORDING:
                raise RecordingError(f"{path} is still being recorded; add to its assistance "
                                     "after it closes")
            group = f.require_group("assistance")
            taken = sorted((set(group.attrs) | set(group)) & (set(arrays) | set(scalars)))
            if taken:
                raise RecordingError(f"{Path(path).name} already has {', '.join(taken)} in "
                                     "/assistance; nothing was changed")
            _write_assistance(group, scalars, arrays)
    except (OSError, RuntimeError, ValueError) as exc:
        raise _disk_error(Path(path), "store the assistance's estimates in", exc) from exc


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


def write_trial(
    path: str | os.PathLike,
    records: np.ndarray,
    *,
    parameters: TrialParameters,
    subject: SubjectInfo,
    robot: Mapping | object,
    backend: str,
    sample_period_s: float,
    channels: tuple[Channel, ...] = CHANNELS,
    events: Iterable[Mapping] = (),
    status: str = "complete",
    summary: Mapping | None = None,
    metrics: Mapping | None = None,
    assistance: Mapping | None = None,
) -> Path:
    """Write a whole trial held in memory (headless runs, tests, conversions).

    Events are mappings with time_s, tick, kind, message and optional values, as
    the reader returns them.
    """
    writer = TrialFileWriter(
        path, parameters=parameters, subject=subject, robot=robot, backend=backend,
        sample_period_s=sample_period_s, channels=channels, live=False,
        flush_interval_s=None,
    )
    try:
        writer.append(records)
        for event in events:
            writer.add_event(event["time_s"], event["tick"], event["kind"], event["message"],
                             event.get("values"))
    except BaseException:
        writer.close("recording_lost")
        raise
    return writer.close(status, summary, metrics, assistance)


# -- helpers ----------------------------------------------------------------


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
