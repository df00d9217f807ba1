"""The recorder: drains the loop's ring in batches into the trial file, in its own process.

It never talks to the robot and the loop never waits for it. It reads the ring every
`POLL_S`, writes the records of the trial (ring sequence numbers from `BeginTrial.first_seq`
to `EndTrial.end_seq`) and flushes at least every `FLUSH_S`, so a crash loses at most that
much. Records outside a trial (connected, at zero torque) are read and dropped, so the ring
never fills with them.

If the disk fails, the recorder raises the shared `recording_failed` flag with the cause
(device.recording.messages: the loop's supervisor turns it into a RECORDING_LOST fault
naming it and stops the trial) and keeps draining; at the trial's end it tells the console
whether the file could still be closed ("closed") or not ("lost": the console finishes the
trial from what reached the file) and lowers the flag for the next trial. A full disk is
not a failure of the file: the writer holds space beyond the file's end
(device.recording.trialfile.reserve), so the recorder says why in the file, writes the
trial's last samples into what is held and closes the file as `recording_lost` with
nothing lost.
If the loop process dies (its pipe reaches end of file), the recorder writes every record
the loop had pushed, adds a "loop process lost" event and closes the file as "faulted".

It raises a beat counter every RECORDER_BEAT_S from a thread of its own, by which the
loop sees a stopped recorder (device.loop.recorder_watch). A stop signal (SIGINT, SIGTERM,
SIGHUP: device.stopsignals) does not end it where it stands: it records the trial until
the loop ends it, closes the file, and then ends. Sent to the console's process group,
the signal reaches the loop too, which stops the trial as a fault naming it; if the loop
has not ended the trial SIGNAL_GRACE_RECORDS later (the recorder alone was signalled),
the recorder's flag stops it. Counted in the loop's records, not in seconds, so which
of the two names the signal does not depend on how promptly either process woke.

Ordering: the loop sends BeginTrial before it pushes the trial's first record, and the
recorder reads the ring *before* it reads its messages, so a record of a trial is never
seen before the message that opens the trial.
"""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
import time
from multiprocessing.connection import Connection

import numpy as np

from device.errors import DeviceError, RecordingError
from device.recording.messages import (
    DISK_SHORT,
    RECORDER_BEAT_S,
    RECORDING_OK,
    STOPPED_BY_SIGNAL,
    WRITE_FAILED,
    BeginTrial,
    EndTrial,
    RecorderNotice,
    TrialEvent,
)
from device.recording.ring import RecordRing
from device.recording.trialfile import TrialFileWriter
from device.recording.trialfile.reserve import SpaceShort
from device.stopsignals import StopSignal

log = logging.getLogger(__name__)

POLL_S = 0.05
SIGNAL_GRACE_RECORDS = 250
"""The loop's ticks (0.5 s) the recorder, told to stop, lets the loop end the trial itself."""
FLUSH_S = 0.25
BATCH = 8192


class Recorder:
    """Drains one ring into trial files; one file at a time."""

    def __init__(self, ring: RecordRing, console: Connection | None, failed_flag=None) -> None:
        self.ring = ring
        self.console = console
        self.failed_flag = failed_flag
        self.cursor = ring.recorder_cursor
        self.writer: TrialFileWriter | None = None
        self.first_seq = 0
        self.end_seq: int | None = None
        self.end_message: EndTrial | None = None
        self.trial_path = ""
        """The file of the trial being recorded ('' between trials)."""
        self.last_flush = time.monotonic()
        self.failed = False
        self.failure = ""
        """Why the trial's file failed, once it did (told again with its "lost" notice)."""
        self.short = ""
        """Why the disk is short, once it is: the file ends on the space it holds."""
        self.samples = 0
        self.last_sample = (float("nan"), -1)
        """The trial time and tick of the last sample written."""

    # ------------------------------------------------------------------ main
    def run(self, loop: Connection, stop: StopSignal | None = None) -> None:
        """Until the loop's pipe closes (or, after a stop signal, until no trial file is
        open): read the ring, then the messages, then write."""
        stop = stop or StopSignal()
        signalled_at: int | None = None  # the ring position at which the signal was seen
        told = False
        while True:
            records, seq0 = self._read()
            loop_alive = True
            messages = []
            try:
                while loop.poll():
                    messages.append(loop.recv())
            except (EOFError, OSError):
                loop_alive = False
            self._handle(records, seq0, messages)
            if not loop_alive:
                self._loop_lost()
                return
            if stop.name:
                if signalled_at is None:
                    signalled_at = self.cursor
                    log.warning("recorder: %s; it ends once the trial's file is closed",
                                stop.words)
                if self.writer is None:
                    return
                if not told and self.cursor - signalled_at > SIGNAL_GRACE_RECORDS:
                    told = True  # the loop was not told: the flag stops the trial
                    self._flag(STOPPED_BY_SIGNAL + getattr(signal, stop.name, 0))
            self._flush_if_due()
            if loop.poll(POLL_S):
                continue

    def _read(self, up_to: int | None = None) -> tuple[np.ndarray, int]:
        """New records from the ring (all of them, or up to sequence `up_to`)."""
        seq0 = self.cursor
        chunks = []
        while True:
            limit = BATCH if up_to is None else max(0, min(BATCH, up_to - self.cursor))
            if limit == 0:
                break
            batch = self.ring.read_new(self.cursor, limit)
            if len(batch.records) == 0:
                break
            chunks.append(batch.records)
            self.cursor = batch.cursor
            self.ring.commit_read(self.cursor)
        if not chunks:
            return np.empty(0, dtype=self.ring.dtype), seq0
        return np.concatenate(chunks) if len(chunks) > 1 else chunks[0], seq0

    def _handle(self, records: np.ndarray, seq0: int, messages: list) -> None:
        pending, pending_seq = records, seq0
        for message in messages:
            if isinstance(message, BeginTrial):
                self._write(pending, pending_seq)  # anything of an earlier trial
                pending, pending_seq = _after(pending, pending_seq, message.first_seq)
                self._open(message)
            elif isinstance(message, TrialEvent):
                self._event(message)
            elif isinstance(message, EndTrial):
                # records up to end_seq were pushed before this message was sent
                more, _ = self._read(up_to=message.end_seq)
                pending = np.concatenate((pending, more)) if len(more) else pending
                self._write(pending, pending_seq, end_seq=message.end_seq)
                pending, pending_seq = _after(pending, pending_seq, message.end_seq)
                self._close(message.status, message.summary, message.assistance)
        self._write(pending, pending_seq)

    # ------------------------------------------------------------------ file
    def _open(self, message: BeginTrial) -> None:
        if self.writer is not None:
            self._close("stopped_early", {})
        self.first_seq = message.first_seq
        self.trial_path = message.path
        self.samples = 0
        self.failed = False
        self.failure = ""
        self.short = ""
        self.last_sample = (float("nan"), -1)
        try:
            self.writer = TrialFileWriter(
                message.path, parameters=message.parameters, subject=message.subject,
                robot=message.robot, backend=message.backend,
                sample_period_s=message.sample_period_s, channels=_channels_for(self.ring),
            )
        except (DeviceError, OSError) as exc:
            # the writer's errors name the file and what to do; an OSError only the errno
            reason = (str(exc) if isinstance(exc, DeviceError)
                      else f"cannot create trial file {message.path}: {exc}")
            self._fail(message.path, reason,
                       DISK_SHORT if isinstance(exc, SpaceShort) else WRITE_FAILED)
            return
        self._notify("opened", message.path)

    def _write(self, records: np.ndarray, seq0: int, end_seq: int | None = None) -> None:
        if self.writer is None or self.failed or len(records) == 0:
            return
        start = max(0, self.first_seq - seq0)
        stop = len(records) if end_seq is None else max(0, min(len(records), end_seq - seq0))
        if stop <= start:
            return
        written = records[start:stop]
        try:
            self.writer.append(written)
        except SpaceShort as exc:
            self._space_short(str(exc))  # after the batch went in
        except (DeviceError, OSError) as exc:
            self._fail(str(self.writer.path), str(exc))
            return
        self.samples += stop - start
        self.last_sample = (float(written["time"][-1]), int(written["tick"][-1]))

    def _event(self, message: TrialEvent) -> None:
        if self.writer is None or self.failed:
            return
        try:
            self.writer.add_event(message.time_s, message.tick, message.kind, message.message,
                                  message.values)
        except (DeviceError, OSError) as exc:
            self._fail(str(self.writer.path), str(exc))

    def _close(self, status: str, summary: dict, assistance: dict | None = None) -> None:
        """The trial is over: its file closed, the console told its fate ("closed", or
        "lost" when it could not be finished: the console then finishes the trial from
        what reached it, with the fault it heard), and the recorder ready for the next
        trial whatever happened to this one's file (the flag back to RECORDING_OK: a flag
        left raised faulted every later trial at once)."""
        writer, self.writer = self.writer, None
        path, self.trial_path = self.trial_path, ""
        try:
            if writer is not None:
                self._finish(writer, status, summary, assistance)
            elif path and self.failed:
                # its file could not even be made: the console finishes the trial without
                self._notify("lost", path, "recording_lost", self.failure)
        finally:
            self.failed = False
            self.failure = ""
            self.short = ""
            self._flag(RECORDING_OK)

    def _finish(self, writer: TrialFileWriter, status: str, summary: dict,
                assistance: dict | None) -> None:
        if self.failed or self.short:
            status = "recording_lost"
        try:
            path = writer.close(status, summary, None, assistance)
        except SpaceShort as exc:
            # every sample is in the file, which reads as it is; only its status is not
            self._notify("closed", str(writer.path), status, str(exc), samples=self.samples)
        except (DeviceError, OSError) as exc:
            # after a write error: the file keeps what reached it before the error
            said = f"{self.failure}; " if self.failure else ""
            self._notify("lost", str(writer.path), "recording_lost",
                         f"{said}could not close the file: {exc}", samples=self.samples)
        else:
            self._notify("closed", str(path), status, samples=self.samples)

    def _flush_if_due(self) -> None:
        if self.writer is None or self.failed:
            return
        now = time.monotonic()
        if now - self.last_flush >= FLUSH_S:
            self.last_flush = now
            try:
                self.writer.flush()
            except SpaceShort as exc:
                self._space_short(str(exc))
            except (DeviceError, OSError) as exc:
                self._fail(str(self.writer.path), str(exc))

    def _fail(self, path: str, reason: str, cause: int = WRITE_FAILED) -> None:
        self.failed = True
        self.failure = self.failure or reason
        self._flag(cause)
        log.error("recording failed for %s: %s", path, reason)
        self._notify("error", path, "recording_lost", reason)

    def _space_short(self, reason: str) -> None:
        """The disk is full: the loop is told (it stops the trial), the file says why, and
        the trial's last samples go into the space the file holds."""
        if self.short:
            return
        self.short = reason
        self._flag(DISK_SHORT)
        path = str(self.writer.path)
        log.error("recording stops for %s: %s", path, reason)
        self._notify("error", path, "recording_lost", reason)
        time_s, tick = self.last_sample
        self._event(TrialEvent(time_s, tick, "recording", reason,
                               {"cause": "disk full", "samples_saved": self.samples}))

    def _flag(self, cause: int) -> None:
        if self.failed_flag is not None:
            self.failed_flag.value = cause

    def _loop_lost(self) -> None:
        """The loop process is gone: keep what it pushed and close the file as faulted."""
        records, seq0 = self._read()
        self._write(records, seq0)
        if self.writer is not None:
            self._event(TrialEvent(float("nan"), -1, "fault",
                                   "the control loop process stopped unexpectedly; the robot's "
                                   "amplifier watchdog and the backend's close hold it safe",
                                   {"cause": "loop process lost"}))
        if self.trial_path:  # a file that was not made is told "lost" too
            self._close("faulted", {"loop_process_lost": 1.0})

    def _notify(self, kind: str, path: str, status: str = "", message: str = "",
                samples: int = 0) -> None:
        if self.console is None:
            return
        # a console that is gone cannot be told; the file is what matters
        with contextlib.suppress(OSError, EOFError, BrokenPipeError):
            self.console.send(RecorderNotice(kind, path, status, message, samples))


def _after(records: np.ndarray, seq0: int, seq: int) -> tuple[np.ndarray, int]:
    """The records from sequence number `seq` on."""
    skip = max(0, min(len(records), seq - seq0))
    return records[skip:], seq0 + skip


def _channels_for(ring: RecordRing):
    from device.recording.record import CHANNELS, RECORD_DTYPE

    if ring.dtype == RECORD_DTYPE:
        return CHANNELS
    raise RecordingError("the ring carries extra channels; pass them to the recorder")


def recorder_main(loop_conn, console_conn, ring_name: str, failed_flag, beat=None) -> None:
    """Entry point of the recorder process."""
    stop = StopSignal().install()  # first: see device.stopsignals
    logging.basicConfig(level=logging.INFO)
    ring = RecordRing.attach(ring_name)
    beating = threading.Event()
    if beat is not None:
        threading.Thread(target=_beat, args=(beat, beating), name="rehab-recorder-beat",
                         daemon=True).start()
    try:
        Recorder(ring, console_conn, failed_flag).run(loop_conn, stop)
    finally:
        beating.set()
        ring.close()
        console_conn.close()


def _beat(beat, stop: threading.Event) -> None:
    """Raise the beat counter every RECORDER_BEAT_S until told to stop: the loop's proof
    that this process runs (a stopped process raises nothing)."""
    while not stop.wait(RECORDER_BEAT_S):
        beat.value += 1
