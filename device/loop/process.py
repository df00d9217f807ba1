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

Why one module of some 550 lines: it is one object, the loop process's state (the
connection, the trial, the commands waiting for a tick) and the three things that
change it (the ticks, the commands, the faults); each piece reads and writes that state,
and split across modules they would pass it around or reach into each other.
"""

from __future__ import annotations

import dataclasses
import faulthandler
import math
import select
import time
from dataclasses import dataclass
from multiprocessing.connection import Connection

from core.errors import ParameterError
from device.backend import REAL_TIME, SIMULATED, Backend, SensorReading
from device.errors import BackendError, DeviceError, StateError
from device.loop.backends import limits_for_backend, make_backend, sensor_offset_for
from device.loop.engine import TickEngine
from device.loop.messages import (
    BackendConfig,
    Build,
    ClearFault,
    ClockStarted,
    Connect,
    Disconnect,
    FaultRaised,
    ForceEstimate,
    Notice,
    Reply,
    SensorZeroed,
    SetAssistance,
    ShownToPatient,
    Shutdown,
    Start,
    StateChanged,
    Stop,
    TrialEnded,
    TrialMarker,
    TrialStarted,
)
from device.loop.pipeline import (
    PERIOD_S,
    TickPipeline,
    TrialPlan,
    assistance_group,
    has_compiled_form,
    learned_controller,
    learned_model_refusal,
)
from device.loop.realtime import (
    CLOCKS,
    LAST_CPU,
    measure_wakeups,
    prepare_process,
    timing_warning,
)
from device.loop.recorder_watch import RecorderPulse
from device.loop.states import TRANSITIONS, Command, State, refusal
from device.recording.messages import (
    DISK_SHORT,
    STOPPED_BY_SIGNAL,
    WRITE_FAILED,
    BeginTrial,
    EndTrial,
    TrialEvent,
)
from device.recording.ring import RecordRing
from device.safety.faults import Fault
from device.safety.limits import SafetyLimits
from device.safety.supervisor import SafetySupervisor
from device.stopsignals import StopSignal, signal_name

STOPPING_TIMEOUT_S = 2.0
"""Longest wait in Stopping for the recorder to take the trial's last samples."""
WORKSPACE_MARGIN_M = 0.10
"""The end effector may leave the exercise's path by this much before WORKSPACE trips."""
NOISE_RESERVE = 1000
"""Simulated sensor-noise rows (2 s of ticks) kept ahead, drawn between ticks so that no
tick pays for a draw."""

_COMMANDS = {
    Build: Command.BUILD, Connect: Command.CONNECT, Disconnect: Command.DISCONNECT,
    Start: Command.START, Stop: Command.STOP, ClearFault: Command.CLEAR_FAULT,
    SetAssistance: Command.SET_ASSISTANCE, Shutdown: Command.SHUTDOWN,
}


SLACK_S = 200e-6
"""Time before each deadline for commands: enough for one, short enough that the tick's
code and data are still warm in the caches when it runs."""

LATER = object()
"""A command handler's answer when it is carried out at the next tick (its reply then)."""


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


class DeviceLoop:
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
                _cue_patient(self.backend)
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
                kind = _COMMANDS[type(command)]
                self._send(Reply(command.id, False, f"{kind.value} refused: the robot was "
                                                    "disconnected before it could be done."))

    # ------------------------------------------------------------------ trial
    def _start_trial(self, command: Start) -> str:
        self.paused = True
        # the exercise waits at its start while the drives' torque ramps up (H3)
        self.pipeline.begin(self.reading.q1_rad, self.reading.q2_rad,
                            still_s=self.supervisor.limits.restart_ramp_s)
        # every trial starts from its own settings: a live change belonged to the trial it
        # was made in (issue 27: one made between trials ran every later trial at it)
        self.pipeline.set_assistance_level(self.plan.parameters.assistance_level)
        self.supervisor.restart_ramp()
        self.trial_path = command.path
        self.trial_tick = 0
        self.trial_start_sample_s = self.reading.time_s
        if self.pipeline.approach_ticks == 0:
            _cue_patient(self.backend)
        plan = self.plan
        self.seed_used = True
        first_seq = self.ring.write_count
        self.trial_first_seq = first_seq
        self.recorder_pulse.reset()
        self._to_recorder(BeginTrial(
            command.path, first_seq, plan.parameters, command.subject,
            dataclasses.asdict(plan.robot), self.opened.label, plan.period_s,
        ))
        started = {"approach_ticks": self.pipeline.approach_ticks}
        if self.opened.kind == "simulator":
            started["seed"] = self.opened.seed  # the file runs again with it
            started["robot_seed"] = self.opened.robot_seed  # on the same simulated robot
        self._to_recorder(TrialEvent(0.0, 0, "start", "trial started", started))
        if command.display is not None:
            self._tell_shown(command.display, 0)
        # a task the robot leads: each phase's start, told as the tick comes (core.holdtasks)
        self.task_events = list(reversed(self.pipeline.task_events()))
        self._tell_task_events()
        self._send(TrialStarted(command.path, self.pipeline.approach_ticks,
                                self.pipeline.total_ticks, self.t0, first_seq))
        return ""

    def _tell_shown(self, shown: ShownToPatient, tick: int) -> None:
        """What the patient's screen shows from `tick` on, into the trial file."""
        self._to_recorder(TrialEvent(tick * self.plan.period_s, tick, "patient_screen",
                                     shown.message, dict(shown.values)))

    def _tell_task_events(self) -> None:
        """The task's events whose tick has come, to the recorder and the console."""
        while self.task_events and self.task_events[-1][0] <= self.trial_tick:
            tick, kind, message, values = self.task_events.pop()
            event = TrialEvent(tick * self.plan.period_s, tick, kind, message, values)
            self._to_recorder(event)

    def _end_trial(self, status: str, message: str, values: dict | None = None) -> None:
        tick = self.trial_tick
        time_s = tick * self.plan.period_s
        self._to_recorder(TrialEvent(time_s, tick, "stop", message, values or {}))
        summary = {"approach_s": self.pipeline.approach_ticks * self.plan.period_s,
                   "ticks": float(tick),
                   # wall_time is perf_counter() − this; on Linux both perf_counter and
                   # time.monotonic read CLOCK_MONOTONIC, so camera frames stamped with
                   # time.monotonic() line up with the samples (device.camera.capture).
                   "wall_time_origin_monotonic_s": self.t0,
                   # the robot's own clock over the trial: ticks × period on the
                   # simulator however late the ticks, monotonic seconds on hardware
                   "robot_clock_s": self.reading.time_s - self.trial_start_sample_s,
                   "timing": self.backend.timing}
        self.end_seq = self.ring.write_count
        pipeline = self.pipeline
        self._to_recorder(EndTrial(self.end_seq, status, summary, assistance_group(
            self.plan.parameters, pipeline.guidance, pipeline.feedforward_history)))
        self._send(TrialEnded(self.trial_path, status, summary, self.end_seq))

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
        if self.state == State.RUNNING:
            tick = self.trial_tick
            self._to_recorder(TrialEvent(tick * self.plan.period_s, tick, "fault",
                                         message, detail))
            status = "recording_lost" if fault == Fault.RECORDING_LOST else "faulted"
            self._end_trial(status, f"stopped by a fault: {fault.label}")
        self._send(FaultRaised(int(fault), message, detail, loop_t, detected))
        self._enter(State.FAULTED, message)

    def _recording_cause(self, detail: dict) -> str:
        """Why the recording was lost, in the therapist's words, with its cause in the
        fault's detail; '' when it is the ring overflowing (the supervisor's own words)."""
        if self.recorder_gone:
            # the right cause: not the disk, the process that writes to it
            detail["cause"] = "recorder process stopped"
            return RECORDER_GONE
        if self.recorder_stalled:
            detail["cause"] = "recorder stopped responding"
            detail["silent_ticks"] = self.recorder_pulse.silent
            return RECORDER_STALLED
        flag = int(self.recording_failed.value)
        if flag > STOPPED_BY_SIGNAL:
            name = signal_name(flag - STOPPED_BY_SIGNAL)
            detail["cause"] = f"signal {name}"
            return (f"The recorder was told to stop ({name}), so the motors were stopped and "
                    "the trial saved as incomplete. Restart the console before the next trial")
        cause = RECORDING_CAUSES.get(flag)
        if cause is None:
            return ""
        detail["cause"], message = cause
        return message

    def _recorder_stopped(self) -> bool:
        """Whether the recorder's beat has been silent too long (device.loop.
        recorder_watch): counted at every tick of a running trial."""
        if not self.recorder_stalled and self.recorder_pulse.stalled():
            self.recorder_stalled = True
        return self.recorder_stalled

    def _signal_cause(self, detail: dict) -> str:
        """A stop signal stopped the trial: the fault's words and cause name it."""
        detail["cause"] = f"signal {self.stop_signal.name}"
        return (f"The console was told to stop ({self.stop_signal.words}), so the motors "
                "were stopped at once and the trial saved as faulted")

    # ------------------------------------------------------------------ commands
    def _commands_waiting(self) -> bool:
        try:
            return self.console.poll()
        except (EOFError, OSError):
            return True

    def _handle_commands(self) -> None:
        try:
            while self.console.poll():
                self._command(self.console.recv())
        except (EOFError, OSError):
            self.console_lost = True

    def _command(self, command, after_a_tick: bool = False) -> None:
        """Carry out an allowed command and reply; a refused one is answered with why. A
        command that needs a tick first (a Start before the first reading, a ClearFault,
        which must see the cause gone on a fresh tick) waits for the next one."""
        if isinstance(command, ForceEstimate):
            if self.pipeline is not None and self.pipeline.assistance.estimated:
                self.pipeline.set_force_estimate(command.fx_N, command.fy_N, command.tick)
            return
        if isinstance(command, ShownToPatient):
            if self.state == State.RUNNING:
                self._tell_shown(command, self.trial_tick)
            return
        kind = _COMMANDS.get(type(command))
        if kind is None:
            return
        state = self.state
        reason = refusal(state, kind)
        if not reason:
            try:
                outcome = _HANDLERS[kind](self, command, after_a_tick)
            except (DeviceError, ValueError) as exc:
                outcome = f"{kind.value} failed: {exc}"
            if outcome is LATER:
                self.later.append(command)
                return
            reason, why = outcome if isinstance(outcome, tuple) else (outcome, "")
            if not reason and self.state == state:
                self._enter(TRANSITIONS[(state, kind)], why)
        self._send(Reply(command.id, not reason, reason))

    def _do_build(self, command: Build, after_a_tick: bool):
        refused = learned_model_refusal(command.parameters, command.model)
        if refused:
            return f"build refused: {refused}"
        self.paused = True
        # the whole reference now, at zero torque, so that Start only plans the approach
        plan = TrialPlan.build(command.parameters, period_s=self.config.period_s,
                               tabulated=True)
        reconnect = self.state == State.CONNECTED and self.backend_config is not None and (
            command.backend != self.backend_config or command.backend.kind == "simulator")
        if reconnect and command.backend.kind != self.backend_config.kind:
            return "disconnect before changing the robot backend"
        limits = (command.limits or SafetyLimits()).around_path(
            plan.parameters.path().points(), WORKSPACE_MARGIN_M)
        self.plan, self.backend_config, self.limits = plan, command.backend, limits
        self.model = command.model
        self.pipeline = self._new_pipeline()
        if reconnect:
            # the virtual patient follows the new exercise: rebuild the simulator
            self._disconnect_backend()
            refused = self._open_backend()
            if refused:
                self._enter(State.BUILT, "the robot could not be reconnected")
                return refused
            return "", f"connected to the {self.opened.label}"
        if self.engine is not None and self.state.ticking:
            self.engine = TickEngine(self.backend, self.pipeline, self.supervisor)
        return "", "trial built"

    def _do_connect(self, command: Connect, after_a_tick: bool):
        refused = self._open_backend()
        return refused, f"connected to the {self.opened.label}"

    def _do_disconnect(self, command: Disconnect, after_a_tick: bool):
        self._disconnect_backend()
        return "", "disconnected"

    def _do_start(self, command: Start, after_a_tick: bool):
        if self.seed_used and self.backend_config.kind == "simulator" and (
                self.backend_config.seed is None):
            # a new virtual patient and sensor noise for this trial, at rest at the path's
            # start (a course of simulated trials varies as a person's would)
            self._disconnect_backend()
            refused = self._open_backend(check_timing=False)
            if refused:
                self._enter(State.BUILT, "the simulator could not be reopened")
                return f"start refused: {refused}"
        if self.reading is None:
            return LATER  # the first tick after Connect has not read the sensors yet
        return self._start_trial(command), "trial started"

    def _do_stop(self, command: Stop, after_a_tick: bool):
        self._end_trial("stopped_early", "stopped by the therapist")
        return "", "trial stopped; saving"

    def _do_clear_fault(self, command: ClearFault, after_a_tick: bool):
        if not after_a_tick:
            return LATER  # the e-stop released a moment ago is seen by the next tick
        try:
            self.supervisor.clear()
        except StateError as exc:
            return str(exc)
        self.fault_reported = Fault.NONE
        return "", "fault cleared"

    def _do_set_assistance(self, command: SetAssistance, after_a_tick: bool):
        """A live change of the running trial's level (only Running accepts it: between
        trials the level is the built trial's). The record's `assistance_level` carries
        it from the next tick; the event says when and to what the therapist changed it.
        A transparent trial has no level (core.control.transparent): refused."""
        if self.plan.parameters.assist == "transparent":
            return ("set assistance level refused: the transparent mode adds no help, so "
                    "it has no level to change; stop the trial and build one in another "
                    "mode to help the patient")
        self.pipeline.set_assistance_level(command.level)
        tick = self.trial_tick
        self._to_recorder(TrialEvent(tick * self.plan.period_s, tick, "assistance",
                                     f"assistance level set to {command.level:.0%}",
                                     {"level": self.pipeline.assistance.level}))
        return ""

    def _do_shutdown(self, command: Shutdown, after_a_tick: bool):
        if self.state == State.RUNNING and command.signal and not after_a_tick:
            # the console was given a stop signal: the next tick stops the trial as at a
            # fault naming it (zero torque in that tick), then the loop shuts down
            self.stop_signal.set(command.signal)
            return LATER
        if self.state == State.RUNNING:
            self._end_trial("stopped_early", "console closed")
        self.shutdown = True
        return "", "shutting down"

    def _new_pipeline(self) -> TickPipeline:
        controller = None
        if self.model is not None:
            # an FNN or a DeLaN runs compiled (core.learning.kernel), another model
            # interpreted through its step
            controller = learned_controller(self.model, self.plan)
        pipeline = TickPipeline(self.plan, sensor_offset_rad=self.sensor_offset_rad,
                                controller=controller,
                                compiled=self.config.compiled and (
                                    controller is None or has_compiled_form(self.model)))
        return pipeline

    def _open_backend(self, check_timing: bool = True) -> str:
        """Make and open the configured backend with its supervisor and tick engine (a
        simulator with a seed drawn now when its config draws one per trial): '' or why
        not."""
        self.paused = True
        config = self.backend_config
        if config.kind == "simulator" and config.seed is None:
            from device.sim.simulator import draw_seed  # as make_backend: the simulator's

            config = dataclasses.replace(config, seed=draw_seed())
        backend = make_backend(config, self.plan.parameters, self.plan, self.clock.sleep,
                               self.config.compiled)
        if backend.timing == REAL_TIME and check_timing and self.config.timing_check_s > 0.0:
            self._check_timing()
        backend.open()
        tare = getattr(getattr(backend, "inner", backend), "tare", None)
        if tare is not None:
            # before the Connect's reply: the window shows "zero taken" (a zero under load
            # raised TareUnderLoad in open(): the Connect failed with its one line)
            self._send(SensorZeroed(tare.duration_s, tare.spread_N, tare.limit_N))
        try:
            self.limits = limits_for_backend(self.limits, backend)
        except ParameterError as exc:
            backend.safe_state()
            backend.close()
            return f"connect refused: {exc}"
        self.sensor_offset_rad = sensor_offset_for(config)
        self.pipeline = self._new_pipeline()
        self.backend = backend
        self.supervisor = SafetySupervisor(self.plan.robot, self.limits)
        if self.config.compiled:
            from device.compiled.warmup import load_kernels

            load_kernels(("loop",))  # a first call inside a tick would stall it
        self.engine = TickEngine(backend, self.pipeline, self.supervisor)
        self.fault_reported = Fault.NONE
        self.reading = None
        self.opened, self.seed_used = config, False
        return ""

    def _check_timing(self) -> None:
        """Before a real robot is powered: would this machine's wake-ups trip the
        late-tick watchdog? If so, say so in plain words (the Connect goes on)."""
        limits = self.limits
        late = measure_wakeups(self.config.timing_check_s)
        warning = timing_warning(late, limits.late_tick_s, limits.late_run_ticks,
                                 self.config.period_s)
        if warning:
            self._send(Notice("warning", warning))

    def _disconnect_backend(self) -> None:
        backend, self.backend = self.backend, None
        if backend is not None:
            backend.safe_state()
            try:
                backend.close()
            except BackendError as exc:
                self._send(Notice("warning", f"while disconnecting: {exc}"))

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


RECORDER_CHECK_TICKS = 25
"""How often (ticks: 50 ms) a running trial checks that the recorder is still there."""
RECORDER_GONE = ("The recorder stopped, so nothing more of this trial could be saved; the "
                 "motors were stopped. The trial's file keeps what reached it, and the "
                 "trial is marked incomplete. Restart the console before the next trial")
RECORDER_STALLED = ("The recorder stopped responding, so the motors were stopped; the trial's "
                    "file keeps what reached it and the trial is marked incomplete. Restart "
                    "the console before the next trial")

RECORDING_CAUSES = {
    WRITE_FAILED: ("write error", "The trial file could not be written (a disk error), so "
                   "the motors were stopped. The file keeps what was saved before the error "
                   "and the trial is marked incomplete. Check the disk before the next trial"),
    DISK_SHORT: ("disk full", "The disk holding the trial files is full, so the motors were "
                 "stopped. Every sample so far is saved in the trial's file, which is marked "
                 "incomplete. Free space on that disk before the next trial"),
}
"""What the recorder's flag says (device.recording.messages), as the fault's cause and
message."""

_HANDLERS = {
    Command.BUILD: DeviceLoop._do_build, Command.CONNECT: DeviceLoop._do_connect,
    Command.DISCONNECT: DeviceLoop._do_disconnect, Command.START: DeviceLoop._do_start,
    Command.STOP: DeviceLoop._do_stop, Command.CLEAR_FAULT: DeviceLoop._do_clear_fault,
    Command.SET_ASSISTANCE: DeviceLoop._do_set_assistance,
    Command.SHUTDOWN: DeviceLoop._do_shutdown,
}
"""What each command does; where it leads is device.loop.states.TRANSITIONS."""


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


def _cue_patient(backend: Backend) -> None:
    """A virtual patient starts the exercise together with the reference."""
    cue = getattr(backend, "cue_patient", None)
    if cue is not None:
        cue()


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
