"""The recorder in this process (a thread in place of its process, a ring and pipes of its
own): what it writes when the disk fills, what it tells the loop and the console."""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import threading
import time
from dataclasses import dataclass, field

import h5py
import numpy as np
import pytest

from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.recording.messages import (
    DISK_SHORT,
    RECORDING_OK,
    BeginTrial,
    EndTrial,
    RecorderNotice,
)
from device.recording.record import RECORD_DTYPE
from device.recording.recorder import Recorder
from device.recording.ring import RecordRing
from device.recording.trialfile import SubjectInfo
from tests.device.smalldisk import DISK_KIND, SmallDisk

PARAMS = THESIS_SUBJECT.replace(repetitions=1)
SUBJECT = SubjectInfo.from_parameters("PREC01", PARAMS)
PERIOD_S = 0.002


@dataclass
class Flag:
    """The recording-failed flag the loop reads (a shared counter in the real processes)."""

    value: int = RECORDING_OK


@dataclass
class RecorderUnderTest:
    ring: RecordRing
    loop: object
    notices: object
    flag: Flag
    thread: threading.Thread
    seen: list = field(default_factory=list)
    tick: int = 0

    def push(self, n: int) -> None:
        """n ticks of a running trial into the ring, as the loop pushes them."""
        for _ in range(n):
            slot = self.ring.slot()
            slot["tick"] = self.tick
            slot["time"] = self.tick * PERIOD_S
            slot["lateness"] = 0.0
            slot["compute_time"] = 1e-5
            self.ring.commit()
            self.tick += 1

    def begin(self, path) -> None:
        self.loop.send(BeginTrial(str(path), self.ring.write_count, PARAMS, SUBJECT, {},
                                  "simulator", PERIOD_S))

    def end(self, status: str) -> None:
        self.loop.send(EndTrial(self.ring.write_count, status, {}))

    def notice(self, kind: str, timeout: float = 20.0) -> RecorderNotice:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for seen in self.seen:
                if seen.kind == kind:
                    self.seen.remove(seen)
                    return seen
            if self.notices.poll(0.05):
                self.seen.append(self.notices.recv())
        raise AssertionError(f"no {kind!r} notice within {timeout} s; saw {self.seen}")

    def wait(self, predicate, what: str, timeout: float = 20.0) -> None:
        deadline = time.monotonic() + timeout
        while not predicate():
            assert time.monotonic() < deadline, f"{what} within {timeout} s"
            time.sleep(0.01)


@contextlib.contextmanager
def running_recorder(capacity: int = 20_000):
    ring = RecordRing.create(capacity, RECORD_DTYPE, prefix="rectest_")
    loop_end, recorder_end = mp.Pipe()
    notices_read, notices_write = mp.Pipe(duplex=False)
    flag = Flag()
    recorder = Recorder(ring, notices_write, flag)
    thread = threading.Thread(target=recorder.run, args=(recorder_end,), daemon=True)
    thread.start()
    test = RecorderUnderTest(ring, loop_end, notices_read, flag, thread)
    try:
        yield test
    finally:
        loop_end.close()
        thread.join(20)
        ring.close()
        ring.unlink()


@pytest.fixture
def big_enough_disk(tmp_path):
    """A disk with room for a trial beside the 64 MiB the recorder keeps free."""
    with SmallDisk(tmp_path, 96) as disk:
        yield disk


@pytest.mark.parametrize("kind", [DISK_KIND])
def test_a_disk_filled_mid_trial_ends_the_file_in_good_order_with_nothing_lost(
        big_enough_disk, kind):
    """Issue 28 #2: the recorder stopped writing at the full disk's first error and the
    close made the file unreadable. Now it tells the loop why (DISK_SHORT, which the loop
    turns into RECORDING_LOST naming the disk), says why in the file, writes every sample
    the loop pushed until its stop into the space the file holds, and closes it."""
    path = big_enough_disk.root / "trial.h5"
    with running_recorder() as rec:
        rec.begin(path)
        rec.push(1500)
        assert rec.notice("opened").path == str(path)
        rec.wait(lambda: rec.ring.recorder_cursor == rec.ring.write_count, "drained")
        big_enough_disk.fill()
        rec.push(200)
        rec.wait(lambda: rec.flag.value != RECORDING_OK, "the recorder raised its flag")
        assert rec.flag.value == DISK_SHORT
        error = rec.notice("error")
        assert "full" in error.message or "MiB free" in error.message
        rec.push(60)  # the loop's ticks until its fault stops the trial
        rec.end("recording_lost")
        closed = rec.notice("closed")
    assert closed.status == "recording_lost"
    assert closed.samples == 1760
    assert rec.flag.value == RECORDING_OK  # ready for the next trial
    data = read_trial(path)
    assert data.status == "recording_lost"
    np.testing.assert_array_equal(data.channels["tick"], np.arange(1760))
    recording = [e for e in data.events if e["kind"] == "recording"]
    assert recording
    assert recording[0]["values"]["cause"] == "disk full"
    with h5py.File(path, "r") as f:  # a plain reader too: nothing left flagged
        assert f["timeseries/tick"].shape == (1760,)
    big_enough_disk.free()


def test_after_a_write_error_the_console_is_told_the_file_is_lost_and_the_next_trial_records(
        tmp_path, monkeypatch):
    """A write that fails (EIO) stops the trial (WRITE_FAILED). The close of that file
    failed too, and the recorder only said "error": the console never heard the trial's
    file was finished either way, so the window kept the trial 'recording' in the registry
    (its cause nowhere) and Start waiting for the file to close, and the flag stayed
    raised, so every later trial faulted at once and wrote nothing. Now the console hears
    "lost" (the window then finishes the trial with the fault it saw) and the next trial
    records whole."""
    import errno

    from device.recording.messages import WRITE_FAILED
    from device.recording.trialfile import TrialFileWriter

    first, second = tmp_path / "first.h5", tmp_path / "second.h5"
    flush = TrialFileWriter._flush

    def failing(self):
        raise OSError(errno.EIO, "Input/output error")

    with running_recorder() as rec:
        rec.begin(first)
        rec.push(300)
        assert rec.notice("opened").path == str(first)
        rec.wait(lambda: rec.ring.recorder_cursor == rec.ring.write_count, "drained")
        monkeypatch.setattr(TrialFileWriter, "_flush", failing)
        rec.push(200)
        rec.wait(lambda: rec.flag.value != RECORDING_OK, "the recorder raised its flag")
        assert rec.flag.value == WRITE_FAILED
        assert "Input/output error" in rec.notice("error").message
        rec.end("recording_lost")
        lost = rec.notice("lost")
        assert (lost.path, lost.status) == (str(first), "recording_lost")
        assert "could not close" in lost.message
        rec.wait(lambda: rec.flag.value == RECORDING_OK, "the flag lowered for the next trial")
        monkeypatch.setattr(TrialFileWriter, "_flush", flush)  # the disk works again
        rec.tick = 0
        rec.begin(second)
        rec.push(400)
        assert rec.notice("opened").path == str(second)
        rec.end("complete")
        closed = rec.notice("closed")
    assert (closed.path, closed.status, closed.samples) == (str(second), "complete", 400)
    assert rec.flag.value == RECORDING_OK
    data = read_trial(second)
    assert data.status == "complete"
    np.testing.assert_array_equal(data.channels["tick"], np.arange(400))
    kept = read_trial(first)  # what reached the failing file still reads
    np.testing.assert_array_equal(kept.channels["tick"], np.arange(len(kept.channels["tick"])))


def test_a_trial_whose_file_cannot_be_made_is_told_lost_and_the_next_one_records(tmp_path):
    """A trial file that cannot be created (here: its folder is a file) raised the flag for
    good: the trial's end was never told to the console, and the next trial faulted at
    once. Now its end is "lost" and the next trial records."""
    blocked = tmp_path / "not-a-folder"
    blocked.write_text("")
    with running_recorder() as rec:
        rec.begin(blocked / "t.h5")
        rec.push(50)
        rec.wait(lambda: rec.flag.value != RECORDING_OK, "the recorder raised its flag")
        assert "cannot create" in rec.notice("error").message
        rec.end("recording_lost")
        assert rec.notice("lost").path == str(blocked / "t.h5")
        rec.wait(lambda: rec.flag.value == RECORDING_OK, "the flag lowered for the next trial")
        rec.tick = 0
        rec.begin(tmp_path / "next.h5")
        rec.push(100)
        rec.end("complete")
        closed = rec.notice("closed")
    assert (closed.status, closed.samples) == ("complete", 100)


def test_a_trial_whose_file_cannot_be_made_is_told_lost_when_the_loop_dies(tmp_path):
    """The loop process dying during such a trial ended the recorder without a word of the
    trial's file: the console, which hears the loop's death but not how the file ended,
    kept the trial 'recording'. Now the file's end is told first ("lost")."""
    blocked = tmp_path / "not-a-folder"
    blocked.write_text("")
    with running_recorder() as rec:
        rec.begin(blocked / "t.h5")
        rec.push(50)
        assert "cannot create" in rec.notice("error").message
        rec.loop.close()  # the loop process is gone: its pipe's end of file
        lost = rec.notice("lost")
    assert (lost.path, lost.status) == (str(blocked / "t.h5"), "recording_lost")
    assert "does not exist" in lost.message
