"""The 2 ms control loop, in its own process.

Every tick while connected: read the sensors → (running: pipeline → controller →
assistance) → safety supervisor → write the torques → push one record into the ring.
Commands arrive on a pipe polled once per tick; e-stop and the console's heartbeat are
shared counters read every tick. The loop never logs, never touches a file and never
waits on anything but its own deadline.

Why a process and not a thread: a thread beside a live pyqtgraph window missed 4–9 % of
2 ms deadlines on a 2-core machine because of the GIL; a process keeps ~1 %
(docs/architecture.md). It is also a safety boundary: if the console dies, the pipe closes and
the loop stops the trial at once and puts the robot in its safe state by itself.

Time: the loop keeps absolute 2 ms deadlines on the wall clock and records how late
each tick started. What a late tick means depends on whose clock the robot lives on
(device.backend): a real robot gets the wall clock, and the supervisor faults a tick
more than 10 ms late; a simulated one is stepped by exactly one period per tick, so a
stall of the host delays the simulation, is recorded and shown, and stops nothing.
Before a real robot is opened, Connect checks for a second whether this machine wakes
the loop on time and tells the therapist when it does not.

State machine: device.loop.states. Faults: device.safety.supervisor (latched until cleared).
"""

from __future__ import annotations

import dataclasses
import faulthandler
import math
import time
from dataclasses import dataclass
from multiprocessing.connection import Connection

from core.errors import ParameterError
from core.trial import TrialParameters
from device.backend import REAL_TIME, SIMULATED, TIMINGS, Backend, SensorReading
from device.errors import BackendError, DeviceError, StateError
from device.loop.messages import (
    BackendConfig,
    Build,
    ClearFault,
    Connect,
    Disconnect,
    FaultRaised,
    Notice,
    Reply,
    SetAssistance,
    Shutdown,
    Start,
    StateChanged,
    Stop,
    TrialEnded,
    TrialStarted,
)
from device.loop.pipeline import PERIOD_S, TickPipeline, TrialPlan, idle_record
from device.loop.realtime import (
    LAST_CPU,
    measure_wakeups,
    prepare_process,
    timing_warning,
    wait_until,
)
from device.loop.states import Command, State, refusal
from device.recording.messages import BeginTrial, EndTrial, TrialEvent
from device.recording.ring import RecordRing
from device.safety.faults import Fault
from device.safety.supervisor import SafetyLimits, SafetySupervisor

NO_READING = SensorReading(math.nan, math.nan, math.nan, math.nan, math.nan, math.nan)
STOPPING_TIMEOUT_S = 2.0
"""Longest wait in Stopping for the recorder to take the trial's last samples."""
WORKSPACE_MARGIN_M = 0.10
"""The end effector may leave the exercise's path by this much before WORKSPACE trips."""

_COMMANDS = {
    Build: Command.BUILD, Connect: Command.CONNECT, Disconnect: Command.DISCONNECT,
    Start: Command.START, Stop: Command.STOP, ClearFault: Command.CLEAR_FAULT,
    SetAssistance: Command.SET_ASSISTANCE, Shutdown: Command.SHUTDOWN,
}


SLACK_S = 200e-6
"""Time before each deadline for commands and for rehearsing the compiled tick on a
copy of its state (device.compiled.looptick): enough for a command and a cold
rehearsal, short enough that the caches are still warm when the real tick runs."""


@dataclass(frozen=True, slots=True)
class LoopConfig:
    period_s: float = PERIOD_S
    cpu: int | None = LAST_CPU  # None: any CPU
    realtime: bool = True
    compiled: bool = True
    """Run the simulator's trial ticks compiled (device.compiled.looptick) when the
    configuration allows; False keeps every tick in Python."""
    timing_check_s: float = 1.0
    """How long Connect measures this machine's wake-up lateness before it opens a
    REAL_TIME backend (device.loop.realtime.timing_warning); 0 skips the check."""


def make_backend(config: BackendConfig, params: TrialParameters, plan: TrialPlan) -> Backend:
    """The backend a BackendConfig names, built inside the loop process."""
    if config.timing not in (None, *TIMINGS):
        raise BackendError(f"unknown timing {config.timing!r}; use {' or '.join(TIMINGS)}")
    if config.kind == "simulator":
        from device.sim.simulator import SimulatorBackend

        backend: Backend = SimulatorBackend.from_trial(
            params, config.patient, seed=config.seed, robot=plan.robot, patient_waits=True,
            timing=config.timing or SIMULATED,
        )
    elif config.kind == "quanser":
        if config.timing == SIMULATED:
            raise BackendError("the real robot moves on the wall clock; simulated timing "
                               "is only for the simulator")
        from device.hardware.quanser import QuanserBackend
        from device.hardware.settings import load_hardware_settings

        if not config.hardware_settings:
            raise BackendError("the hardware backend needs its settings file "
                               "(docs/hardware.md); choose it in the Parameters tab")
        settings = load_hardware_settings(config.hardware_settings)
        backend = QuanserBackend(settings, plan.robot.motors)
    else:
        raise BackendError(f"unknown backend {config.kind!r}; use simulator or quanser")
    if config.fault_scenario:
        from device.sim.faultinjection import FaultInjectingBackend

        backend = FaultInjectingBackend(backend, config.fault_scenario, at_s=config.fault_at_s,
                                        **dict(config.fault_options))
    return backend


def limits_for_backend(limits: SafetyLimits, backend: Backend) -> SafetyLimits:
    """The supervisor's limits with the force sensor's rated range where the backend
    knows it from the sensor's calibration (the hardware backend, once open)."""
    inner = getattr(backend, "inner", backend)  # under a FaultInjectingBackend
    rated = getattr(inner, "force_sensor_range_N", None)
    if rated is None:
        return limits
    return limits.for_sensor(*rated)


def sensor_offset_for(config: BackendConfig) -> float:
    if config.kind == "quanser" and config.hardware_settings:
        from device.hardware.settings import load_hardware_settings

        return load_hardware_settings(config.hardware_settings).force_sensor.mounting_offset_rad
    return 0.0


class DeviceLoop:
    """The loop's state and its tick. One instance per loop process."""

    def __init__(self, console: Connection, recorder: Connection | None, ring: RecordRing,
                 estop_flag, heartbeat, recording_failed, config: LoopConfig) -> None:
        self.console = console
        self.recorder = recorder
        self.ring = ring
        self.estop_flag = estop_flag
        self.heartbeat = heartbeat
        self.recording_failed = recording_failed
        self.config = config
        self.state = State.IDLE
        self.console_lost = False
        self.plan: TrialPlan | None = None
        self.backend_config: BackendConfig | None = None
        self.limits: SafetyLimits | None = None
        self.backend: Backend | None = None
        self.supervisor: SafetySupervisor | None = None
        self.pipeline: TickPipeline | None = None
        self.sensor_offset_rad = 0.0
        self.reading: SensorReading | None = None
        self.trial_path = ""
        self.trial_tick = 0
        self.end_seq = 0
        self.fault_reported = Fault.NONE
        self.assistance_level: float | None = None
        self.shutdown = False
        self.stopping_since = 0.0
        self.paused = False
        self.t0 = 0.0
        self.trial_start_sample_s = 0.0
        self.compiled = None  # device.compiled.looptick.CompiledTick during a trial

    # ------------------------------------------------------------------ main
    def run(self) -> None:
        while not self.shutdown:
            if self.state in (State.IDLE, State.BUILT):
                self._idle_wait()
            else:
                self._run_connected()
        self._disconnect_backend()

    def _idle_wait(self) -> None:
        """Not connected: nothing to tick, wait for a command."""
        try:
            ready = self.console.poll(0.05)
        except (EOFError, OSError):
            ready = True
        if ready:
            self._handle_commands()
        if self.console_lost:
            self.shutdown = True

    def _run_connected(self) -> None:
        cfg = self.config
        period = cfg.period_s
        clock = time.perf_counter
        t0 = self.t0 = clock()
        deadline = t0 + period
        beat = self.heartbeat.value
        beat_seen = t0
        push = self.ring.push
        overwrite = self.ring.would_overwrite_unrecorded
        supervisor = self.supervisor
        backend = self.backend
        simulated = backend.timing == SIMULATED
        k = 0
        overrun = 0.0
        while self.state in (State.CONNECTED, State.RUNNING, State.STOPPING, State.FAULTED):
            # The slack before the deadline: commands, then a rehearsal of the tick, so
            # that the tick itself is only sensors → torque (its compute time).
            wait_until(deadline - SLACK_S, clock)
            if self.console.poll():
                if self.compiled is not None:
                    self.compiled.hand_back()
                self._handle_commands()
                if self.state not in (State.CONNECTED, State.RUNNING, State.STOPPING,
                                      State.FAULTED):
                    break
                supervisor, backend = self.supervisor, self.backend
                simulated = backend.timing == SIMULATED
                if self.paused:
                    # Build, Connect and Start compute tables (milliseconds of numpy) at
                    # zero torque; the schedule restarts from now instead of counting
                    # the pause as late ticks.
                    self.paused = False
                    deadline, overrun = clock() + SLACK_S, 0.0
                self._take_over()
            compiled = self.compiled
            if compiled is not None and compiled.active and self.state == State.RUNNING:
                compiled.warm(self.trial_tick, k * period if simulated else deadline - t0)
            now = wait_until(deadline, clock)
            lateness = max(now - deadline, overrun)
            overrun = 0.0
            loop_t = now - t0
            # The robot's clock (device.backend): a real robot moves on the wall clock, so
            # its supervisor must see how late the tick is; a simulated one is stepped by
            # one period per tick, and on its clock no tick is late. The wall-clock
            # lateness is recorded either way.
            if simulated:
                robot_t, robot_lateness = k * period, 0.0
            else:
                robot_t, robot_lateness = loop_t, lateness
            value = self.heartbeat.value
            if value != beat:
                beat, beat_seen = value, now
            beat_age = math.inf if self.console_lost else now - beat_seen
            estop = bool(self.estop_flag.value)
            written = None
            if compiled is not None and compiled.active and self.state == State.RUNNING:
                lost = bool(self.recording_failed.value) or overwrite()
                written = compiled.tick(self.trial_tick, robot_t, robot_lateness, beat_age,
                                        estop, lost)
            if written is not None:
                # an ordinary running tick, done compiled; anything else comes back here
                # undone and runs below in Python
                out1, out2 = written
                fault = Fault.NONE
                compute = clock() - now
                reading = SensorReading._make(compiled.reading())
                self.reading = reading
                self.pipeline.set_last_tick(compiled.last_tick())
                running = True
            else:
                try:
                    reading = backend.read(robot_t)
                except BackendError as exc:
                    reading = exc
                running = self.state == State.RUNNING and isinstance(reading, SensorReading)
                if running:
                    tau1, tau2 = self.pipeline.control(self.trial_tick, reading)
                    rate1, rate2 = self.pipeline.rates
                else:
                    tau1 = tau2 = rate1 = rate2 = 0.0
                lost = bool(self.recording_failed.value) or (overwrite() and self.state ==
                                                             State.RUNNING)
                out1, out2, fault = supervisor.step(
                    robot_t, reading, rate1, rate2, tau1, tau2, robot_lateness, beat_age, estop,
                    lost,
                )
                try:
                    backend.write(out1, out2)
                except BackendError:
                    backend.safe_state()
                compute = clock() - now
                if running:
                    self.reading = reading
            if running:
                record = self.pipeline.record(
                    self.trial_tick, reading, loop_t, lateness, compute, (out1, out2),
                    int(self.state), int(fault))
            else:
                if isinstance(reading, SensorReading):
                    self.reading = reading
                else:
                    reading = NO_READING  # a failed read still leaves its tick in the record
                tick = self.trial_tick if self.state == State.RUNNING else k
                record = idle_record(
                    self.plan.robot, self.pipeline.arm, tick, reading, loop_t, lateness,
                    compute, int(self.state), int(fault), period, self.sensor_offset_rad)
            if not overwrite():
                push(record)
            if fault and fault != self.fault_reported:
                self._on_fault(fault, loop_t)
            elif running:
                self._advance_trial(backend)
            elif self.state == State.STOPPING:
                if self.ring.recorder_cursor >= self.end_seq:
                    self._set_state(State.CONNECTED, "the trial file has all its samples")
                elif now - self.stopping_since > STOPPING_TIMEOUT_S:
                    self._send(Notice("warning", "the recorder did not confirm the last "
                                                 "samples; check the trial file"))
                    self._set_state(State.CONNECTED, "stopped without the recorder's answer")
            if self.console_lost and self.state != State.RUNNING:
                self.shutdown = True
                break
            if compiled is not None and (self.state != State.RUNNING or not compiled.active):
                compiled = self._take_over()
            if compiled is not None:
                compiled.keep_noise()  # here, well before the next deadline
            k += 1
            deadline += period
            behind = clock() - deadline
            if behind > 0.0:
                # Missed deadlines are skipped, not run back to back: a burst of ticks
                # microseconds apart would read the same sensor sample over and over.
                # The schedule stays on its 2 ms grid, and the next tick reports how late
                # the first missed one was, so the lateness watchdog still sees it.
                deadline += period * math.ceil(behind / period)
                overrun = behind

    # ------------------------------------------------------------------ trial
    def _advance_trial(self, backend: Backend) -> None:
        self.trial_tick += 1
        if self.trial_tick == self.pipeline.approach_ticks:
            if self.compiled is not None:
                self.compiled.hand_back()  # taken over again after this tick
            _cue_patient(backend)
        if self.trial_tick >= self.pipeline.total_ticks:
            self._end_trial("complete", "trial complete")
            self._set_state(State.STOPPING, "trial complete; saving")

    def _take_over(self):
        """Let the compiled tick run the trial's next tick, if there is one and it may;
        drop it once the trial is over. Returns the compiled tick (None when dropped)."""
        compiled = self.compiled
        if compiled is None:
            return None
        if self.state != State.RUNNING:
            compiled.hand_back()
            self.compiled = None
            return None
        if not compiled.active:
            compiled.take_over()
        return compiled

    def _start_trial(self, command: Start) -> str:
        if self.reading is None:
            return "no sensor reading yet; wait a moment after Connect"
        self.paused = True
        self.pipeline.begin(self.reading.q1_rad, self.reading.q2_rad)
        if self.assistance_level is not None:
            self.pipeline.set_assistance_level(self.assistance_level)
        self.supervisor.restart_ramp()
        self.trial_path = command.path
        self.trial_tick = 0
        self.trial_start_sample_s = self.reading.time_s
        if self.pipeline.approach_ticks == 0:
            _cue_patient(self.backend)
        self.compiled = None
        if self.config.compiled:
            # imported here: numba belongs in the loop process, not in the console's
            from device.compiled.looptick import CompiledTick, unsupported_live

            if not unsupported_live(self.backend, self.pipeline, self.supervisor):
                self.compiled = CompiledTick(self.backend, self.pipeline, self.supervisor)
                self.compiled.take_over()
        plan = self.plan
        self._to_recorder(BeginTrial(
            command.path, self.ring.write_count, plan.parameters, command.subject,
            dataclasses.asdict(plan.robot), self.backend_config.label, plan.period_s,
        ))
        self._to_recorder(TrialEvent(0.0, 0, "start", "trial started",
                                     {"approach_ticks": self.pipeline.approach_ticks}))
        self._send(TrialStarted(command.path, self.pipeline.approach_ticks,
                                self.pipeline.total_ticks))
        self._set_state(State.RUNNING, "trial started")
        return ""

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
        self._to_recorder(EndTrial(self.end_seq, status, summary))
        self._send(TrialEnded(self.trial_path, status, summary))

    def _on_fault(self, fault: Fault, loop_t: float) -> None:
        self.fault_reported = fault
        sup = self.supervisor
        detail = dict(sup.fault_detail)
        detected = time.monotonic()
        detail["monotonic_s"] = detected
        if self.state == State.RUNNING:
            tick = self.trial_tick
            self._to_recorder(TrialEvent(tick * self.plan.period_s, tick, "fault",
                                         sup.fault_message, detail))
            status = "recording_lost" if fault == Fault.RECORDING_LOST else "faulted"
            self._end_trial(status, f"stopped by a fault: {fault.label}")
        self._send(FaultRaised(int(fault), sup.fault_message, detail, loop_t, detected))
        self._set_state(State.FAULTED, sup.fault_message)

    # ------------------------------------------------------------------ commands
    def _handle_commands(self) -> None:
        try:
            while self.console.poll():
                self._command(self.console.recv())
        except (EOFError, OSError):
            self.console_lost = True

    def _command(self, command) -> None:
        kind = _COMMANDS.get(type(command))
        if kind is None:
            return
        reason = refusal(self.state, kind)
        if not reason:
            try:
                reason = self._do(command)
            except (DeviceError, ValueError) as exc:
                reason = f"{kind.value} failed: {exc}"
        self._send(Reply(command.id, not reason, reason))

    def _do(self, command) -> str:
        """Carry out an allowed command; returns '' or why it could not be done."""
        if isinstance(command, Build):
            return self._build(command)
        if isinstance(command, Connect):
            return self._connect()
        if isinstance(command, Disconnect):
            self._disconnect_backend()
            self._set_state(State.BUILT, "disconnected")
            return ""
        if isinstance(command, Start):
            return self._start_trial(command)
        if isinstance(command, Stop):
            self._end_trial("stopped_early", "stopped by the therapist")
            self._set_state(State.STOPPING, "trial stopped; saving")
            return ""
        if isinstance(command, ClearFault):
            try:
                self.supervisor.clear()
            except StateError as exc:
                return str(exc)
            self.fault_reported = Fault.NONE
            if self.pipeline is not None:
                self.pipeline.controller.reset()
            self._set_state(State.CONNECTED, "fault cleared")
            return ""
        if isinstance(command, SetAssistance):
            self.assistance_level = command.level
            if self.pipeline is not None:
                self.pipeline.set_assistance_level(command.level)
            return ""
        if isinstance(command, Shutdown):
            if self.state == State.RUNNING:
                self._end_trial("stopped_early", "console closed")
            self.shutdown = True
            self._set_state(State.IDLE, "shutting down")
            return ""
        return f"{type(command).__name__} is not handled"

    def _build(self, command: Build) -> str:
        self.paused = True
        plan = TrialPlan.build(command.parameters, period_s=self.config.period_s)
        reconnect = self.state == State.CONNECTED and self.backend_config is not None and (
            command.backend != self.backend_config or command.backend.kind == "simulator")
        if reconnect and command.backend.kind != self.backend_config.kind:
            return "disconnect before changing the robot backend"
        limits = (command.limits or SafetyLimits()).around_path(
            plan.parameters.path().points(), WORKSPACE_MARGIN_M)
        self.plan, self.backend_config, self.limits = plan, command.backend, limits
        self.pipeline = TickPipeline(plan, sensor_offset_rad=self.sensor_offset_rad)
        if self.assistance_level is not None:
            self.pipeline.set_assistance_level(self.assistance_level)
        if reconnect:
            # the virtual patient follows the new exercise: rebuild the simulator
            self._disconnect_backend()
            return self._connect()
        if self.state == State.IDLE:
            self._set_state(State.BUILT, "trial built")
        return ""

    def _connect(self) -> str:
        self.paused = True
        config = self.backend_config
        backend = make_backend(config, self.plan.parameters, self.plan)
        if backend.timing == REAL_TIME and self.config.timing_check_s > 0.0:
            self._check_timing()
        backend.open()
        try:
            self.limits = limits_for_backend(self.limits, backend)
        except ParameterError as exc:
            backend.safe_state()
            backend.close()
            return f"connect refused: {exc}"
        self.sensor_offset_rad = sensor_offset_for(config)
        self.pipeline = TickPipeline(self.plan, sensor_offset_rad=self.sensor_offset_rad)
        if self.assistance_level is not None:
            self.pipeline.set_assistance_level(self.assistance_level)
        self.backend = backend
        self.supervisor = SafetySupervisor(self.plan.robot, self.limits)
        if self.config.compiled and config.kind == "simulator":
            from device.compiled.warmup import load_kernels

            load_kernels(("loop",))  # a first call inside a tick would stall it
        self.fault_reported = Fault.NONE
        self.reading = None
        self._set_state(State.CONNECTED, f"connected to the {config.label}")
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
    def _set_state(self, state: State, reason: str) -> None:
        if state == State.STOPPING:
            self.stopping_since = time.perf_counter()
        self.state = state
        self._send(StateChanged(int(state), reason))

    def _send(self, message) -> None:
        if self.console_lost:
            return
        try:
            self.console.send(message)
        except (OSError, EOFError, BrokenPipeError):
            self.console_lost = True

    def _to_recorder(self, message) -> None:
        if self.recorder is None:
            return
        try:
            self.recorder.send(message)
        except (OSError, EOFError, BrokenPipeError):
            self.recorder = None
            self.recording_failed.value = 1


def _cue_patient(backend: Backend) -> None:
    """A virtual patient starts the exercise together with the reference."""
    cue = getattr(backend, "cue_patient", None)
    if cue is not None:
        cue()


def loop_main(console: Connection, recorder: Connection, ring_name: str, estop_flag,
              heartbeat, recording_failed, config: LoopConfig) -> None:
    """Entry point of the loop process."""
    faulthandler.enable()  # a crash in compiled code still leaves a traceback on stderr
    problems = prepare_process(config.cpu) if config.realtime else []
    ring = RecordRing.attach(ring_name)
    loop = DeviceLoop(console, recorder, ring, estop_flag, heartbeat, recording_failed, config)
    for problem in problems:
        loop._send(Notice("warning", f"real-time setup: {problem}"))
    try:
        loop.run()
    finally:
        loop._disconnect_backend()
        ring.close()
        recorder.close()
        console.close()
