"""The console's side of the device link: starts the loop and recorder processes, sends
typed commands, reads their events, drains the ring for the live view. Qt-free.

One owner: the window runs a `DeviceClient` on a worker thread (ui.device_bridge); the
headless command line uses it directly. `estop()` and `heartbeat()` only touch shared
counters, so any thread may call them at any time.

Process layout::

    console process ── DeviceClient ── owns the ring (shared memory) and the pipes
        ├── loop process      (device.loop.process.loop_main): the 2 ms loop, the backend
        └── recorder process  (device.recording.recorder.recorder_main): ring → trial file

If the loop dies, the recorder closes the trial file itself and the client reports it;
if the console dies, the loop sees its pipe close, stops the trial and makes the robot
safe, and both children exit. If the recorder dies (its notices' pipe closes), the loop
stops the trial, and the client saves what the recorder had not written from the ring it
owns and closes the trial's file (device.recording.salvage), then tells of it as the
recorder would have ("closed", or "lost" when the file could not be finished).
"""

from __future__ import annotations

import contextlib
import itertools
import multiprocessing as mp
import signal
import threading
import time
from dataclasses import dataclass, replace

import numpy as np

from core.trial import TrialParameters
from device.errors import DeviceError
from device.loop.messages import (
    BackendConfig,
    Build,
    ClearFault,
    Connect,
    Disconnect,
    FaultRaised,
    ForceEstimate,
    Reply,
    SetAssistance,
    ShownToPatient,
    Shutdown,
    Start,
    StateChanged,
    Stop,
    TrialEnded,
    TrialNote,
    TrialStarted,
)
from device.loop.process import LoopConfig, loop_main
from device.loop.states import State
from device.recording.messages import RecorderNotice
from device.recording.record import RECORD_DTYPE
from device.recording.recorder import recorder_main
from device.recording.ring import RecordRing
from device.recording.salvage import LostFault, salvage
from device.recording.segment import reclaim_stale
from device.recording.trialfile import SubjectInfo
from device.safety.limits import SafetyLimits

RING_SECONDS = 16.0
HEARTBEAT_S = 0.1
LOOP_START_S = 120.0
"""How long a command waits for a loop process that has not said anything yet: it answers
once it has imported numpy, its compiled kernels and the backend's modules, which took
over 10 s (a command's own timeout) on the 2-core machine at load 9."""

ANSWER_MARGIN_S = 1.0
"""A Start's limit (Start.answer_by_s) is this much before the console stops waiting, so
that the loop's answer to a Start it took just in time is read before then."""
PATIENCE_S = 10.0
"""How long the console waits for a running loop by default (a command's answer, an
event, fresh samples) before it calls the loop hung; Build and Connect, which compute the
reference and zero the sensor, get three times as long. A live loop answers within a tick
or two: the margin is for a loaded PC. The tests raise it (tests/conftest.py): a shared
CI host can stall a process for 20 s and more, and a test waits for the event itself,
never for a prompt wake-up."""


def _resource_tracker_deaf_to_hangups() -> None:
    """Start multiprocessing's resource tracker (which unlinks the ring if this process
    dies) with SIGHUP blocked: it is in the console's process group and ignores SIGINT and
    SIGTERM, but a closed terminal's SIGHUP killed it, and its successor printed a
    traceback when the ring was unlinked. A blocked signal stays blocked in a child."""
    from multiprocessing import resource_tracker

    if not hasattr(signal, "pthread_sigmask") or not hasattr(signal, "SIGHUP"):
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGHUP})
    try:
        resource_tracker.ensure_running()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


@dataclass
class _Trial:
    """The trial being recorded, as the console heard of it: what a dead recorder's
    successor needs to finish its file."""

    path: str
    first_seq: int
    end_seq: int = -1
    fault: LostFault | None = None


@dataclass(frozen=True, slots=True)
class LoopLost:
    """The loop process ended without being asked to (killed, crashed)."""

    exitcode: int | None
    message: str


class DeviceClient:
    """Start, command and watch the loop; read its records."""

    def __init__(self, *, ring_seconds: float = RING_SECONDS,
                 loop_config: LoopConfig | None = None, auto_heartbeat: bool = True) -> None:
        self.loop_config = loop_config or LoopConfig()
        self.ring_capacity = max(64, round(ring_seconds / self.loop_config.period_s))
        self.auto_heartbeat = auto_heartbeat
        self.state = State.IDLE
        self.ring: RecordRing | None = None
        self._ids = itertools.count(1)
        self._pending: list = []
        self._live_cursor = 0
        self._stop_beats = threading.Event()
        self._beats: threading.Thread | None = None
        self._loop = self._recorder = None
        self._conn = self._notices = None
        self._lost_reported = False
        self._trial: _Trial | None = None
        self._recorder_lost = False
        self._loop_heard = False
        """Whether the loop process has said anything yet (it is past its start)."""

    # ------------------------------------------------------------------ life
    def start(self) -> None:
        """Create the ring and start the loop and recorder processes (state Idle)."""
        if self._loop is not None:
            raise DeviceError("the device link is already started")
        ctx = mp.get_context("spawn")
        _resource_tracker_deaf_to_hangups()
        reclaim_stale()
        self.ring = RecordRing.create(self.ring_capacity, RECORD_DTYPE)
        self.estop_flag = ctx.RawValue("b", 0)
        self.heartbeat_counter = ctx.RawValue("q", 0)
        self.recording_failed = ctx.RawValue("b", 0)
        self.recorder_beat = ctx.RawValue("q", 0)
        console_end, loop_end = ctx.Pipe(duplex=True)
        to_recorder_read, to_recorder_write = ctx.Pipe(duplex=False)
        notices_read, notices_write = ctx.Pipe(duplex=False)
        self._recorder = ctx.Process(
            target=recorder_main, name="rehab-recorder",
            args=(to_recorder_read, notices_write, self.ring.name, self.recording_failed,
                  self.recorder_beat),
        )
        self._loop = ctx.Process(
            target=loop_main, name="rehab-loop",
            args=(loop_end, to_recorder_write, self.ring.name, self.estop_flag,
                  self.heartbeat_counter, self.recording_failed, self.loop_config,
                  self.recorder_beat),
        )
        self._recorder.start()
        self._loop.start()
        # Only the children keep these ends, so a child's death shows as end of file.
        for end in (loop_end, to_recorder_read, to_recorder_write, notices_write):
            end.close()
        self._conn, self._notices = console_end, notices_read
        self._live_cursor = self.ring.write_count
        if self.auto_heartbeat:
            self._beats = threading.Thread(target=self._beat, name="rehab-heartbeat",
                                           daemon=True)
            self._beats.start()

    def close(self, timeout: float = 5.0, signal: str = "") -> list:
        """Shut the loop down (a running trial is stopped and saved; as at a fault naming
        it when the console was given the stop `signal`, device.stopsignals), wait for
        both processes and release the ring. Returns what they said meanwhile (the
        trial's end, its fault, its file closed), for the caller to record. Safe to call
        twice."""
        self._stop_beats.set()
        if self._loop is None:
            return []
        if self._loop.is_alive():
            with contextlib.suppress(OSError, EOFError):
                self._conn.send(Shutdown(next(self._ids), signal))
        for proc in (self._loop, self._recorder):
            proc.join(timeout)
            if proc.is_alive():
                proc.terminate()
                proc.join(1.0)
            if proc.is_alive():  # it catches SIGTERM; a stopped one does not even see it
                proc.kill()
                proc.join(1.0)
        self._lost_reported = True  # asked to end: not "ended unexpectedly"
        # their last words, and a dead recorder's trial finished from the ring (salvage)
        last = self.events(0.0)
        for conn in (self._conn, self._notices):
            conn.close()
        self.ring.close()
        self.ring.unlink()
        self._loop = self._recorder = None
        return last

    def __enter__(self) -> DeviceClient:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def loop_pid(self) -> int | None:
        return None if self._loop is None else self._loop.pid

    @property
    def recorder_pid(self) -> int | None:
        return None if self._recorder is None else self._recorder.pid

    # ------------------------------------------------------------------ safety lines
    def estop(self, held: bool = True) -> None:
        """Press (or release) the emergency stop: the loop zeroes the torque on its next
        tick and latches the fault until it is released and cleared."""
        self.estop_flag.value = 1 if held else 0

    def heartbeat(self) -> None:
        """Tell the loop the console is alive; it must come at least every 0.5 s."""
        self.heartbeat_counter.value += 1

    def _beat(self) -> None:
        while not self._stop_beats.wait(HEARTBEAT_S):
            self.heartbeat()

    # ------------------------------------------------------------------ commands
    def send(self, command) -> int:
        try:
            self._conn.send(command)
        except (OSError, EOFError) as exc:
            raise DeviceError("the control loop is not running; restart the console") from exc
        return command.id

    def request(self, command, timeout: float | None = None) -> Reply:
        """Send a command and wait for its reply (`timeout` default PATIENCE_S); other
        events stay queued for `events`."""
        timeout = PATIENCE_S if timeout is None else timeout
        # a loop still starting answers once it has imported its modules; its death is
        # heard at once (LoopLost), so the longer wait never hides one
        budget = timeout if self._loop_heard else max(timeout, LOOP_START_S)
        deadline = time.monotonic() + budget
        if isinstance(command, Start):  # not run once this console has stopped waiting
            command = replace(command, answer_by_s=deadline - ANSWER_MARGIN_S)
        ident = self.send(command)
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                remaining = 0.0  # one last look: an answer already in the pipe counts
            reply = None
            for event in self._receive(min(remaining, 0.05)):
                if reply is None and isinstance(event, Reply) and event.id == ident:
                    reply = event  # what came with it in the same batch stays queued
                    continue
                self._pending.append(event)
                if isinstance(event, LoopLost):
                    raise DeviceError(event.message)
            if reply is not None:
                return reply
            if remaining <= 0:
                raise DeviceError(f"the loop did not answer {type(command).__name__} within "
                                  f"{budget:g} s")

    def build(self, parameters: TrialParameters, backend: BackendConfig | None = None,
              limits: SafetyLimits | None = None, timeout: float | None = None,
              model=None) -> Reply:
        """Build a trial; `model` is the learned model its parameters name (Build.model)."""
        return self.request(Build(next(self._ids), parameters, backend or BackendConfig(),
                                  limits, model),
                            3 * PATIENCE_S if timeout is None else timeout)

    def connect(self, timeout: float | None = None) -> Reply:
        return self.request(Connect(next(self._ids)),
                            3 * PATIENCE_S if timeout is None else timeout)

    def disconnect(self) -> Reply:
        return self.request(Disconnect(next(self._ids)))

    def start_trial(self, path: str, subject: SubjectInfo,
                    display: ShownToPatient | None = None) -> Reply:
        """Start a trial recorded to `path`; `display`: what the patient's screen shows
        as it starts (the trial file records it)."""
        return self.request(Start(next(self._ids), str(path), subject, display))

    def stop(self) -> Reply:
        return self.request(Stop(next(self._ids)))

    def clear_fault(self) -> Reply:
        return self.request(ClearFault(next(self._ids)))

    def set_assistance(self, level: float) -> Reply:
        return self.request(SetAssistance(next(self._ids), level))

    def send_force_estimate(self, fx_N: float, fy_N: float, tick: int) -> None:
        """The latest estimate of the patient's force for the trial's tick `tick` (from
        EMG), sent without waiting: the loop takes it between two ticks."""
        try:
            self._conn.send(ForceEstimate(float(fx_N), float(fy_N), int(tick)))
        except (OSError, EOFError) as exc:
            raise DeviceError("the control loop is not running; restart the console") from exc

    def show_to_patient(self, shown: ShownToPatient) -> None:
        """The patient's screen changed (opened, closed, an option): sent without waiting;
        a running trial's file records it at the tick the loop takes it."""
        self._send_data(shown)

    def note(self, note: TrialNote) -> None:
        """Something the console saw, for the running trial's file (messages.TrialNote):
        sent without waiting, recorded at the tick the loop takes it."""
        self._send_data(note)

    def _send_data(self, data) -> None:
        try:
            self._conn.send(data)
        except (OSError, EOFError) as exc:
            raise DeviceError("the control loop is not running; restart the console") from exc

    # ------------------------------------------------------------------ events and data
    def events(self, timeout: float = 0.0) -> list:
        """Everything the loop and the recorder said since the last call."""
        out, self._pending = self._pending, []
        out.extend(self._receive(timeout))
        return out

    def _receive(self, timeout: float) -> list:
        out = self._drain(self._conn, timeout)
        notices = self._drain(self._notices, 0.0)
        if notices:
            # the loop's messages sent before the recorder's: the recorder closes a trial's
            # file only after the loop has told this console of the fault that ended it
            # (device.loop.process), so a fault already in the loop's pipe goes first and
            # the window keeps it as the trial's cause (a "lost" notice read before it left
            # the registry without the fault)
            out += self._drain(self._conn, 0.0)
        out += notices
        for event in out:
            if isinstance(event, StateChanged):
                self.state = State(event.state)
            self._follow_trial(event)
        notice = self._salvage_if_due()
        if notice is not None:
            out.append(notice)
        return out

    def _drain(self, conn, timeout: float) -> list:
        """Every message waiting on `conn` (the first within `timeout`); a closed pipe is
        told once: the loop's as LoopLost, the recorder's by the salvage it calls for."""
        out = []
        try:
            while conn.poll(timeout if not out else 0):
                out.append(conn.recv())
                self._loop_heard = self._loop_heard or conn is self._conn
        except (EOFError, OSError):
            if conn is self._conn and not self._lost_reported:
                self._lost_reported = True
                code = None if self._loop is None else self._loop.exitcode
                out.append(LoopLost(code, "the control loop process ended unexpectedly; "
                                          "the robot is unpowered by its watchdog. Restart "
                                          "the console before the next trial."))
            elif conn is self._notices:
                self._recorder_lost = True  # only the recorder held its end
        return out

    def _follow_trial(self, event) -> None:
        """Keep what a dead recorder's successor needs: the trial's file and ring bounds,
        and the fault that stopped it."""
        if isinstance(event, TrialStarted):
            self._trial = _Trial(event.path, event.first_seq)
        elif self._trial is None:
            return
        elif isinstance(event, TrialEnded) and event.path == self._trial.path:
            self._trial.end_seq = event.end_seq
        elif isinstance(event, FaultRaised):
            self._trial.fault = LostFault(event.message, dict(event.detail))
        elif (isinstance(event, RecorderNotice) and event.path == self._trial.path
              and event.kind in ("closed", "lost")):  # its file's end, told
            self._trial = None

    def _salvage_if_due(self) -> RecorderNotice | None:
        """Once the recorder is dead and the trial over (or the loop dead too), its file
        finished from the ring by this console: the notice the recorder would have sent."""
        trial = self._trial
        if not self._recorder_lost or trial is None or trial.first_seq < 0:
            return None
        end_seq = trial.end_seq
        if end_seq < 0:
            if not self._lost_reported:
                return None  # the loop stops the trial within 50 ms of the recorder's death
            end_seq = self.ring.write_count
        self._trial = None
        notice = salvage(trial.path, self.ring, trial.first_seq, end_seq, trial.fault,
                         self.loop_config.period_s)
        # no recorder reads the ring any more: let the loop write on (the live view)
        self.ring.commit_read(self.ring.write_count)
        return notice

    def wait_for(self, predicate, timeout: float | None = None) -> list:
        """Collect events until one satisfies `predicate` (within `timeout`, default
        PATIENCE_S); returns all of them."""
        timeout = PATIENCE_S if timeout is None else timeout
        seen = []
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for event in self.events(0.05):
                seen.append(event)
                if predicate(event):
                    return seen
        raise DeviceError(f"timed out after {timeout:g} s waiting; saw {seen[-5:]!r}")

    def wait_state(self, state: State, timeout: float | None = None) -> None:
        """Return once the loop is in `state` (at once if it already is)."""
        if self.state == state:
            return
        self.wait_for(lambda event: self.state == state, timeout)

    def wait_for_samples(self, n: int = 1, timeout: float | None = None) -> list:
        """Return once the loop has pushed `n` more records (ticks with a sensor reading)
        than when called (within `timeout`, default PATIENCE_S), collecting the events
        that came meanwhile: after Connect, the loop has a reading for Start once this
        returns."""
        timeout = PATIENCE_S if timeout is None else timeout
        target = self.ring.write_count + n
        seen = []
        deadline = time.monotonic() + timeout
        while self.ring.write_count < target:
            if time.monotonic() > deadline:
                raise DeviceError(f"the loop pushed no sample within {timeout:g} s; saw "
                                  f"{seen[-5:]!r}")
            seen += self.events(0.005)
        return seen

    def live_records(self, max_n: int | None = None) -> np.ndarray:
        """Records pushed since the last call (lossy: skips ahead if the ring wrapped)."""
        return self.live_batch(max_n)[0]

    def live_batch(self, max_n: int | None = None) -> tuple[np.ndarray, int]:
        """`live_records`, with the ring sequence number of the first record (the records
        are consecutive): a ClockStarted read after it says which clock each is on."""
        if self._recorder_lost and self._trial is None:
            self.ring.commit_read(self.ring.write_count)  # nothing left to save
        batch = self.ring.read_new(self._live_cursor, max_n)
        self._live_cursor = batch.cursor
        return batch.records, batch.cursor - len(batch.records)
