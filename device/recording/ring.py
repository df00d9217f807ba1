"""The shared-memory ring buffer between the 2 ms loop and its readers.

The loop process writes one fixed-size record per tick; the recorder (must see every
record) and the live view (may skip ahead) copy them out from other processes. One
`RecordRing` is one POSIX shared-memory segment: a 256-byte header of int64 counters,
then `capacity` records of a numpy structured dtype (`device.recording.record.RECORD_DTYPE`, or
an extended one from `extend_channels`). Linux: POSIX shared memory in /dev/shm.

Writing, per tick, without locks, logging or file I/O:

- ``push(values)``: one record from plain Python numbers in `flat_names` order (integer
  fields take ints). It packs them straight into the slot with a precompiled
  ``struct``: about 1 µs for the 52 numbers of RECORD_DTYPE (bench/ring.py), three
  times faster than numpy's own tuple-to-record assignment. The loop's choice.
- ``slot()`` then ``commit()``: fill the record in place through a numpy view. Each
  field write costs ~0.3 µs (numpy scalar overhead), so a whole record is ~11 µs; worth
  it only for a few fields or for large array fields (EMG blocks) of an extended dtype.

Counters (all counts of records since the ring was created, never wrapped):

- ``write``: records published. Record ``i`` lives in slot ``i % capacity``.
- ``claim``: ``write + 1`` while the writer is filling the next slot, else ``write``.
  A reader uses it to tell which slot may be half-overwritten under its copy.
- ``read``: records the recorder has copied out (`commit_read`). While the ring is
  ``recorded``, the writer refuses to reuse a slot whose record is not below this count,
  so the recorder never loses a record silently: the loop gets `RecordingLost` (or sees
  `would_overwrite_unrecorded()`) and stops the trial instead.
- ``finished``: set by the writer after its last record (`finish`).

There is exactly one writer and at most one recorder per ring; any number of lossy
readers keep their own cursors (plain ints, never published). `read_new` returns a
`Batch` (records, cursor, lost); the recorder checks ``lost == 0``, saves the records,
then publishes its cursor with `commit_read`.

Ownership and cleanup
---------------------
The process that calls `RecordRing.create` owns the segment; everyone else uses
`RecordRing.attach`. Every handle calls `close()`; only the owner calls `unlink()`. Who
removes a segment when, and why attachers map it without the resource tracker, are
device.recording.segment's notes.

Memory ordering
---------------
No locks: each counter has one writing process, and all counters are aligned int64s
stored and loaded whole through a memoryview (one 8-byte mov: single-copy atomic on
x86-64 and AArch64). Each step below is a separate C call from the interpreter, so
the C compiler cannot reorder them; what remains is the CPU's ordering. We rely on:

1. writer: store ``claim``, then the record's bytes, then ``write``  (store -> store);
2. reader: load ``write``, then copy the slots, then load ``claim``  (load -> load);
3. recorder: copy the slots, then store ``read``  (load -> store);
4. writer: load ``read``, then store into the slot it permits  (load -> store);
5. `drained`: the writer stores ``write`` before ``finished``, a reader loads
   ``finished`` before ``write``.

x86-64 (TSO) keeps all four orders; it reorders only a store with a later load, which
nothing here relies on. With them, a record a reader copies is either intact or has
an index below ``claim - capacity`` on the re-check, and is dropped. AArch64 is weakly
ordered: without a barrier (``dmb``), which Python cannot issue, a reader could in
principle see ``write`` before the record's bytes. The window is the store buffer's
drain time (nanoseconds), but it is not excluded by the architecture: porting to ARM
needs a fence at those points (a small C extension or an atomics package).
"""

from __future__ import annotations

import os
import struct
import weakref
import zlib
from multiprocessing.shared_memory import SharedMemory
from typing import NamedTuple

import numpy as np

from device.errors import RecordingError, StateError
from device.recording.record import RECORD_DTYPE, empty_records, flat_names, record_struct
from device.recording.segment import (
    NAME_PREFIX,
    RingError,
    SegmentMap,
    map_segment,
    new_ring_name,
    owner_cleanup,
    unlink_segment,
)

_MAGIC = 0x52454841425249  # "REHABRI"
_VERSION = 1
_HEADER_BYTES = 256
# int64 slots of the header. The counters each sit on their own 64-byte cache line so
# the writer's and the recorder's stores do not bounce one line between cores.
_MAGIC_AT, _VERSION_AT, _CAPACITY_AT, _ITEMSIZE_AT, _DTYPE_CRC_AT, _RECORDED_AT = range(6)
_WRITE_AT, _CLAIM_AT = 8, 9
_READ_AT = 16
_FINISHED_AT = 24


class RecordingLost(RecordingError):
    """The recorder fell a whole ring behind: the next record would overwrite one it has not
    saved. The loop must stop the trial (safe state, "recording lost" fault)."""


class Batch(NamedTuple):
    """What `RecordRing.read_new` returns.

    ``records`` are the records with indices ``cursor - len(records)`` … ``cursor - 1``
    (a copy, safe to keep); ``lost`` records before them were overwritten before they
    could be copied (always 0 for the recorder of a ``recorded`` ring).
    """

    records: np.ndarray
    cursor: int
    lost: int


def _dtype_crc(dtype: np.dtype) -> int:
    return zlib.crc32(repr(dtype.descr).encode())

class RecordRing:
    """One shared-memory ring of fixed-size records; see the module docstring for the rules.

    Not thread-safe within a process: one thread per handle.
    """

    def __init__(self, segment: SegmentMap, name: str, dtype: np.dtype,
                 capacity: int, owner: bool) -> None:
        # Private: use create() or attach().
        self._segment = segment
        self._name = name
        self._dtype = dtype
        self._capacity = capacity
        self._itemsize = dtype.itemsize
        self._owner = owner
        self._pending = False
        buf = segment.buf
        self._header_view = buf[:_HEADER_BYTES]
        self._ctr = self._header_view.cast("q")
        self._recorded = bool(self._ctr[_RECORDED_AT])
        # frombuffer, not ndarray(buffer=...): the latter keeps only the mmap alive, so
        # close() would succeed under a live view and the next access would segfault.
        self._records = np.frombuffer(buf, dtype, count=capacity, offset=_HEADER_BYTES)
        self._bytes = np.frombuffer(
            buf, np.uint8, count=capacity * self._itemsize, offset=_HEADER_BYTES
        ).reshape(capacity, self._itemsize)
        self._blank = empty_records(1, dtype).view(np.uint8)
        packer = record_struct(dtype)
        self._pack_into = packer.pack_into if packer is not None else None
        self._finalizer = (
            weakref.finalize(self, owner_cleanup, name, os.getpid()) if owner else None
        )

    # -- creation and attachment ----------------------------------------------------

    @classmethod
    def create(cls, capacity: int, dtype: np.dtype = RECORD_DTYPE, *, recorded: bool = True,
               prefix: str = NAME_PREFIX) -> RecordRing:
        """A new ring owned by this process; pass `name` to the processes that attach.

        ``recorded``: a recorder must read every record, so the writer refuses to overwrite
        records the recorder has not committed. False for a live-view-only ring.
        """
        dtype = np.dtype(dtype)
        if dtype.names is None:
            raise ValueError(f"ring dtype must be a structured record dtype, not {dtype}")
        if capacity < 1:
            raise ValueError(f"ring capacity {capacity}: must be at least 1 record")
        name = new_ring_name(prefix)
        # SharedMemory creates, sizes and registers the segment with the resource tracker
        # (the last-resort cleanup); the map we keep is made like an attacher's.
        created = SharedMemory(name, create=True, size=_HEADER_BYTES + capacity * dtype.itemsize)
        created.close()
        try:
            segment = map_segment(name)
            with segment.buf[:_HEADER_BYTES] as raw, raw.cast("q") as header:
                header[_VERSION_AT] = _VERSION
                header[_CAPACITY_AT] = capacity
                header[_ITEMSIZE_AT] = dtype.itemsize
                header[_DTYPE_CRC_AT] = _dtype_crc(dtype)
                header[_RECORDED_AT] = int(recorded)
                header[_MAGIC_AT] = _MAGIC
            return cls(segment, name, dtype, capacity, owner=True)
        except BaseException:
            unlink_segment(name)
            raise

    @classmethod
    def attach(cls, name: str, dtype: np.dtype = RECORD_DTYPE) -> RecordRing:
        """The ring `name` created by another process (or this one), for writing or reading.

        The dtype must be the creator's, field for field.
        """
        dtype = np.dtype(dtype)
        segment = map_segment(name)
        try:
            capacity = cls._check_layout(segment.buf, name, dtype)
            return cls(segment, name, dtype, capacity, owner=False)
        except BaseException:
            segment.close()
            raise

    @staticmethod
    def _check_layout(buf: memoryview, name: str, dtype: np.dtype) -> int:
        if len(buf) < _HEADER_BYTES:
            raise RingError(f"shared memory {name!r} is {len(buf)} bytes: not a record ring")
        with buf[:_HEADER_BYTES] as raw, raw.cast("q") as header:
            magic, version = header[_MAGIC_AT], header[_VERSION_AT]
            capacity, itemsize = header[_CAPACITY_AT], header[_ITEMSIZE_AT]
            crc = header[_DTYPE_CRC_AT]
        if magic != _MAGIC:
            raise RingError(f"shared memory {name!r} is not a record ring (no ring header)")
        if version != _VERSION:
            raise RingError(f"ring {name!r} has layout version {version}, this code reads "
                            f"{_VERSION}: run the loop and its readers from the same install")
        if itemsize != dtype.itemsize or crc != _dtype_crc(dtype):
            raise RingError(f"ring {name!r} holds {itemsize}-byte records of another dtype "
                            f"than the {dtype.itemsize}-byte one given: attach with the "
                            "creator's dtype (same channels, same order)")
        if len(buf) < _HEADER_BYTES + capacity * itemsize:
            raise RingError(f"ring {name!r} is truncated: {len(buf)} bytes for {capacity} "
                            f"records of {itemsize} bytes")
        return capacity

    # -- writer (the loop) ------------------------------------------------------------

    def would_overwrite_unrecorded(self) -> bool:
        """True when the next record would overwrite one the recorder has not read (O(1))."""
        ctr = self._ctr
        return self._recorded and ctr[_WRITE_AT] - ctr[_READ_AT] >= self._capacity

    def recorder_lag(self) -> int:
        """Records written that the recorder has not committed yet."""
        ctr = self._ctr
        return ctr[_WRITE_AT] - ctr[_READ_AT]

    def push(self, values) -> None:
        """Write and publish one record from plain numbers in `flat_names` order.

        Raises RecordingLost, before touching shared memory, when the record would overwrite
        one the recorder has not read.
        """
        ctr = self._ctr
        written = ctr[_WRITE_AT]
        if self._recorded and written - ctr[_READ_AT] >= self._capacity:
            raise self._lost(written)
        if self._pack_into is None:
            raise RingError(f"push needs a dtype of plain numeric fields; {self._dtype} has "
                            "others: fill slot() and commit() instead")
        self._pending = False
        ctr[_CLAIM_AT] = written + 1
        try:
            self._pack_into(self._segment.buf, _HEADER_BYTES
                            + (written % self._capacity) * self._itemsize, *values)
        except struct.error as e:
            raise RingError(f"push: {e}; give {len(flat_names(self._dtype))} plain numbers "
                            "in flat_names() order") from e
        ctr[_WRITE_AT] = written + 1

    def slot(self) -> np.void:
        """The next record to fill in place (a view into shared memory); publish with commit().

        It starts blank (floats NaN, integers 0). Readers do not see it until commit().
        Calling slot() again before commit() blanks and returns the same record. Raises
        RecordingLost like push(). Drop the view before close().
        """
        ctr = self._ctr
        written = ctr[_WRITE_AT]
        if self._recorded and written - ctr[_READ_AT] >= self._capacity:
            raise self._lost(written)
        ctr[_CLAIM_AT] = written + 1
        self._pending = True
        index = written % self._capacity
        # The slot still holds the record from a ring ago: a field the loop forgets to fill
        # must read as missing (NaN, 0), not as stale data.
        self._bytes[index] = self._blank
        return self._records[index]

    def commit(self) -> None:
        """Publish the record filled through slot()."""
        if not self._pending:
            raise StateError("commit() without slot(): there is no record being filled")
        self._pending = False
        ctr = self._ctr
        ctr[_WRITE_AT] = ctr[_CLAIM_AT]

    def finish(self) -> None:
        """Tell the readers no more records will come (after the last push or commit)."""
        self._ctr[_FINISHED_AT] = 1

    def _lost(self, written: int) -> RecordingLost:
        lag = written - self._ctr[_READ_AT]
        return RecordingLost(
            f"recording lost: the recorder has not read the last {lag} records and the ring "
            f"{self._name!r} holds {self._capacity}; record {written} would overwrite one not "
            "yet saved. Stop the trial: the recorder process is stalled or gone."
        )

    # -- readers ----------------------------------------------------------------------

    def read_new(self, cursor: int, max_n: int | None = None) -> Batch:
        """Copy of the records from index `cursor` on (at most `max_n`), with the new cursor.

        A reader more than a ring behind skips ahead to the oldest record still held; records
        the writer overwrote while they were being copied are dropped; both count in
        ``lost``. Start a cursor at 0 (whole trial) or at `write_count` (from now on).
        """
        ctr = self._ctr
        capacity = self._capacity
        written = ctr[_WRITE_AT]
        if not 0 <= cursor <= written:
            raise RingError(f"cursor {cursor} is outside 0…{written} records written to ring "
                            f"{self._name!r}: was it taken from another ring?")
        start = max(cursor, written - capacity)
        n = written - start
        if max_n is not None:
            if max_n < 0:
                raise ValueError(f"max_n {max_n}: must be 0 or more")
            n = min(n, max_n)
        out = np.empty(n, self._dtype)
        if n:
            self._copy(start, n, out)
        # Whatever the writer may have started overwriting while we copied is below this.
        intact_from = ctr[_CLAIM_AT] - capacity
        end = start + n
        if intact_from > start:
            out = out[min(intact_from, end) - start:]
            end = max(end, intact_from)
        return Batch(out, end, end - len(out) - cursor)

    def _copy(self, start: int, n: int, out: np.ndarray) -> None:
        # As raw bytes: numpy copies a packed structured dtype field by field, ~15x slower.
        dst = out.view(np.uint8).reshape(n, self._itemsize)
        first = start % self._capacity
        k = min(n, self._capacity - first)
        dst[:k] = self._bytes[first:first + k]
        if k < n:
            dst[k:] = self._bytes[:n - k]

    def commit_read(self, cursor: int) -> None:
        """Recorder only: records below `cursor` are safely copied out; the writer may reuse
        their slots. Call after read_new, with the cursor it returned."""
        ctr = self._ctr
        if not ctr[_READ_AT] <= cursor <= ctr[_WRITE_AT]:
            raise RingError(f"commit_read({cursor}) outside {ctr[_READ_AT]}…{ctr[_WRITE_AT]}: "
                            "the recorder cursor only moves forward, up to what was written; "
                            "is a second recorder attached?")
        ctr[_READ_AT] = cursor

    def drained(self, cursor: int) -> bool:
        """True when the writer has finished and `cursor` is past its last record."""
        ctr = self._ctr
        # finished before write: the writer stores them in the other order.
        return bool(ctr[_FINISHED_AT]) and cursor >= ctr[_WRITE_AT]

    # -- state ------------------------------------------------------------------------

    @property
    def name(self) -> str:
        return self._name

    @property
    def capacity(self) -> int:
        return self._capacity

    @property
    def dtype(self) -> np.dtype:
        return self._dtype

    @property
    def owner(self) -> bool:
        return self._owner

    @property
    def recorded(self) -> bool:
        return self._recorded

    @property
    def write_count(self) -> int:
        """Records published since the ring was created."""
        return self._ctr[_WRITE_AT]

    @property
    def recorder_cursor(self) -> int:
        """The recorder's committed cursor: where a restarted recorder resumes."""
        return self._ctr[_READ_AT]

    @property
    def finished(self) -> bool:
        return bool(self._ctr[_FINISHED_AT])

    @property
    def closed(self) -> bool:
        return self._segment is None

    # -- lifetime ---------------------------------------------------------------------

    def close(self) -> None:
        """Unmap this handle's view of the segment. Every handle calls it, once it has
        dropped the views slot() returned; idempotent."""
        if self._segment is None:
            return
        self._records = self._bytes = None
        if self._ctr is not None:
            self._ctr.release()
            self._header_view.release()
            self._ctr = self._header_view = None
        try:
            self._segment.close()
        except BufferError as e:
            raise RingError(f"ring {self._name!r} cannot be unmapped: a record view from slot() "
                            "is still referenced; drop it and close again") from e
        self._segment = None

    def unlink(self) -> None:
        """Owner only: remove the segment's name. Handles already open keep working until
        they close; no new process can attach. Idempotent."""
        if not self._owner:
            raise RingError(f"ring {self._name!r} is owned by another process: attachers only "
                            "close(); the owner unlinks")
        if self._finalizer.detach() is not None:  # None once unlinked: unregister only once
            unlink_segment(self._name)

    def __enter__(self) -> RecordRing:
        return self

    def __exit__(self, *exc_info) -> None:
        try:
            self.close()
        finally:
            if self._owner:
                self.unlink()

    def __repr__(self) -> str:
        role = "owner" if self._owner else "attached"
        state = "closed" if self.closed else f"written={self.write_count}"
        return f"<RecordRing {self._name!r} {role} capacity={self._capacity} {state}>"
