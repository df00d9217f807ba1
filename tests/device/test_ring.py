"""The shared-memory record ring: ordering, cursors, loss detection, torn reads, cleanup.

Records carry their sequence number in every field (see `values_for`), so a record
stitched from two writes, a gap or a duplicate shows as a mismatch with the record
`expected` rebuilds from its `tick`. Cross-process tests spawn their processes (fork
in a process with numpy's threads warns on Python 3.12). Every test has its own name
prefix and fails if a segment with it is left in /dev/shm.
"""

from __future__ import annotations

import gc
import multiprocessing as mp
import os
import secrets
import signal
import subprocess
import sys
import textwrap
import time
from multiprocessing import shared_memory
from pathlib import Path

import numpy as np
import pytest

from device.errors import DeviceError, RecordingError, StateError
from device.recording.record import RECORD_DTYPE, Channel, extend_channels
from device.recording.ring import RecordingLost, RecordRing, flat_names
from device.recording.segment import SHM_DIR, RingError, reclaim_stale

ROOT = Path(__file__).resolve().parents[2]
CHILD_TIMEOUT_S = 60.0

pytestmark = pytest.mark.skipif(not SHM_DIR.is_dir(), reason="needs Linux /dev/shm")


# -- records derived from a sequence number --------------------------------------------

def _layout(dtype: np.dtype) -> list[tuple[str, int, int]]:
    """(kind, itemsize, flat position) of every number push() takes."""
    layout = []
    for name in dtype.names:
        field = dtype.fields[name][0]
        count = int(np.prod(field.shape)) if field.shape else 1
        first = len(layout)
        layout.extend((field.base.kind, field.base.itemsize, first + k) for k in range(count))
    return layout


def _number(seq, kind: str, itemsize: int, position: int):
    if kind == "f":
        return seq + position * 0.25  # exact in float32 for seq < 2**21
    if kind == "u":
        return seq % (1 << (8 * itemsize))
    if kind == "b":
        return seq % 2 == 1
    return seq


def values_for(seq: int, layout) -> tuple:
    return tuple(_number(seq, kind, size, pos) for kind, size, pos in layout)


def expected(seqs, dtype: np.dtype = RECORD_DTYPE) -> np.ndarray:
    seqs = np.asarray(seqs, dtype=np.int64)
    out = np.zeros(seqs.size, dtype)
    position = 0
    for name in dtype.names:
        field = dtype.fields[name][0]
        count = int(np.prod(field.shape)) if field.shape else 1
        columns = [_number(seqs, field.base.kind, field.base.itemsize, position + k)
                   for k in range(count)]
        position += count
        out[name] = (np.stack(columns, axis=-1).reshape(seqs.size, *field.shape)
                     if field.shape else columns[0])
    return out


def torn_indices(records: np.ndarray) -> np.ndarray:
    """Indices of records whose fields do not all agree with their own tick."""
    want = expected(records["tick"], records.dtype)
    itemsize = records.dtype.itemsize
    got_bytes = records.view(np.uint8).reshape(-1, itemsize)
    want_bytes = want.view(np.uint8).reshape(-1, itemsize)
    return np.flatnonzero((got_bytes != want_bytes).any(axis=1))


def assert_records(records: np.ndarray, first: int) -> None:
    ticks = records["tick"]
    want = np.arange(first, first + len(records))
    assert np.array_equal(ticks, want), f"ticks {ticks[:8]}… expected from {first}"
    torn = torn_indices(records)
    assert torn.size == 0, f"records {ticks[torn[:5]]} have fields from another record"


def fill(ring: RecordRing, first: int, n: int) -> None:
    layout = _layout(ring.dtype)
    for seq in range(first, first + n):
        ring.push(values_for(seq, layout))


# -- fixtures ---------------------------------------------------------------------------

def _segments(prefix: str) -> list[str]:
    return sorted(p.name for p in SHM_DIR.iterdir() if p.name.startswith(prefix))


@pytest.fixture
def prefix():
    """A name prefix of this test's own; fails the test if a segment with it is left."""
    prefix = f"ringtest_{secrets.token_hex(4)}_"
    yield prefix
    left = _segments(prefix)
    for name in left:  # do not leak into the next run even when failing
        (SHM_DIR / name).unlink(missing_ok=True)
    assert not left, f"shared memory left behind: {left}"


@pytest.fixture
def spawn(monkeypatch):
    """A spawn context whose children can import this module (and so its targets)."""
    monkeypatch.syspath_prepend(str(ROOT))
    return mp.get_context("spawn")


def _join(process, timeout=CHILD_TIMEOUT_S) -> None:
    process.join(timeout)
    if process.is_alive():
        process.kill()
        process.join()
        pytest.fail(f"{process.name} did not finish within {timeout} s")
    assert process.exitcode == 0, f"{process.name} exited with {process.exitcode}"


# -- single process ---------------------------------------------------------------------

def test_records_come_out_in_order_across_many_wraparounds(prefix):
    rng = np.random.default_rng(1)
    with RecordRing.create(5, prefix=prefix) as ring:
        cursor = 0
        written = 0
        while written < 200:
            n = int(rng.integers(0, 6 - ring.recorder_lag()))
            fill(ring, written, n)
            written += n
            batch = ring.read_new(cursor, max_n=int(rng.integers(1, 7)))
            assert batch.lost == 0
            assert_records(batch.records, cursor)
            assert batch.cursor == cursor + len(batch.records)
            cursor = batch.cursor
            ring.commit_read(cursor)
            assert ring.recorder_cursor == cursor
        batch = ring.read_new(cursor)
        assert_records(batch.records, cursor)
        assert batch.cursor == written == ring.write_count


def test_read_new_returns_a_copy_that_later_writes_do_not_change(prefix):
    with RecordRing.create(4, recorded=False, prefix=prefix) as ring:
        fill(ring, 0, 4)
        records = ring.read_new(0).records
        records["time"] = -1.0
        assert_records(ring.read_new(0).records, 0)
        fill(ring, 4, 8)
        assert np.array_equal(records["tick"], [0, 1, 2, 3])


def test_lossy_reader_skips_ahead_and_counts_what_it_lost(prefix):
    with RecordRing.create(8, recorded=False, prefix=prefix) as ring:
        fill(ring, 0, 30)
        records, cursor, lost = ring.read_new(0)
        assert (cursor, lost) == (30, 22)
        assert_records(records, 22)

        records, cursor, lost = ring.read_new(3, max_n=3)
        assert (cursor, lost) == (25, 19)
        assert_records(records, 22)

        records, cursor, lost = ring.read_new(25)
        assert (cursor, lost) == (30, 0)
        assert_records(records, 25)
        records, cursor, lost = ring.read_new(30)
        assert (len(records), cursor, lost) == (0, 30, 0)


def test_lossy_reader_starting_now_sees_only_new_records(prefix):
    with RecordRing.create(8, recorded=False, prefix=prefix) as ring:
        fill(ring, 0, 5)
        cursor = ring.write_count
        assert len(ring.read_new(cursor).records) == 0
        fill(ring, 5, 2)
        records, cursor, lost = ring.read_new(cursor)
        assert_records(records, 5)
        assert (cursor, lost) == (7, 0)


def test_writer_refuses_exactly_when_the_next_record_would_overwrite_an_unread_one(prefix):
    with RecordRing.create(6, prefix=prefix) as ring:
        fill(ring, 0, 5)
        assert not ring.would_overwrite_unrecorded()
        assert ring.recorder_lag() == 5
        fill(ring, 5, 1)
        assert ring.would_overwrite_unrecorded()
        assert ring.recorder_lag() == 6
        with pytest.raises(RecordingLost, match="recording lost"):
            fill(ring, 6, 1)
        with pytest.raises(RecordingLost):
            ring.slot()
        assert ring.write_count == 6

        # The recorder still finds every record, the oldest one included, intact.
        records, cursor, lost = ring.read_new(0)
        assert (cursor, lost) == (6, 0)
        assert_records(records, 0)

        ring.commit_read(1)
        assert not ring.would_overwrite_unrecorded()
        fill(ring, 6, 1)
        assert ring.would_overwrite_unrecorded()
        ring.commit_read(7)
        assert ring.recorder_lag() == 0
        fill(ring, 7, 6)
        assert ring.would_overwrite_unrecorded()


def test_recording_lost_is_a_device_recording_error():
    assert issubclass(RecordingLost, RecordingError)
    assert issubclass(RingError, DeviceError)


def test_unrecorded_ring_never_refuses(prefix):
    with RecordRing.create(3, recorded=False, prefix=prefix) as ring:
        fill(ring, 0, 10)
        assert not ring.would_overwrite_unrecorded()
        assert ring.recorder_lag() == 10


def test_a_slot_being_filled_hides_the_record_it_overwrites(prefix):
    with RecordRing.create(4, recorded=False, prefix=prefix) as ring:
        fill(ring, 0, 4)
        assert ring.read_new(0).lost == 0
        record = ring.slot()  # overwrites record 0's slot from now on
        record["tick"] = 4
        records, cursor, lost = ring.read_new(0)
        assert (cursor, lost) == (4, 1)
        assert_records(records, 1)
        assert len(ring.read_new(4).records) == 0  # not published yet
        ring.commit()
        del record
        records, cursor, lost = ring.read_new(0)
        assert (cursor, lost) == (5, 1)
        assert records["tick"].tolist() == [1, 2, 3, 4]


def test_slot_starts_blank_and_commit_publishes_it(prefix):
    with RecordRing.create(2, recorded=False, prefix=prefix) as ring:
        fill(ring, 0, 2)
        record = ring.slot()
        assert record["tick"] == 0
        assert np.isnan(record["time"])
        assert np.isnan(record["robot_angle"]).all()
        assert ring.slot()["tick"] == 0  # the same slot until commit
        record["tick"] = 2
        record["time"] = 0.004
        record["robot_angle"] = (0.1, 0.2)
        ring.commit()
        with pytest.raises(StateError, match="without slot"):
            ring.commit()
        del record
        (last,) = ring.read_new(2).records
        assert last["tick"] == 2
        assert last["time"] == 0.004
        assert last["robot_angle"].tolist() == [0.1, 0.2]
        assert np.isnan(last["force"]).all()


def test_recorder_reads_a_full_ring_without_loss(prefix):
    # The writer is stopped by the full ring, so no slot is being overwritten: all
    # `capacity` records are readable, the oldest included.
    with RecordRing.create(4, prefix=prefix) as ring:
        fill(ring, 0, 4)
        with pytest.raises(RecordingLost):
            ring.push(values_for(4, _layout(ring.dtype)))
        records, cursor, lost = ring.read_new(0)
        assert (cursor, lost) == (4, 0)
        assert_records(records, 0)


@pytest.mark.parametrize(("overwritten", "capacity", "first_kept"), [
    (1, 8, 1),    # the writer finished one record during our copy
    (3, 8, 3),
    (8, 8, 8),    # all copied slots overwritten: nothing returned
    (11, 8, 11),  # more than a ring: the records not even copied are lost too
])
def test_records_overwritten_during_the_copy_are_dropped(prefix, monkeypatch, overwritten,
                                                          capacity, first_kept):
    with RecordRing.create(capacity, recorded=False, prefix=prefix) as writer:
        reader = RecordRing.attach(writer.name)
        try:
            fill(writer, 0, capacity)
            copy = reader._copy

            def copy_while_the_writer_runs(start, n, out):
                copy(start, n, out)
                fill(writer, capacity, overwritten)

            monkeypatch.setattr(reader, "_copy", copy_while_the_writer_runs)
            records, cursor, lost = reader.read_new(0)
            assert torn_indices(records).size == 0
            assert (cursor, lost) == (max(capacity, first_kept), first_kept)
            assert_records(records, first_kept)
        finally:
            reader.close()


def test_a_slot_claimed_during_the_copy_is_dropped(prefix, monkeypatch):
    with RecordRing.create(4, recorded=False, prefix=prefix) as writer:
        reader = RecordRing.attach(writer.name)
        try:
            fill(writer, 0, 4)
            copy = reader._copy
            monkeypatch.setattr(reader, "_copy", lambda *args: (copy(*args), writer.slot()))
            records, cursor, lost = reader.read_new(0)
            assert (cursor, lost) == (4, 1)
            assert_records(records, 1)
        finally:
            reader.close()


def test_extended_dtype_round_trips_and_attach_checks_the_dtype(prefix):
    _, dtype = extend_channels((
        Channel("emg", 8, "f4", "V", "none", "EMG samples"),
        Channel("video_frame", 1, "i4", "1", "none", "camera frame index"),
    ))
    with RecordRing.create(16, dtype, prefix=prefix) as ring:
        assert flat_names(dtype)[-9:] == (*(f"emg[{i}]" for i in range(8)), "video_frame")
        fill(ring, 0, 16)
        reader = RecordRing.attach(ring.name, dtype)
        try:
            assert_records(reader.read_new(0).records, 0)
        finally:
            reader.close()
        with pytest.raises(RingError, match="another dtype"):
            RecordRing.attach(ring.name)
        with pytest.raises(RingError, match="another dtype"):
            RecordRing.attach(ring.name, RECORD_DTYPE.descr[::-1])


def test_flat_names_follow_the_dtype():
    names = flat_names()
    assert names[0] == "tick"
    assert names.index("robot_angle[1]") == names.index("robot_angle[0]") + 1
    assert len(names) == sum(int(np.prod(RECORD_DTYPE.fields[n][0].shape)) or 1
                             for n in RECORD_DTYPE.names)


def test_push_rejects_values_that_do_not_fit_the_record(prefix):
    layout = _layout(RECORD_DTYPE)
    with RecordRing.create(4, prefix=prefix) as ring:
        good = values_for(0, layout)
        with pytest.raises(RingError, match="flat_names"):
            ring.push(good[:-1])
        with pytest.raises(RingError, match="flat_names"):
            ring.push((0.5, *good[1:]))  # tick is an integer field
        assert ring.write_count == 0
        ring.push(good)
        assert_records(ring.read_new(0).records, 0)


def test_push_needs_numeric_fields_but_slot_does_not(prefix):
    dtype = np.dtype([("tick", "i8"), ("label", "S8")])
    with RecordRing.create(4, dtype, prefix=prefix) as ring:
        with pytest.raises(RingError, match="slot"):
            ring.push((1, b"x"))
        record = ring.slot()
        record["tick"], record["label"] = 1, b"start"
        ring.commit()
        del record
        assert ring.read_new(0).records.tolist() == [(1, b"start")]


def test_create_and_attach_refuse_bad_arguments(prefix):
    with pytest.raises(ValueError, match="capacity"):
        RecordRing.create(0, prefix=prefix)
    with pytest.raises(ValueError, match="structured"):
        RecordRing.create(4, np.float64, prefix=prefix)
    with pytest.raises(ValueError, match="prefix"):
        RecordRing.create(4, prefix="bad/prefix_")
    with pytest.raises(RingError, match="no ring named"):
        RecordRing.attach(f"{prefix}1_missing")

    plain = shared_memory.SharedMemory(f"{prefix}1_plain", create=True, size=4096)
    try:
        with pytest.raises(RingError, match="not a record ring"):
            RecordRing.attach(plain.name)
    finally:
        plain.close()
        plain.unlink()


def test_cursors_outside_the_written_range_are_refused(prefix):
    with RecordRing.create(4, prefix=prefix) as ring:
        fill(ring, 0, 3)
        with pytest.raises(RingError, match="cursor 4"):
            ring.read_new(4)
        with pytest.raises(ValueError, match="max_n"):
            ring.read_new(0, max_n=-1)
        with pytest.raises(RingError, match="commit_read"):
            ring.commit_read(4)
        ring.commit_read(2)
        with pytest.raises(RingError, match="only moves forward"):
            ring.commit_read(1)


def test_finish_and_drained(prefix):
    with RecordRing.create(4, prefix=prefix) as ring:
        fill(ring, 0, 2)
        assert not ring.drained(2)
        ring.finish()
        assert ring.finished
        assert not ring.drained(1)
        assert ring.drained(2)


# -- ownership and cleanup ---------------------------------------------------------------

def _mapped(name: str) -> bool:
    """Whether this process still maps the segment or holds a descriptor on it."""
    if f"/dev/shm/{name}" in Path("/proc/self/maps").read_text():
        return True
    for fd in Path("/proc/self/fd").iterdir():
        try:
            if name in os.readlink(fd):
                return True
        except OSError:  # closed while we looked (the listing's own descriptor)
            continue
    return False


def test_create_attach_close_unlink_twice_in_one_process_leaves_nothing(prefix):
    for _ in range(2):
        owner = RecordRing.create(8, prefix=prefix)
        name = owner.name
        reader = RecordRing.attach(name)
        fill(owner, 0, 5)
        assert_records(reader.read_new(0).records, 0)
        assert _segments(prefix) == [name]
        reader.close()
        reader.close()
        owner.close()
        assert _segments(prefix) == [name]  # close alone does not remove it
        owner.unlink()
        owner.unlink()
        assert _segments(prefix) == []
        assert not _mapped(name)
        assert owner.closed
        assert reader.closed


def test_only_the_owner_unlinks_and_readers_outlive_the_name(prefix):
    owner = RecordRing.create(8, prefix=prefix)
    reader = RecordRing.attach(owner.name)
    try:
        with pytest.raises(RingError, match="owned by another process"):
            reader.unlink()
        fill(owner, 0, 3)
        owner.unlink()
        assert _segments(prefix) == []
        with pytest.raises(RingError, match="no ring named"):
            RecordRing.attach(owner.name)
        fill(owner, 3, 2)
        assert_records(reader.read_new(0).records, 0)
    finally:
        reader.close()
        owner.close()


def test_close_refuses_while_a_slot_view_is_held(prefix):
    with RecordRing.create(4, prefix=prefix) as ring:
        record = ring.slot()
        with pytest.raises(RingError, match="slot"):
            ring.close()
        del record
        ring.close()
        assert ring.closed


def test_owner_that_forgets_to_unlink_is_cleaned_up_when_collected(prefix):
    ring = RecordRing.create(4, prefix=prefix)
    fill(ring, 0, 2)
    assert _segments(prefix) == [ring.name]
    del ring
    gc.collect()
    assert _segments(prefix) == []


def _dead_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_reclaim_unlinks_only_rings_whose_owner_is_gone(prefix):
    stale = shared_memory.SharedMemory(f"{prefix}{_dead_pid()}_0", create=True, size=4096)
    stale.close()
    foreign = shared_memory.SharedMemory(f"{prefix}nopid", create=True, size=4096)
    with RecordRing.create(4, prefix=prefix) as live:
        try:
            assert reclaim_stale(prefix) == [stale.name]
            assert _segments(prefix) == sorted([live.name, foreign.name])
            assert reclaim_stale(prefix) == []
        finally:
            foreign.close()
            foreign.unlink()


def test_reclaim_treats_a_zombie_owner_as_gone(prefix):
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    try:
        deadline = time.monotonic() + 10
        stat = Path(f"/proc/{child.pid}/stat")
        while stat.read_text().rpartition(")")[2].split()[0] != "Z":
            assert time.monotonic() < deadline, "child did not exit"
            time.sleep(0.01)
        zombie = shared_memory.SharedMemory(f"{prefix}{child.pid}_0", create=True, size=4096)
        zombie.close()
        assert reclaim_stale(prefix) == [zombie.name]
    finally:
        child.wait()


# -- across processes ---------------------------------------------------------------------

def _writer(name: str, n: int, conn) -> None:
    """Pushes records 0…n-1, waiting whenever the recorder is a whole ring behind."""
    ring = RecordRing.attach(name)
    try:
        layout = _layout(ring.dtype)
        waits = 0
        for seq in range(n):
            while ring.would_overwrite_unrecorded():
                waits += 1
                time.sleep(0)
            ring.push(values_for(seq, layout))
        ring.finish()
        conn.send(waits)
    finally:
        ring.close()


def test_recorder_in_another_process_gets_every_record_once_and_whole(prefix, spawn):
    n = 200_000
    with RecordRing.create(512, prefix=prefix) as ring:
        parent, child = spawn.Pipe()
        writer = spawn.Process(target=_writer, args=(ring.name, n, child), name="writer")
        writer.start()
        cursor = batches = 0
        deadline = time.monotonic() + CHILD_TIMEOUT_S
        while not ring.drained(cursor):
            assert time.monotonic() < deadline, f"recorder stuck at {cursor} of {n}"
            assert writer.is_alive() or writer.exitcode == 0, "writer died"
            time.sleep(0.0005)  # drain in batches, as the recorder does
            batches += 1
            if batches == 10:  # stall until the writer has filled the ring and must wait
                while ring.recorder_lag() < ring.capacity:
                    assert time.monotonic() < deadline, "writer never filled the ring"
                    time.sleep(0.001)
            records, new_cursor, lost = ring.read_new(cursor)
            assert lost == 0
            assert_records(records, cursor)
            cursor = new_cursor
            ring.commit_read(cursor)
        waits = parent.recv()
        _join(writer)
        assert cursor == n == ring.write_count
        assert waits > 0  # the writer was held back, so the refusal rule was exercised


def _racing_writer(name: str, n: int) -> None:
    ring = RecordRing.attach(name)
    try:
        fill(ring, 0, n)
        ring.finish()
    finally:
        ring.close()


def test_lossy_reader_in_another_process_never_returns_a_torn_record(prefix, spawn):
    # A ring far too small for the reader: the writer overwrites the slots it copies.
    n = 150_000
    with RecordRing.create(16, recorded=False, prefix=prefix) as ring:
        writer = spawn.Process(target=_racing_writer, args=(ring.name, n), name="writer")
        writer.start()
        cursor = read = lost_total = 0
        deadline = time.monotonic() + CHILD_TIMEOUT_S
        while ring.write_count < 3 * ring.capacity:  # be lapped at least once
            assert time.monotonic() < deadline, "writer did not start"
            time.sleep(0.001)
        while not ring.drained(cursor):
            assert time.monotonic() < deadline, f"reader stuck at {cursor} of {n}"
            records, new_cursor, lost = ring.read_new(cursor)
            assert torn_indices(records).size == 0, "torn record returned"
            assert_records(records, new_cursor - len(records))
            assert lost == new_cursor - len(records) - cursor >= 0
            cursor = new_cursor
            read += len(records)
            lost_total += lost
        _join(writer)
        assert read + lost_total == n
        assert read > 0
        assert lost_total > 0


def _stalled_writer(name: str, conn) -> None:
    """Pushes until the recorder is a ring behind, reports, waits, does it again, then
    reports the RecordingLost it gets for pushing anyway."""
    ring = RecordRing.attach(name)
    try:
        layout = _layout(ring.dtype)
        seq = 0
        for _ in range(2):
            while not ring.would_overwrite_unrecorded():
                ring.push(values_for(seq, layout))
                seq += 1
            conn.send((ring.write_count, ring.recorder_lag()))
            conn.recv()
        try:
            ring.push(values_for(seq, layout))
        except RecordingLost as e:
            conn.send(("lost", str(e), ring.write_count))
        else:
            conn.send(("pushed", "", ring.write_count))
    finally:
        ring.close()


def test_writer_notices_a_stalled_recorder_before_overwriting(prefix, spawn):
    with RecordRing.create(256, prefix=prefix) as ring:
        parent, child = spawn.Pipe()
        writer = spawn.Process(target=_stalled_writer, args=(ring.name, child), name="writer")
        writer.start()
        assert parent.poll(CHILD_TIMEOUT_S)
        assert parent.recv() == (256, 256)
        records, cursor, lost = ring.read_new(0, max_n=100)
        ring.commit_read(cursor)
        parent.send("go")
        assert parent.poll(CHILD_TIMEOUT_S)
        assert parent.recv() == (356, 256)
        parent.send("go")
        outcome, message, written = parent.recv()
        assert (outcome, written) == ("lost", 356)
        assert "recording lost" in message
        _join(writer)
        records, cursor, lost = ring.read_new(100)
        assert (cursor, lost) == (356, 0)
        assert_records(records, 100)


def _owner(prefix: str, conn) -> None:
    ring = RecordRing.create(64, prefix=prefix)
    fill(ring, 0, 10)
    conn.send(ring.name)
    conn.recv()  # until killed


def test_killed_owner_leaves_a_readable_segment_that_reclaim_removes(prefix, spawn):
    parent, child = spawn.Pipe()
    owner = spawn.Process(target=_owner, args=(prefix, child), name="owner")
    owner.start()
    assert parent.poll(CHILD_TIMEOUT_S)
    name = parent.recv()
    reader = RecordRing.attach(name)
    try:
        os.kill(owner.pid, signal.SIGKILL)
        owner.join(CHILD_TIMEOUT_S)
        assert owner.exitcode == -signal.SIGKILL
        assert _segments(prefix) == [name]  # nobody unlinked it
        assert_records(reader.read_new(0).records, 0)  # the data survives its writer

        assert reclaim_stale(prefix) == [name]
        assert _segments(prefix) == []
        assert_records(reader.read_new(0).records, 0)  # open mappings stay valid
    finally:
        reader.close()
    assert not _mapped(name)


_TRACKER_SCRIPT = """
import multiprocessing as mp, os, signal, subprocess, sys
from device.recording.ring import RecordRing
from device.recording.segment import reclaim_stale

PREFIX = sys.argv[1]
ATTACH = "from device.recording.ring import RecordRing; r = RecordRing.attach({!r}); r.close()"

def attach_and_close(name):
    ring = RecordRing.attach(name)
    ring.read_new(0)
    ring.close()

def own_and_wait(prefix, conn):
    ring = RecordRing.create(8, prefix=prefix)
    conn.send(ring.name)
    conn.recv()

if __name__ == "__main__":
    ctx = mp.get_context("spawn")
    with RecordRing.create(8, prefix=PREFIX) as ring:
        child = ctx.Process(target=attach_and_close, args=(ring.name,))
        child.start(); child.join()
        # A process with its own resource tracker attaches and exits.
        subprocess.run([sys.executable, "-c", ATTACH.format(ring.name)], check=True)
        # A tracker that wrongly registered the attach would unlink it after that exit;
        # give it the time to do so before looking.
        import time; time.sleep(0.5)
        print("alive after foreign attacher:", os.path.exists("/dev/shm/" + ring.name))
    parent, conn = ctx.Pipe()
    owner = ctx.Process(target=own_and_wait, args=(PREFIX, conn))
    owner.start()
    name = parent.recv()
    os.kill(owner.pid, signal.SIGKILL); owner.join()
    print("reclaimed:", reclaim_stale(PREFIX) == [name])
"""


def test_no_resource_tracker_warnings_and_foreign_attachers_do_not_unlink(prefix, tmp_path):
    # The tracker reports at the exit of the whole process family, so run one of our own.
    script = tmp_path / "tracker_check.py"
    script.write_text(textwrap.dedent(_TRACKER_SCRIPT))
    done = subprocess.run([sys.executable, str(script), prefix], capture_output=True,
                          text=True, timeout=CHILD_TIMEOUT_S, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split("\n")[:2] == ["alive after foreign attacher: True", "reclaimed: True"]
    assert done.stderr == ""
