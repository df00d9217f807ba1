"""Writing a trial file while the trial runs (`TrialFileWriter`, the recorder's; the whole
trial at once is device.recording.trialfile.whole's; what the file holds before its first
sample, device.recording.trialfile.header's). The layout is in
device.recording.trialfile.layout and docs/data-format.md.

Crash safety, in brief (the document has the reasoning):

* The file is written in place under its final name (made under a hidden one until
  its header is written), never as a `.part` that is renamed at the end: after a
  kill -9 or a power cut the file the registry points to is already there and
  readable, and a rename would fail on Windows while a viewer holds the file open.
  Whether a trial finished is recorded inside the file (`status`), so it survives
  copies.
* Everything but the samples and events is written before the file switches to
  SWMR mode; from then on only appends happen, which SWMR keeps consistent on disk.
* `flush` pushes HDF5's caches to the file and fsyncs it, so a power cut loses at
  most what was appended since the last flush. `append` flushes by itself when
  the recorder has not done so for `flush_interval_s`.
* `close` ends SWMR (which clears the "open for writing" flag) and reopens the
  file normally to add the status, summary and metrics, because HDF5 does not
  support creating attributes under SWMR; the last thing it writes is the seal, the
  digest of everything in the file (device.recording.trialfile.seal), the samples'
  from the digests `append` kept as it wrote them. The header has its own digest,
  written before the first sample.
* A write that fails for want of space leaves HDF5 unable to close the file, and a
  reopen that fails so leaves it flagged "open for writing" and unreadable. So a live
  writer holds disk space beyond the file's end (device.recording.trialfile.reserve:
  `reserve_bytes`, topped up at every flush), which nothing else can take: when the disk
  can no longer give it, or fewer than `min_free_bytes` are free, `flush` raises
  SpaceShort once, the trial's last samples still go into what is held, and `close`
  reopens the file only when the room it needs is held.
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Mapping
from pathlib import Path

import h5py
import numpy as np

from core.trial import TrialParameters
from device.errors import RecordingError
from device.recording.record import CHANNELS, Channel
from device.recording.trialfile import seal
from device.recording.trialfile.header import check_header, header_attributes, write_header
from device.recording.trialfile.layout import (
    CHUNK_ROWS,
    LIBVER,
    MIN_FREE_BYTES,
    STATUSES,
    SubjectInfo,
    _assistance_parts,
    _check_channels,
    _check_metrics,
    _check_records,
    _check_scalars,
    _disk_error,
    _event_row,
    _free_bytes,
    _write_assistance,
    utc_now_iso,
)
from device.recording.trialfile.making import make_file, making_name, publish
from device.recording.trialfile.reserve import CLOSE_BYTES, RESERVE_BYTES, HeldSpace, SpaceShort
from device.recording.trialfile.resume import adopt
from device.recording.trialfile.summary import computed_summary


class TrialFileWriter:
    """Writes one trial file while the trial runs. Not thread-safe: one recorder owns it.

    `live=True` switches the file to SWMR after the header so viewers can read it
    during the trial; `write_trial` uses `live=False` for headless runs.
    `durable=True` fsyncs on every flush so a power cut, not only a crash, keeps
    every flushed sample. `reserve_bytes`: disk space held beyond the file's end
    (device.recording.trialfile.reserve), by default RESERVE_BYTES for a live file and
    none for a whole one.
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
        reserve_bytes: int | None = None,
    ) -> None:
        self._init_state(path, channels, live, durable, flush_interval_s, chunk_rows,
                         min_free_bytes, reserve_bytes)
        check_header(sample_period_s, parameters, subject)
        self._bytes_per_minute = self._dtype.itemsize / sample_period_s * 60.0
        header = header_attributes(parameters, subject, robot, backend, sample_period_s)

        self._open_new()
        try:
            self._datasets, self._events = write_header(
                self._file, header, parameters, self._channels, chunk_rows)
            self._digests = {name: seal.RunningDigest() for name, _, _ in self._datasets}
            if live:
                self._file.swmr_mode = True
            self._flush()
            # after the header: starting SWMR gives back blocks past the file's end
            self._hold_reserve()
            self._publish()
        except (RecordingError, OSError, RuntimeError, ValueError) as exc:
            self._abandon()
            self._release()
            # The file is ours and unusable without its header.
            with contextlib.suppress(OSError):
                if self._making is not None:
                    os.unlink(self._making)
            if isinstance(exc, RecordingError):
                raise
            raise _disk_error(self._path, "write the header of", exc) from exc

    def _init_state(self, path, channels, live, durable, flush_interval_s, chunk_rows,
                    min_free_bytes, reserve_bytes) -> None:
        """The writer's state before its file: a new one's (`__init__`) or a dead writer's
        (`resume`)."""
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
        self._making: Path | None = making_name(self._path)
        self._last_flush = time.monotonic()
        self._reserve_bytes = (RESERVE_BYTES if live else 0) if reserve_bytes is None \
            else int(reserve_bytes)
        self._space: HeldSpace | None = None
        self._short: str | None = None
        """Why the disk is short, once it is: the recording ends on what is held."""
        self.close_problem = ""
        """What `close` could not add for want of space ('' when nothing)."""
        _check_channels(self._channels)
        if not isinstance(chunk_rows, int) or chunk_rows < 1:
            raise RecordingError(f"chunk_rows = {chunk_rows!r}: give a whole number >= 1")
        self._dtype = np.dtype([c.numpy_field for c in self._channels])
        # what one append may add beyond its records: a new chunk of every channel and
        # of the events, and HDF5's metadata blocks
        self._growth_bytes = chunk_rows * self._dtype.itemsize + 2**18

    @classmethod
    def resume(cls, path: str | os.PathLike,
               channels: tuple[Channel, ...] = CHANNELS) -> TrialFileWriter:
        """The writer of a trial file whose writer died with it open (a killed recorder),
        to add what that one did not write and close the file: the dead writer's flags
        cleared (device.recording.trialfile.recover), every channel cut to the samples
        all of them hold whole, then SWMR and the reserve as for a new file. Only for a
        file whose writer is known to be dead."""
        self = cls.__new__(cls)
        self._init_state(path, channels, True, True, 0.5, CHUNK_ROWS, 0, None)
        self._making = None
        self._file, self._datasets, self._events, self._n, self._n_events = adopt(
            self._path, self._channels)  # its header checked first: never sealed over damage
        try:
            # the samples kept, digested as if this writer had appended them (the seal)
            self._digests = seal.running_digests(
                self._file["timeseries"], [name for name, _, _ in self._datasets], self._n)
            self._bytes_per_minute = (self._dtype.itemsize * 60.0
                                      / float(self._file.attrs["sample_period_s"]))
        except (OSError, RuntimeError, ValueError, KeyError) as exc:
            self._abandon()
            raise _disk_error(self._path, "take over", exc) from exc
        try:
            self._file.swmr_mode = True
            self._flush()
            self._space = HeldSpace(self._path, self._reserve_bytes)
            self._space.top_up()
        except (OSError, RuntimeError, ValueError) as exc:
            self._abandon()
            raise _disk_error(self._path, "reopen", exc) from exc
        return self

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

    @property
    def short_of_space(self) -> str | None:
        """Why the disk is short, once it is (else None)."""
        return self._short

    @property
    def space_held(self) -> bool:
        """Whether disk space is held for this file (False where the file system cannot,
        device.recording.trialfile.reserve)."""
        return self._space is not None and self._space.held

    # -- writing -------------------------------------------------------------

    def append(self, records: np.ndarray) -> None:
        """Append a batch of records (the writer's dtype; field order may differ)."""
        self._check_writable()
        records = np.asarray(records)
        _check_records(self._path, self._dtype, records)
        n = records.shape[0]
        if n == 0:
            return
        self._check_room(records.nbytes)
        start, stop = self._n, self._n + n
        written = []
        try:
            # One dataset at a time, extent then data: a crash part way leaves the
            # datasets not yet touched shorter, which the reader trims to.
            for name, dataset_id, tail in self._datasets:
                dataset_id.set_extent((stop, *tail))
                file_space = dataset_id.get_space()
                file_space.select_hyperslab((start, *(0 for _ in tail)), (n, *tail))
                values = np.ascontiguousarray(records[name])
                dataset_id.write(h5py.h5s.create_simple((n, *tail)), file_space, values)
                written.append((name, values))
        except (OSError, RuntimeError, ValueError) as exc:
            self._failed = str(exc)
            raise _disk_error(self._path, f"append samples {start}-{stop - 1} to", exc) from exc
        # the seal's digest of the samples covers whole batches only, as `close` keeps them
        for name, values in written:
            self._digests[name].add(values)
        self._n = stop
        self._maybe_flush()

    def add_event(
        self, time_s: float, tick: int, kind: str, message: str, values: Mapping | None = None
    ) -> None:
        """Record a start, stop, fault, mark... `values` goes in as JSON."""
        self._check_writable()
        row = _event_row(time_s, tick, kind, message, values)
        self._check_room(row.nbytes)
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

        Raises SpaceShort once, after flushing, when the disk runs short: fewer than
        `min_free_bytes` free, or the reserve held beyond the file's end can no longer be
        topped up (another program filled the disk, or the trial did). The writer then
        takes further samples only into what is held, and `close` finishes the file.
        """
        self._check_writable()
        try:
            self._flush()
        except (OSError, RuntimeError) as exc:
            self._failed = str(exc)
            raise _disk_error(self._path, "flush", exc) from exc
        if self._short is not None:
            return
        problem = self._space.top_up() if self._space is not None else ""
        free = _free_bytes(self._path.parent)
        if free is not None and free < self._min_free_bytes:
            problem = self._space_problem(free)
        if not problem:
            return
        self._short = problem
        held = self._space is not None and self._space.held
        if not held:
            # nothing held: a write that fails for want of space would leave the file
            # unclosable, so nothing more is written
            self._failed = problem
        raise SpaceShort(
            f"stopped recording to trial file {self._path} at sample {self._n}: {problem}. "
            "Every sample so far is saved; "
            + ("the space held for the file takes the trial's last samples and closes it "
               "with status 'recording_lost'." if held else
               "close it with status 'recording_lost'.")
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
            computed = computed_summary(self._file, self._n, self._n_events)
        except (OSError, RuntimeError, ValueError, KeyError):
            # After a write error the file may not read back; the counts still hold.
            computed = {"n_samples": np.int64(self._n), "n_events": np.int64(self._n_events)}
        try:
            self._flush()
            if self._live:
                # HDF5 does not allow new attributes or groups under SWMR.
                self._file.close()
                self._file = None
                # the reopen writes only into space held for it (where space can be held)
                if self._space is not None and not self._space.ensure(CLOSE_BYTES):
                    self.close_problem = (
                        f"{self._short or 'the disk is full'}: every sample and event is "
                        "in the file, its status and summary could not be added")
                    raise SpaceShort(f"trial file {self._path} closed without its status: "
                                     f"{self.close_problem}")
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
            seal.seal_at_close(f, self._n, self._digests)
            self._flush()
        except (OSError, RuntimeError, ValueError) as exc:
            raise _disk_error(self._path, f"close (status {status!r})", exc) from exc
        finally:
            self._closed = True
            self._abandon()
            self._release()
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
        free = _free_bytes(self._path.parent)
        if free is not None and free < self._min_free_bytes:
            raise SpaceShort(f"cannot create trial file {self._path}: {self._space_problem(free)}")
        self._file = make_file(self._path, self._making)

    def _publish(self) -> None:
        publish(self._making, self._path)
        self._making = None

    def _space_problem(self, free: int) -> str:
        return (
            f"only {free / 2**20:.0f} MiB free on the disk holding {self._path.parent}; the "
            f"recorder stops a trial while fewer than {self._min_free_bytes / 2**20:.0f} MiB "
            "are free; a trial "
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

    def _hold_reserve(self) -> None:
        """Hold the file's reserve from its first byte on; a disk that cannot give it
        refuses the trial file before a sample is due."""
        if not self._reserve_bytes:
            return
        self._space = HeldSpace(self._making, self._reserve_bytes)
        problem = self._space.top_up()
        if problem:
            raise SpaceShort(f"cannot create trial file {self._path}: {problem}. Free space "
                             "or set the data directory to a larger disk")

    def _check_room(self, nbytes: int) -> None:
        """Once the disk is short, a write goes only into the space held, and never into
        the part kept for `close`."""
        if self._short is None or self._space is None:
            return
        room = self._space.room()
        if room is not None and room < nbytes + self._growth_bytes + CLOSE_BYTES:
            self._failed = f"{self._short}, and the space held for it is used up"
            raise RecordingError(
                f"stopped writing trial file {self._path} at sample {self._n}: "
                f"{self._failed}. Close it with status 'recording_lost'."
            )

    def _release(self) -> None:
        if self._space is not None:
            self._space.release()

    def _abandon(self) -> None:
        if self._file is not None:
            # Already failing: the caller gets the first error, not this one.
            with contextlib.suppress(OSError, RuntimeError):
                self._file.close()
            self._file = None
