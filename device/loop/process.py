"""The 2 ms control loop, in its own process.

Every period while a backend is connected the loop waits for its deadline, runs one
tick of the tick engine (device.loop.engine: sensors → while a trial runs, rate
estimate, reference, controller, assistance → safety supervisor → motors), pushes the
tick's record into the ring and lets the state it is in do its part (a running trial
advances, a stopping one waits for its file). Commands arrive on a pipe and are taken
in the slack before each deadline; e-stop and the console's heartbeat are shared
counters read every tick. The loop never logs, never touches a file and never waits on
anything but its own deadline.

Why a process and not a thread: a thread beside a live pyqtgraph window missed 4–9 % of
2 ms deadlines on a 2-core machine because of the GIL; a process keeps ~1 %
(docs/architecture.md). It is also a safety boundary: if the console dies, the pipe
closes and the loop stops the trial at once and puts the robot in its safe state by
itself.

Time: the loop keeps absolute 2 ms deadlines on the wall clock and records how late
each tick started. What a late tick means depends on whose clock the robot lives on
(device.backend): a real robot gets the wall clock, and the supervisor faults a tick
more than 10 ms late; a simulated one is stepped by exactly one period per tick, so a
stall of the host delays the simulation, is recorded and shown, and stops nothing.
Before a real robot is opened, Connect checks for a second whether this machine wakes
the loop on time and tells the therapist when it does not. `LoopConfig(clock="own")`
gives the loop a clock of its own (device.loop.realtime.OwnClock) on which only an
injected delay makes a tick late, so the watchdog can be proved on any machine.

States: device.loop.states (which command leads where); each state's behaviour is
here: what entering and leaving it does (`_entered`, `_leaving`) and what it does every
tick (`_during`). Faults: device.safety (latched until cleared). Which backend it drives:
device.loop.backends.

One object, the loop process's state (the connection, the trial, the commands waiting for
a tick), in four modules by what changes it: the ticks and the states here, the commands
and the backend they open in device.loop.commands (LoopCommands), the causes of a stopped
recording in device.loop.causes (StopCauses), a trial's start and end as the recorder and
the console hear them in device.loop.trial_run (TrialRun); DeviceLoop is all four.
"""

from __future__ import annotations

import faulthandler
import math
import select
import time
from dataclasses import dataclass
from multiprocessing.connection import Connection

from device.backend import SIMULATED, Backend, SensorReading
from device.loop.causes import RECORDER_CHECK_TICKS, StopCauses
from device.loop.commands import AREA_CHECK_TICKS, COMMAND_KINDS, LoopCommands
from device.loop.engine import TickEngine
from device.loop.messages import (
    BackendConfig,
    ClockStarted,
    FaultRaised,
    Notice,
    Reply,
    StateChanged,
    TrialMarker,
)
from device.loop.pipeline import (
    PERIOD_S,
    TickPipeline,
    TrialPlan,
)
from device.loop.realtime import (
    CLOCKS,
    LAST_CPU,
    prepare_process,
)
from device.loop.recorder_watch import RecorderPulse
from device.loop.states import State
from device.loop.trial_run import TrialRun, cue_patient
from device.recording.messages import (
    TrialEvent,
)
from device.recording.ring import RecordRing
from device.safety.faults import Fault
from device.safety.limits import SafetyLimits
from device.safety.supervisor import SafetySupervisor
from device.stopsignals import StopSignal

STOPPING_TIMEOUT_S = 2.0
"""Longest wait in Stopping for the recorder to take the trial's last samples."""
NOISE_RESERVE = 1000
"""Simulated sensor-noise rows (2 s of ticks) kept ahead, drawn between ticks so that no
tick pays for a draw."""

SLACK_S = 200e-6
"""Time before each deadline for commands: enough for one, short enough that the tick's
code and data are still warm in the caches when it runs."""



@dataclass(frozen=True, slots=True)
class LoopConfig:
    period_s: float = PERIOD_S
    cpu: int | None = LAST_CPU  # None: any CPU
    realtime: bool = True
    compiled: bool = True
    """Run the tick's kernels compiled (device.loop.engine); False runs them interpreted."""
    timing_check_s: float = 1.0
    """How long Connect measures this machine's wake-up lateness before it opens a
    REAL_TIME backend (device.loop.realtime.timing_warning); 0 skips the check."""
    clock: str = "wall"
    """The loop's clock (device.loop.realtime.CLOCKS): "wall", or "own" to prove the
    watchdog by injection whatever the machine's stalls (see the module notes)."""


class DeviceLoop(LoopCommands, StopCauses, TrialRun):
    """The loop's state and its ticks. One instance per loop process."""

    def __init__(self, console: Connection, recorder: Connection | None, ring: RecordRing,
                 estop_flag, heartbeat, recording_failed, config: LoopConfig,
                 recorder_beat=None, stop_signal: StopSignal | None = None) -> None:
        self.console = console
        self.recorder = recorder
        # The recorder's death shows at once as an error on our end of its pipe (its end
        # is closed by the system): no heartbeat to miss on a slow disk, no wait for the
        # ring to fill (it took about 16 s).
        self._recorder_watch = select.poll()
        if recorder is not None:
            self._recorder_watch.register(recorder.fileno(), select.POLLERR)
        self.recorder_gone = False
        # a stopped recorder keeps its pipe open: its beat tells (device.loop.recorder_watch)
        self.recorder_pulse = RecorderPulse(recorder_beat)
        self.recorder_stalled = False
        self.stop_signal = stop_signal or StopSignal()
        self.ring = ring
        self.estop_flag = estop_flag
        self.heartbeat = heartbeat
        self.recording_failed = recording_failed
        self.config = config
        self.clock = CLOCKS[config.clock]()
        self.state = State.IDLE
        self.console_lost = False
        self.plan: TrialPlan | None = None
        self.backend_config: BackendConfig | None = None
        self.limits: SafetyLimits | None = None
        self.backend: Backend | None = None
        self.opened: BackendConfig | None = None
        """The backend open now as it was made: `backend_config` with the seed drawn for
        it when the trial's config draws one per trial (BackendConfig.seed None)."""
        self.seed_used = False
        """A trial ran on the simulator open now: the next Start draws a new seed."""
        self.supervisor: SafetySupervisor | None = None
        self.pipeline: TickPipeline | None = None
        self.model = None
        """The learned model the built trial's CT-PID runs on (Build.model), or None."""
        self.engine: TickEngine | None = None
        self.sensor_offset_rad = 0.0
        self.reading: SensorReading | None = None
        self.trial_path = ""
        self.trial_tick = 0
        self.task_events: list = []
        self.end_seq = 0
        self.fault_reported = Fault.NONE
        self.shutdown = False
        self.stopping_since = 0.0
        self.paused = False
        self.t0 = 0.0
        self.trial_first_seq = 0
        self.trial_start_sample_s = 0.0
        self.later: list = []  # commands carried out at the next tick
        self.area_told: str | None = None  # the HandleArea line the console has (None: none)

    # ------------------------------------------------------------------ main
    def run(self) -> None:
        while not self.shutdown:
            if self.state.ticking:
                self._ticks()
            else:
                self._idle_wait()
        self._disconnect_backend()

    def _idle_wait(self) -> None:
        """Not connected: nothing to tick, wait for a command."""
        try:
            ready = self.console.poll(0.05)
        except (EOFError, OSError):
            ready = True
        if ready:
            self._handle_commands()
        if self.console_lost or self.stop_signal.name:
            self.shutdown = True

    def _ticks(self) -> None:
        """Every period while connected: wait → commands in the slack → wait → tick."""
        clock, period = self.clock, self.config.period_s
        self.t0 = clock.now()
        # before the first record of this connection: whoever reads the ring and then the
        # messages knows the clock of every record it read (a new one at every Connect)
        self._send(ClockStarted(self.t0, self.ring.write_count))
        deadline, overrun = self.t0 + period, 0.0
        self._beat = (self.heartbeat.value, self.t0)
        k = 0
        while self.state.ticking and not self.shutdown:
            clock.wait_until(deadline - SLACK_S)
            if self._commands_waiting():
                self._handle_commands()
                if not self.state.ticking:
                    break
                deadline, overrun = self._after_a_pause(deadline, overrun)
            running = self.state == State.RUNNING
            self.engine.rehearse(self.trial_tick if running else None,
                                 self._robot_time(k, deadline - self.t0)[0])
            now = clock.wait_until(deadline)
            self._tick(k, now, max(now - deadline, overrun))
            if (self.console_lost or self.stop_signal.name) and self.state != State.RUNNING:
                self.shutdown = True  # a stop signal: once the trial is stopped and saved
            top_up = getattr(self.backend, "top_up_noise", None)
            if top_up is not None:
                top_up(NOISE_RESERVE)  # here, well before the next deadline
            k += 1
            deadline, overrun = self._after_a_pause(*_next_deadline(deadline, clock.now(),
                                                                    period))

    def _after_a_pause(self, deadline: float, overrun: float) -> tuple[float, float]:
        """Build, Connect and Start compute tables (milliseconds of numpy) at zero torque;
        after them the schedule restarts from now instead of counting the pause as late
        ticks."""
        if not self.paused:
            return deadline, overrun
        self.paused = False
        return self.clock.now() + SLACK_S, 0.0

    def _tick(self, k: int, now: float, lateness: float) -> None:
        """One tick: the engine's step on the robot's clock, its record into the ring, then
        the state's part, and the commands that waited for this tick."""
        wall_t = now - self.t0
        robot_t, on_time = self._robot_time(k, wall_t)
        robot_lateness = 0.0 if on_time else lateness
        value = self.heartbeat.value
        if value != self._beat[0]:
            self._beat = (value, now)
        beat_age = math.inf if self.console_lost else now - self._beat[1]
        running = self.state == State.RUNNING
        overwrite = self.ring.would_overwrite_unrecorded
        if running and k % RECORDER_CHECK_TICKS == 0 and not self.recorder_gone:
            self.recorder_gone = bool(self._recorder_watch.poll(0))
        lost = (bool(self.recording_failed.value) or (running and overwrite())
                or (running and self.recorder_gone) or (running and self._recorder_stopped()))
        stop = bool(self.estop_flag.value) or bool(self.stop_signal.name)
        done = self.engine.step(self.trial_tick if running else None, robot_t, robot_lateness,
                                beat_age, stop, lost, self.clock.now)
        if isinstance(done.reading, SensorReading):
            self.reading = done.reading
        record = self.engine.record(done, self.trial_tick if running else k, wall_t, lateness,
                                    int(self.state), running)
        if not overwrite():
            self.ring.push(record)
        if done.fault and done.fault != self.fault_reported:
            self._on_fault(done.fault, wall_t)
        else:
            self._during(now)
        if self.state == State.CONNECTED and k % AREA_CHECK_TICKS == 0:
            self._tell_area()
        if self.later:
            later, self.later = self.later, []
            for command in later:
                self._command(command, after_a_tick=True)

    def _robot_time(self, k: int, wall_t: float) -> tuple[float, bool]:
        """The robot's clock at tick k (device.backend), and whether every tick is on time
        on it: a real robot moves on the wall clock, so its supervisor must see how late
        the tick is; a simulated one is stepped by one period per tick, and on its clock
        no tick is late. The wall-clock lateness is recorded either way."""
        if self.backend.timing == SIMULATED:
            return k * self.config.period_s, True
        return wall_t, False

    # ------------------------------------------------------------------ states
    def _during(self, now: float) -> None:
        """What the state does every tick after the engine's step."""
        if self.state == State.RUNNING:
            self.trial_tick += 1
            if self.task_events:
                self._tell_task_events()
            if self.trial_tick == self.pipeline.approach_ticks:
                cue_patient(self.backend)
            if self.trial_tick >= self.pipeline.total_ticks:
                self._end_trial("complete", "trial complete")
                self._enter(State.STOPPING, "trial complete; saving")
        elif self.state == State.STOPPING:
            if self.ring.recorder_cursor >= self.end_seq:
                self._enter(State.CONNECTED, "the trial file has all its samples")
            elif now - self.stopping_since > STOPPING_TIMEOUT_S:
                self._send(Notice("warning", "the recorder did not confirm the last "
                                             "samples; check the trial file"))
                self._enter(State.CONNECTED, "stopped without the recorder's answer")

    def _enter(self, state: State, reason: str) -> None:
        """Leave the current state for `state` (both do their part) and tell the console."""
        if state == self.state:
            return
        self._leaving(self.state, state)
        self.state = state
        self._entered(state)
        self._send(StateChanged(int(state), reason))

    def _entered(self, state: State) -> None:
        if state == State.CONNECTED:
            self.area_told = None  # the console hears again where the handle is
        if state == State.STOPPING:
            self.stopping_since = self.clock.now()
        elif state == State.CONNECTED and self.pipeline is not None:
            # after a fault or a trial: the controller's integral ran against zero torque
            self.pipeline.reset_controller()

    def _leaving(self, state: State, to: State) -> None:
        if state.ticking and not to.ticking and self.later:
            # no tick will come to carry out what waited for one: answer it now
            later, self.later = self.later, []
            for command in later:
                kind = COMMAND_KINDS[type(command)]
                self._send(Reply(command.id, False, f"{kind.value} refused: the robot was "
                                                    "disconnected before it could be done."))

    # ------------------------------------------------------------------ faults
    def _on_fault(self, fault: Fault, loop_t: float) -> None:
        self.fault_reported = fault
        sup = self.supervisor
        detail = dict(sup.fault_detail)
        detected = time.monotonic()
        detail["monotonic_s"] = detected
        message = sup.fault_message
        if fault == Fault.RECORDING_LOST:
            message = self._recording_cause(detail) or message
        elif fault == Fault.ESTOP and self.stop_signal.name and not self.estop_flag.value:
            message = self._signal_cause(detail)
        running = self.state == State.RUNNING
        if running:
            tick = self.trial_tick
            self._to_recorder(TrialEvent(tick * self.plan.period_s, tick, "fault",
                                         message, detail))
        # the console hears of the fault before the recorder hears of the trial's end: the
        # recorder's word on the trial's file ("closed", "lost"), sent once it has the end,
        # then always finds the fault in the console's pipe (DeviceClient._receive reads it
        # first), and the registry keeps the fault as the trial's cause. Told after the
        # end, a "lost" notice overtook it and the trial's cause missed the fault.
        self._send(FaultRaised(int(fault), message, detail, loop_t, detected))
        if running:
            status = "recording_lost" if fault == Fault.RECORDING_LOST else "faulted"
            self._end_trial(status, f"stopped by a fault: {fault.label}")
        self._enter(State.FAULTED, message)

    # ------------------------------------------------------------------ messages
    def _send(self, message) -> None:
        if self.console_lost:
            return
        try:
            self.console.send(message)
        except (OSError, EOFError, BrokenPipeError):
            self.console_lost = True

    def _to_recorder(self, message) -> None:
        if isinstance(message, TrialEvent):
            self._mark(message)
        if self.recorder is None:
            return
        try:
            self.recorder.send(message)
        except (OSError, EOFError, BrokenPipeError):
            self.recorder = None
            self.recording_failed.value = 1

    def _mark(self, event: TrialEvent) -> None:
        """The console hears every event the trial file gets, at the tick it belongs to
        (the LSL outlet's markers); the start's carries the trial's settings."""
        values = dict(event.values)
        if event.kind == "start":
            values.update(parameters=self.plan.parameters.to_dict(),
                          backend=self.opened.label, file=self.trial_path)
        self._send(TrialMarker(event.kind, event.message, values, event.tick,
                               self.trial_first_seq + event.tick, self.clock.now()))


def _next_deadline(deadline: float, now: float, period: float) -> tuple[float, float]:
    """The next deadline on the period's grid after `deadline`, and how late `now` is
    for it. Missed deadlines are skipped, not run back to back: a burst of ticks
    microseconds apart would read the same sensor sample over and over. The next tick
    reports how late the first missed one was, so the lateness watchdog still sees it."""
    deadline += period
    behind = now - deadline
    if behind <= 0.0:
        return deadline, 0.0
    return deadline + period * math.ceil(behind / period), behind


def loop_main(console: Connection, recorder: Connection, ring_name: str, estop_flag,
              heartbeat, recording_failed, config: LoopConfig, recorder_beat=None) -> None:
    """Entry point of the loop process."""
    # first: a stop signal to the console's process group stops the trial (device.
    # stopsignals), not the process where it stands
    stop_signal = StopSignal().install()
    faulthandler.enable()  # a crash in compiled code still leaves a traceback on stderr
    problems = prepare_process(config.cpu) if config.realtime else []
    ring = RecordRing.attach(ring_name)
    loop = DeviceLoop(console, recorder, ring, estop_flag, heartbeat, recording_failed, config,
                      recorder_beat, stop_signal)
    for problem in problems:
        loop._send(Notice("warning", f"real-time setup: {problem}"))
    try:
        loop.run()
    finally:
        loop._disconnect_backend()
        ring.close()
        recorder.close()
        console.close()
