"""The window's link to the loop: a worker thread owns the DeviceClient, turns its events
into Qt signals and drains the ring for the live view. The GUI thread never waits on it.

* Commands go onto a queue the worker takes one at a time (a Build may take a second);
  each one's answer comes back as `replied(command, ok, message)`.
* E-stop and the heartbeat are shared counters: `estop()` and `heartbeat()` act at once
  from the GUI thread, whatever the worker is doing.
* Records drained by the worker wait in `take_records()` for the window's repaint timer.
"""

from __future__ import annotations

import logging
import queue
import threading
from dataclasses import dataclass

import numpy as np
from PySide6.QtCore import QObject, Signal

from core.trial import TrialParameters
from device.errors import DeviceError
from device.loop.client import DeviceClient, LoopLost
from device.loop.messages import (
    BackendConfig,
    ClockStarted,
    FaultRaised,
    HandleArea,
    Notice,
    SensorZeroed,
    ShownToPatient,
    StateChanged,
    TrialEnded,
    TrialMarker,
    TrialNote,
    TrialStarted,
)
from device.loop.process import LoopConfig
from device.recording.messages import RecorderNotice
from device.recording.record import RECORD_DTYPE
from device.recording.trialfile import SubjectInfo
from device.safety.limits import SafetyLimits

log = logging.getLogger(__name__)

DRAIN_S = 0.01
MAX_PENDING = 64
"""Batches kept for the repaint timer; older ones are dropped if it falls behind (the
live view is lossy by design, the trial file is not)."""


@dataclass(frozen=True, slots=True)
class _Call:
    name: str
    args: tuple


class DeviceBridge(QObject):
    """Signals from the loop, commands to it."""

    state_changed = Signal(int, str)
    fault_raised = Signal(int, str, dict)
    trial_started = Signal(str, int, int)  # path, approach ticks, total ticks
    trial_ended = Signal(str, str, dict)  # path, status, summary
    file_notice = Signal(str, str, str, str)  # kind, path, status, message
    notice = Signal(str, str)  # level, message
    replied = Signal(str, bool, str)  # command, ok, message
    loop_lost = Signal(str)
    sensor_zeroed = Signal(str)  # the force sensor's zero taken at Connect, in words
    handle_area = Signal(str)  # between trials: the handle outside the area, '' inside

    def __init__(self, *, loop_config: LoopConfig | None = None,
                 client: DeviceClient | None = None, lsl_outlet=None) -> None:
        super().__init__()
        self.client = client or DeviceClient(loop_config=loop_config, auto_heartbeat=False)
        # the robot's state and events on the Lab Streaming Layer (device.lsl.outlet's
        # RobotStateOutlet), published from this worker thread, never from the loop
        self.lsl_outlet = lsl_outlet
        self._calls: queue.Queue[_Call | None] = queue.Queue()
        self._outstanding = 0  # commands put and not yet answered (under _lock)
        self._records: list[np.ndarray] = []
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._started = threading.Event()
        self._start_error = ""
        self._force_feed = None
        self._closing_signal = ""

    # ------------------------------------------------------------------ life
    def start(self, timeout: float = 30.0) -> None:
        """Start the worker and the loop processes; returns once they run."""
        self._thread = threading.Thread(target=self._work, name="rehab-device", daemon=True)
        self._thread.start()
        if not self._started.wait(timeout):
            raise DeviceError("the control loop did not start within "
                              f"{timeout:g} s; see the log file")
        if self._start_error:
            raise DeviceError(self._start_error)

    def close(self, signal: str = "") -> None:
        """End the loop processes (a running trial stopped and saved; as at a fault naming
        the stop `signal` the console was given, device.stopsignals); what they said
        meanwhile (the trial's end, its file closed) is still emitted, for the window to
        record the trial."""
        if self._thread is None:
            return
        self._closing_signal = signal
        self._calls.put(None)
        self._thread.join(15.0)
        self._thread = None

    # ------------------------------------------------------------------ safety lines
    def estop(self, held: bool = True) -> None:
        self.client.estop(held)

    def heartbeat(self) -> None:
        self.client.heartbeat()

    # ------------------------------------------------------------------ commands
    def build(self, parameters: TrialParameters, backend: BackendConfig,
              limits: SafetyLimits | None = None, model=None) -> None:
        """`model`: the learned model the parameters name (device.loop.messages.Build)."""
        self._put(_Call("build", (parameters, backend, limits, None, model)))

    def connect(self) -> None:
        self._put(_Call("connect", ()))

    def disconnect(self) -> None:
        self._put(_Call("disconnect", ()))

    def start_trial(self, path: str, subject: SubjectInfo,
                    display: ShownToPatient | None = None) -> None:
        self._put(_Call("start_trial", (path, subject, display)))

    def show_to_patient(self, shown: ShownToPatient) -> None:
        """What the patient's screen now shows, to the loop in the order of the commands
        (answered by nothing: a running trial's file records it)."""
        self._put(_Call("show_to_patient", (shown,)))

    def note(self, note: TrialNote) -> None:
        """Something the console saw, for the running trial's file (device.loop.messages.
        TrialNote), in the order of the commands; answered by nothing."""
        self._put(_Call("note", (note,)))

    def stop(self) -> None:
        self._put(_Call("stop", ()))

    def clear_fault(self) -> None:
        self._put(_Call("clear_fault", ()))

    def set_assistance(self, level: float) -> None:
        self._put(_Call("set_assistance", (level,)))

    def _put(self, call: _Call) -> None:
        with self._lock:
            self._outstanding += 1
        self._calls.put(call)

    def idle(self) -> bool:
        """Every command sent has been answered (its `replied` is on its way to the GUI
        thread, posted before this turns True)."""
        with self._lock:
            return self._outstanding == 0

    def set_force_feed(self, feed) -> None:
        """While a trial on a force estimate runs: `feed(records)` (app.emg.live_feed.
        LiveForceFeed) is called on this bridge's worker thread with each batch drained,
        and what it returns, (F_x, F_y, tick), goes to the loop; None stops it."""
        self._force_feed = feed

    def take_records(self) -> np.ndarray:
        """Everything drained since the last call, as one array (maybe empty)."""
        with self._lock:
            batches, self._records = self._records, []
        if not batches:
            return np.empty(0, dtype=RECORD_DTYPE)
        return batches[0] if len(batches) == 1 else np.concatenate(batches)

    # ------------------------------------------------------------------ worker
    def _work(self) -> None:
        try:
            self.client.start()
        except (DeviceError, OSError) as exc:
            self._start_error = f"the control loop could not start: {exc}"
            self._started.set()
            return
        self._started.set()
        try:
            while True:
                try:
                    call = self._calls.get(timeout=DRAIN_S)
                except queue.Empty:
                    call = ...
                if call is None:
                    break
                if call is not ...:
                    self._call(call)
                self._drain()
        finally:
            for event in self.client.close(signal=self._closing_signal):
                self._emit(event)
                if self.lsl_outlet is not None:
                    self._publish_event(event)
            if self.lsl_outlet is not None:  # the markers still waiting for their record
                self._publish(self.lsl_outlet.close)

    def _call(self, call: _Call) -> None:
        try:
            reply = getattr(self.client, call.name)(*call.args)
        except DeviceError as exc:
            self.replied.emit(call.name, False, str(exc))
        else:
            if reply is not None:  # None: data sent without an answer (show_to_patient)
                self.replied.emit(call.name, reply.ok, reply.message)
        # after the reply is posted: whoever sees `idle` then finds it queued
        with self._lock:
            self._outstanding -= 1

    def _drain(self) -> None:
        try:
            records, first_seq = self.client.live_batch()
        except DeviceError as exc:
            log.warning("live view: %s", exc)
            records, first_seq = None, 0
        if records is not None and len(records):
            feed = self._force_feed
            if feed is not None:
                self._feed_estimate(feed, records)
            with self._lock:
                self._records.append(records)
                del self._records[:-MAX_PENDING]
        # the messages after the records: a ClockStarted for any record just read is among
        # them (device.lsl.timeline), so the outlet stamps every record on its own clock
        for event in self.client.events():
            self._emit(event)
            if self.lsl_outlet is not None:
                self._publish_event(event)
        if self.lsl_outlet is not None and records is not None and len(records):
            self._publish(self.lsl_outlet.push_records, records, first_seq)

    def _feed_estimate(self, feed, records) -> None:
        try:
            estimate = feed(records)
            if estimate is not None:
                self.client.send_force_estimate(*estimate)
        except Exception as exc:  # no estimate: the loop judges no push, the trial goes on
            log.warning("force estimate stopped: %s", exc)
            feed.lost = f"the estimate stopped ({exc}); the assistance gives no way"
            self._force_feed = None

    def _publish(self, push, *args) -> None:
        try:
            push(*args)
        except Exception as exc:  # the outlet must never take the live view down with it
            log.warning("LSL outlet stopped: %s", exc)
            self.lsl_outlet = None

    def _publish_event(self, event) -> None:
        """What the outlet needs of the loop's messages: each connection's clock, the trial
        file's events at their ticks, and what the recorder or the console adds to it."""
        if isinstance(event, ClockStarted):
            self._publish(self.lsl_outlet.clock_started, event.first_seq,
                          event.origin_monotonic_s)
        elif isinstance(event, TrialMarker):
            self._publish(self.lsl_outlet.mark, event)
        elif isinstance(event, RecorderNotice) and event.kind == "error":
            # the recorder's own 'recording' event in the file (a full disk, a write error)
            self._publish(self.lsl_outlet.push_event, "recording", event.message)
        elif isinstance(event, LoopLost):
            self._publish(self.lsl_outlet.push_event, "fault", event.message)

    def _emit(self, event) -> None:
        if isinstance(event, StateChanged):
            self.state_changed.emit(event.state, event.reason)
        elif isinstance(event, FaultRaised):
            self.fault_raised.emit(event.code, event.message, event.detail)
        elif isinstance(event, TrialStarted):
            self.trial_started.emit(event.path, event.approach_ticks, event.total_ticks)
        elif isinstance(event, TrialEnded):
            self.trial_ended.emit(event.path, event.status, event.summary)
        elif isinstance(event, RecorderNotice):
            self.file_notice.emit(event.kind, event.path, event.status, event.message)
        elif isinstance(event, Notice):
            self.notice.emit(event.level, event.message)
        elif isinstance(event, LoopLost):
            self.loop_lost.emit(event.message)
        elif isinstance(event, SensorZeroed):
            self.sensor_zeroed.emit(event.message)
        elif isinstance(event, HandleArea):
            self.handle_area.emit(event.line)
