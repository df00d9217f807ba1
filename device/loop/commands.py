"""What the loop process does with each command from the console: build, connect,
disconnect, start, stop, clear a fault, set the assistance level, shut down, and the backend
and tick engine a Build or a Connect opens (a part of device.loop.process.DeviceLoop).

A command is carried out between ticks, in the slack before a deadline; one that needs a tick
first (a Start before the first reading, a ClearFault, which must see its cause gone on a
fresh tick) answers LATER and is carried out after the next tick. Where each command leads
is device.loop.states.TRANSITIONS; what each does is here.
"""

from __future__ import annotations

import dataclasses
import time

from core.errors import ParameterError
from device.backend import REAL_TIME
from device.errors import BackendError, DeviceError, StateError
from device.loop.backends import limits_for_backend, make_backend
from device.loop.engine import TickEngine
from device.loop.messages import (
    Build,
    ClearFault,
    Connect,
    Disconnect,
    ForceEstimate,
    HandleArea,
    Notice,
    Reply,
    SensorZeroed,
    SetAssistance,
    ShownToPatient,
    Shutdown,
    Start,
    Stop,
    TrialNote,
)
from device.loop.pipeline import (
    TickPipeline,
    TrialPlan,
    has_compiled_form,
    learned_controller,
    learned_model_refusal,
)
from device.loop.realtime import (
    measure_wakeups,
    timing_warning,
)
from device.loop.states import TRANSITIONS, Command, State, refusal
from device.recording.messages import (
    TrialEvent,
)
from device.safety.faults import Fault
from device.safety.limits import SafetyLimits
from device.safety.supervisor import SafetySupervisor

WORKSPACE_MARGIN_M = 0.10
"""The end effector may leave the exercise's path by this much before WORKSPACE trips."""

AREA_CHECK_TICKS = 50
"""Between trials the console hears every this many ticks (0.1 s) whether the handle is
outside the exercise area, when that changed (HandleArea): often enough to follow a hand
guiding it in, rare enough to cost the loop nothing."""

COMMAND_KINDS = {
    Build: Command.BUILD, Connect: Command.CONNECT, Disconnect: Command.DISCONNECT,
    Start: Command.START, Stop: Command.STOP, ClearFault: Command.CLEAR_FAULT,
    SetAssistance: Command.SET_ASSISTANCE, Shutdown: Command.SHUTDOWN,
}


LATER = object()
"""A command handler's answer when it is carried out at the next tick (its reply then)."""


class LoopCommands:
    """The commands and the backend they open (a part of DeviceLoop: the same state)."""

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
        if isinstance(command, TrialNote):
            if self.state == State.RUNNING:
                tick = self.trial_tick
                self._to_recorder(TrialEvent(tick * self.plan.period_s, tick, command.kind,
                                             command.message, dict(command.values)))
            return
        kind = COMMAND_KINDS.get(type(command))
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
        stays = not reconnect and self.engine is not None and self.state.ticking
        if stays:
            # the robot stays connected: its supervisor takes this trial's limits (the
            # therapist's force limit, the new exercise's area) with the sensor's range as
            # at Connect. It kept the first Build's: on the real robot a force limit lowered
            # for a fragile arm went unheard, and the area stayed the first exercise's
            try:
                limits = limits_for_backend(limits, self.backend)
            except ParameterError as exc:
                return f"build refused: {exc}"
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
        if stays:
            self.supervisor = self.supervisor.with_limits(limits)
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
        outside = self.supervisor.outside_line(self.reading.q1_rad, self.reading.q2_rad)
        if outside:
            # the robot does not drag a handle into its area: the therapist guides it in
            # (docs/safety.md, H8); a trial started outside would latch WORKSPACE at once
            return f"start refused: {outside}."
        if command.answer_by_s is not None and time.monotonic() > command.answer_by_s:
            # the console has stopped waiting and taken the trial back: run, it would be a
            # trial the registry does not have (here after the simulator was reopened)
            late = time.monotonic() - command.answer_by_s
            return (f"start refused: the console stopped waiting for this Start {late:.1f} s "
                    "ago; press Start again")
        return self._start_trial(command), "trial started"

    def _tell_area(self) -> None:
        """Tell the console when the handle went outside the exercise area or came back
        inside (or, outside, moved), as the last tick found it: what a Start now would
        be refused for (the loop calls it every AREA_CHECK_TICKS while connected)."""
        reading = self.reading
        line = "" if reading is None else self.supervisor.outside_line(reading.q1_rad,
                                                                       reading.q2_rad)
        if line != self.area_told:
            self.area_told = line
            self._send(HandleArea(line))

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
            from device.sim.seeds import draw_seed  # as make_backend: the simulator's

            config = dataclasses.replace(config, seed=draw_seed())
        backend = make_backend(config, self.plan.parameters, self.plan, self.clock.sleep,
                               self.config.compiled)
        if backend.timing == REAL_TIME and check_timing and self.config.timing_check_s > 0.0:
            self._check_timing()
        if self.config.compiled:
            from device.compiled.warmup import load_kernels

            # before open(): a real robot's card starts its watchdog there, and the first
            # load of the kernels (a third of a second and more) kept the loop from
            # reloading it, so the first Connect of a console tripped it
            load_kernels(("loop",))
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
        # the real robot's settings as this open read them (None on the simulator): the
        # sensor's mounting and the robot's name, which the trial's backend and start event
        # record (device.hardware.settings.RobotIdentity), from that one read
        settings = getattr(getattr(backend, "inner", backend), "settings", None)
        self.sensor_offset_rad = (0.0 if settings is None
                                  else settings.force_sensor.mounting_offset_rad)
        if settings is not None:
            config = dataclasses.replace(config, robot_name=settings.robot.name)
        self.pipeline = self._new_pipeline()
        self.backend = backend
        self.supervisor = SafetySupervisor(self.plan.robot, self.limits)
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


_HANDLERS = {
    Command.BUILD: LoopCommands._do_build, Command.CONNECT: LoopCommands._do_connect,
    Command.DISCONNECT: LoopCommands._do_disconnect, Command.START: LoopCommands._do_start,
    Command.STOP: LoopCommands._do_stop, Command.CLEAR_FAULT: LoopCommands._do_clear_fault,
    Command.SET_ASSISTANCE: LoopCommands._do_set_assistance,
    Command.SHUTDOWN: LoopCommands._do_shutdown,
}
"""What each command does; where it leads is device.loop.states.TRANSITIONS."""
