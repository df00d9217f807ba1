"""The safety supervisor: the last word between the controller and the motors, every 2 ms tick.

One tick of the supervisor (`SafetySupervisor.step`, or the loop's tick engine
running the same kernel on this object's vectors) takes what the loop measured and
what the controller (after the performance-based assistance) wants to command, and
returns the torques to write and the latched fault code:

* Torque above the drive's limit is clamped, not a fault: both joints are
  scaled by the same factor, which keeps each sign and the direction of the
  force the robot puts on the hand.
* Any fault makes the output exactly zero in the tick it is detected and keeps
  it zero until the therapist clears it (`clear`), which is refused while the
  cause is still present. Zero torque, not a damping brake: the thesis robot is
  backdrivable, so zero torque leaves the patient free to move and never puts
  energy in, and a brake would rely on the rate estimate, which is itself
  among the things a fault may have broken (an encoder jump, NaN, stale data).
* After start and after every clear, the torque limit ramps up from zero over
  `restart_ramp_s`, so a controller that wound up while the torque was zero
  cannot jolt the arm when the torque comes back.

The checks themselves are the kernels of device.safety.checks, one per check, in
the order of docs/safety.md ("Which fault wins"). This class validates the limits
against the robot's drives, owns the constants and state vectors the kernels work
on (the loop's compiled tick engine runs the same kernels on the same vectors,
device.loop.engine), and turns a latched fault's numbers into its detail and the
therapist's banner line. Nothing but the fault's detail is built per tick.
"""

from __future__ import annotations

import math

import numpy as np

from core.errors import ParameterError
from core.robot import RobotModel
from device.backend import SensorReading
from device.errors import BackendError, BackendTimeout, StateError
from device.safety import checks
from device.safety.checks import (
    FINITE_FIELDS,
    FROM_RATE_ESTIMATE,
    LATE_ONE,
    W_CONDITION,
    W_D0,
    W_D3,
    W_FAULT,
    W_FAULT_TIME,
    W_OUTSIDE,
    W_RAMP_SINCE,
    W_SAT_SINCE,
    supervise,
)
from device.safety.faults import Fault
from device.safety.limits import SENSOR_SATURATION_FRACTION, SafetyLimits

_NONE = Fault.NONE
_AXES = ("x'", "y'", "z'")


class SafetySupervisor:
    """Checks every tick, clamps the torque, latches faults until cleared.

    Create one per connection to the robot: an ENCODER_JUMP can only be left by
    reconnecting (the angles may be offset since), which means a new supervisor.
    """

    __slots__ = ("_error", "_fault_detail", "_limits", "_reach", "_robot", "constants",
                 "state")

    def __init__(self, robot: RobotModel | None = None, limits: SafetyLimits | None = None):
        self._robot = robot if robot is not None else RobotModel()
        self._limits = limits if limits is not None else SafetyLimits()
        lim = self._limits
        full = []
        for i, motor in enumerate(self._robot.motors):
            drive_Nm = motor.max_joint_torque_Nm
            if lim.torque_limit_Nm > drive_Nm * (1.0 + 1e-9):
                raise ParameterError(
                    "torque_limit_Nm", lim.torque_limit_Nm, f"(0, {drive_Nm:g}] N·m",
                    f"joint {i + 1}'s drive is rated for {motor.max_current_A:g} A, "
                    f"which is {drive_Nm:g} N·m at the joint",
                )
            if lim.current_limit_A > motor.max_current_A * (1.0 + 1e-9):
                raise ParameterError(
                    "current_limit_A", lim.current_limit_A, f"(0, {motor.max_current_A:g}] A",
                    f"joint {i + 1}'s motor is rated for {motor.max_current_A:g} A",
                )
            full.append(min(lim.torque_limit_Nm,
                            motor.joint_torque_from_current(lim.current_limit_A)))
        reach_min, reach_max = self._robot.reach_band_m(lim.workspace_margin_m)
        if reach_min >= reach_max:
            raise ParameterError(
                "workspace_margin_m", lim.workspace_margin_m,
                f"< {(self._robot.reach_max_m - self._robot.reach_min_m) / 2:g} m",
                "the margin would leave no room inside the robot's reach",
            )
        self._reach = (reach_min, reach_max)
        self.constants = _constants(lim, full, self._reach)
        """The checks' constants vector (device.safety.checks' G_* names)."""
        self.state = np.zeros(checks.W_SIZE)
        """The checks' state vector (W_*): the sample history, counts and timers, the
        latched fault and the last tick's condition."""
        self.state[[W_SAT_SINCE, W_RAMP_SINCE, W_FAULT_TIME]] = math.nan
        self._fault_detail: dict = {}
        self._error: BaseException | None = None

    # ------------------------------------------------------------------ state
    @property
    def limits(self) -> SafetyLimits:
        return self._limits

    @property
    def robot(self) -> RobotModel:
        return self._robot

    @property
    def torque_limits_Nm(self) -> tuple[float, float]:
        """The clamp per joint: the lower of the torque limit and the current limit."""
        return (float(self.constants[checks.G_FULL1]), float(self.constants[checks.G_FULL2]))

    @property
    def reach_band_m(self) -> tuple[float, float]:
        """Distances from the motor axes the handle must stay within (the reach ring less
        the workspace margin)."""
        return self._reach

    @property
    def fault(self) -> Fault:
        """The latched fault, Fault.NONE when the torque is allowed through."""
        return Fault(int(self.state[W_FAULT]))

    @property
    def fault_time_s(self) -> float:
        """Loop time of the tick that latched the fault; NaN when none."""
        return float(self.state[W_FAULT_TIME])

    @property
    def fault_detail(self) -> dict:
        """The latched fault's cause and values, for the trial file's event ({} when none).

        Always has 'fault' (the label) and 'code'; then the values of the check that
        tripped, e.g. {'force_N': 63.2, 'limit_N': 50.0, ...}. Plain floats, ints and
        strings: JSON as it stands.
        """
        return self._fault_detail

    @property
    def fault_message(self) -> str:
        """The therapist's banner line for the latched fault ('No fault' when none)."""
        return self.fault.banner(self._fault_detail)

    @property
    def condition(self) -> Fault:
        """What the last tick found, latched or not: Fault.NONE when every check passed."""
        return Fault(int(self.state[W_CONDITION]))

    @property
    def outside_area(self) -> bool:
        """The last good reading put the handle outside the exercise area (the reach band
        or the region): a fault while a trial runs, a state between trials."""
        return bool(self.state[W_OUTSIDE])

    def outside_line(self, q1_rad: float, q2_rad: float) -> str:
        """What the therapist reads while no trial runs and the last tick found the handle
        outside the exercise area, at the angles of that tick's reading ('' when inside):
        the window's line, and the reason Start is refused until it is inside."""
        if not self.outside_area:
            return ""
        x, y = (float(v) for v in self._robot.position(q1_rad, q2_rad))
        radius = math.hypot(x, y)
        reach_min, reach_max = self._reach
        if not reach_min <= radius <= reach_max:
            return (f"handle outside the robot's reach: guide it inside (now {_cm(radius)} "
                    f"cm from the motor axes; it must be {_cm(reach_min)}–{_cm(reach_max)} "
                    "cm)")
        x0, x1, y0, y1 = (_cm(v) for v in self._limits.region_m)
        return (f"handle outside the exercise area: guide it inside (now at {_cm(x)}, "
                f"{_cm(y)} cm; the area is x {x0} to {x1} cm, y {y0} to {y1} cm)")

    def clear_refusal(self) -> str:
        """Why `clear` would be refused now, or '' when it would succeed."""
        fault = self.fault
        if fault is _NONE:
            return ""
        if not fault.clearable:
            return (f"This fault cannot be cleared: {self.fault_message}. "
                    "Reconnect the robot to start again.")
        condition = self.condition
        if condition is not _NONE:
            return ("The fault cannot be cleared while its cause is present: "
                    f"{condition.banner(self._detail(condition))}.")
        return ""

    def clear(self) -> None:
        """Release the latched fault; the torque then ramps up from zero.

        Raises StateError (with the reason) while the cause is still present as of
        the last tick (e-stop held, force still over its limit, handle still outside
        its region, …) or for a fault that needs a reconnection. Clearing with no
        fault latched does nothing. The loop should also reset the controller's
        integrators, which have been running against zero torque.
        """
        if self.fault is _NONE:
            return
        reason = self.clear_refusal()
        if reason:
            raise StateError(reason)
        self.state[W_FAULT] = _NONE
        self.state[[W_FAULT_TIME, W_SAT_SINCE, W_RAMP_SINCE]] = math.nan
        self._fault_detail = {}

    def with_limits(self, limits: SafetyLimits) -> SafetySupervisor:
        """A supervisor of the same connection with other limits (a Build between trials
        with the robot connected: the therapist's force limit, the new exercise's area),
        carrying this one's state (the sample history, counts and timers). Refused while a
        fault is latched: a fault is left by clearing it, an ENCODER_JUMP by reconnecting."""
        if self.fault is not _NONE:
            raise StateError(f"a fault is latched ({self.fault.label}): clear it first")
        new = SafetySupervisor(self._robot, limits)
        new.state[:] = self.state
        return new

    def restart_ramp(self) -> None:
        """Ramp the torque limit up from zero again, as after a clear: the loop calls it
        when a trial starts, after ticks spent connected at zero torque."""
        self.state[W_RAMP_SINCE] = math.nan

    # ------------------------------------------------------------------- tick
    def step(
        self,
        now_s: float,
        reading: SensorReading | BaseException,
        rate1_rad_s: float,
        rate2_rad_s: float,
        torque1_Nm: float,
        torque2_Nm: float,
        lateness_s: float,
        heartbeat_age_s: float,
        estop: bool,
        recording_lost: bool,
        driving: bool = True,
    ) -> tuple[float, float, Fault]:
        """One tick: check everything, return (torque1_Nm, torque2_Nm, fault) to write.

        now_s: loop time. reading: this tick's SensorReading, or the exception the
        backend's read raised. rate*_rad_s: the loop's joint-rate estimate.
        torque*_Nm: the command after the assistance. lateness_s: how late this tick
        started. heartbeat_age_s: time since the console's last heartbeat (inf if
        none yet). estop: the e-stop is held (a level, not an edge). recording_lost:
        the recorder is behind by more than the ring holds. driving: a trial runs and
        the torque is the controller's; False between trials, when the loop writes zero
        torque and a handle outside the exercise area is a state (`outside_line`),
        not a fault (device.safety.checks.check_workspace).
        """
        values, read_error = self.read_values(reading)
        before = self.state[W_FAULT]
        out1, out2, code = supervise(
            self._robot.constants, self.constants, self.state, now_s, *values, rate1_rad_s,
            rate2_rad_s, torque1_Nm, torque2_Nm, lateness_s, heartbeat_age_s, estop,
            recording_lost, float(read_error), bool(driving))
        self.after_tick(before)
        return (out1, out2, Fault(code))

    def read_values(self, reading) -> tuple[tuple, int]:
        """The six numbers of `reading` and the read-error code for `supervise`: zeros and
        BACKEND_ERROR or BACKEND_TIMEOUT when the read raised or passed no numbers (the
        error is kept for the fault's detail)."""
        if not isinstance(reading, BaseException):
            try:
                values = tuple(reading)
                if len(values) != 6:
                    raise ValueError
                values = tuple(_number(value) for value in values)
            except (TypeError, ValueError):
                # Not a reading of numbers: a bug upstream, handled like a failed read.
                reading = BackendError(f"the loop passed {reading!r:.100} as the sensor reading")
            else:
                self._error = None
                return values, 0
        self._error = reading
        code = Fault.BACKEND_TIMEOUT if isinstance(reading, BackendTimeout) else Fault.BACKEND_ERROR
        return (0.0, 0.0, 0.0, 0.0, 0.0, 0.0), int(code)

    def after_tick(self, fault_before: float) -> None:
        """After `supervise` ran on `state` (here or in the compiled tick engine): when
        it latched a new fault, write that fault's detail."""
        if self.state[W_FAULT] != fault_before and self.state[W_FAULT] != _NONE:
            self._fault_detail = self._detail(self.fault)

    # ----------------------------------------------------------------- detail
    def _detail(self, code: Fault) -> dict:
        """The detail of `code` as the last tick's condition numbers describe it."""
        detail = fault_detail(code, self.state[W_D0:W_D3 + 1].tolist(), self)
        detail["fault"] = code.label
        detail["code"] = int(code)
        return detail

    def _workspace_problem(self, q1: float, q2: float, x: float, y: float) -> str:
        problem = self._robot.limit_problem(q1, q2, now=True)
        if problem:
            return problem
        # in cm, as the window's form, plots and reports give positions (app.units), short
        # enough for the banner's two lines at a laptop's width
        radius = math.hypot(x, y)
        reach_min, reach_max = self._reach
        if not reach_min <= radius <= reach_max:
            return (f"it is {_cm(radius)} cm from the robot's motor axes; it must stay "
                    f"within {_cm(reach_min)}–{_cm(reach_max)} cm")
        x0, x1, y0, y1 = (_cm(v) for v in self._limits.region_m)
        return (f"it is at ({_cm(x)}, {_cm(y)}) cm, outside the exercise area x {x0} to "
                f"{x1} cm, y {y0} to {y1} cm")


def _cm(length_m: float) -> str:
    """A length in the words' unit, cm, to the millimetre: '-45', '37.5'."""
    return f"{round(length_m * 100.0, 1):g}"


def fault_detail(code: Fault, d: list[float], supervisor: SafetySupervisor) -> dict:
    """A fault's detail dict from the four numbers its check returned (device.safety.checks
    says which numbers each check gives)."""
    lim = supervisor.limits
    if code in (Fault.BACKEND_ERROR, Fault.BACKEND_TIMEOUT):
        exc = supervisor._error
        return {"error": (str(exc) or type(exc).__name__)[:300],
                "error_type": type(exc).__name__}
    if code == Fault.NOT_FINITE:
        return {"field": FINITE_FIELDS[int(d[0])], "value": str(d[1])}
    if code == Fault.LATE_TICK:
        late_run = int(d[2])
        if d[0] == LATE_ONE:
            return {"lateness_s": _json_number(d[1]), "limit_s": lim.late_tick_s,
                    "late_ticks": late_run,
                    "reason": f"one tick started {d[1] * 1e3:.1f} ms late "
                              f"(limit {lim.late_tick_s * 1e3:.1f} ms)"}
        return {"lateness_s": _json_number(d[1]), "limit_s": lim.period_s,
                "late_ticks": late_run,
                "reason": f"{late_run} ticks in a row started more than one period "
                          f"({lim.period_s * 1e3:.1f} ms) late"}
    if code == Fault.SENSOR_STALE:
        return {"repeats": int(d[0]), "limit": lim.stale_samples, "time_s": d[1]}
    if code == Fault.ENCODER_JUMP:
        return {"joint": int(d[0]), "change_rad": d[1], "limit_rad": d[2], "sample_dt_s": d[3]}
    if code == Fault.SENSOR_RANGE:
        axis = int(d[0])
        span = lim.sensor_normal_range_N if axis == 2 else lim.sensor_planar_range_N
        return {"axis": _AXES[axis], "force_N": d[1], "range_N": span}
    if code == Fault.FORCE_LIMIT:
        return {"force_N": d[0], "limit_N": lim.force_limit_N, "force_x_sensor_N": d[1],
                "force_y_sensor_N": d[2]}
    if code == Fault.WORKSPACE:
        return {"problem": supervisor._workspace_problem(*d), "q1_rad": d[0], "q2_rad": d[1],
                "x_m": d[2], "y_m": d[3]}
    if code == Fault.JOINT_SPEED:
        return {"joint": int(d[0]), "speed_rad_s": d[1],
                "limit_rad_s": lim.joint_speed_limit_rad_s, "source": _source(d[2])}
    if code == Fault.EE_SPEED:
        return {"speed_m_s": d[0], "limit_m_s": lim.ee_speed_limit_m_s,
                "source": _source(d[1])}
    if code == Fault.HEARTBEAT_LOST:
        age = d[0]
        return {"heartbeat_age_s": _json_number(age), "limit_s": lim.heartbeat_timeout_s,
                "heartbeat": f"last heartbeat {age:.2f} s ago"
                if math.isfinite(age) else "no heartbeat received"}
    if code == Fault.TORQUE_SATURATED:
        limit1, limit2 = supervisor.torque_limits_Nm
        return {"duration_s": d[0], "torque1_Nm": d[1], "torque2_Nm": d[2],
                "limit1_Nm": limit1, "limit2_Nm": limit2}
    return {}  # ESTOP, RECORDING_LOST: the cause is the whole story


def _constants(lim: SafetyLimits, full: list[float], reach: tuple[float, float]) -> np.ndarray:
    g = np.zeros(checks.G_SIZE)
    g[[checks.G_PERIOD, checks.G_HALF_PERIOD, checks.G_FULL1, checks.G_FULL2]] = (
        lim.period_s, 0.5 * lim.period_s, *full)
    g[[checks.G_SATURATION_S, checks.G_RAMP_S, checks.G_JOINT_SPEED, checks.G_EE_SPEED,
       checks.G_FORCE]] = (lim.saturation_time_s, lim.restart_ramp_s,
                           lim.joint_speed_limit_rad_s, lim.ee_speed_limit_m_s,
                           lim.force_limit_N)
    g[checks.G_PLANAR_SAT] = SENSOR_SATURATION_FRACTION * lim.sensor_planar_range_N
    g[checks.G_NORMAL_SAT] = SENSOR_SATURATION_FRACTION * lim.sensor_normal_range_N
    g[[checks.G_JUMP, checks.G_STALE, checks.G_LATE_TICK, checks.G_LATE_RUN,
       checks.G_HEARTBEAT]] = (lim.encoder_jump_rad, lim.stale_samples, lim.late_tick_s,
                               lim.late_run_ticks, lim.heartbeat_timeout_s)
    g[[checks.G_REACH_MIN, checks.G_REACH_MAX]] = reach
    if lim.region_m is not None:
        g[checks.G_REGION] = 1.0
        g[checks.G_X_MIN:checks.G_Y_MAX + 1] = lim.region_m
    return g


def _number(value) -> float:
    """`value` as a float, TypeError for anything that is not a number (a string, None)."""
    math.isfinite(value)
    return float(value)


def _source(flag: float) -> str:
    return "rate estimate" if flag == FROM_RATE_ESTIMATE else "encoder difference"


def _json_number(value) -> float | str:
    """A float for the event's JSON, or its name ('nan', 'inf') where strict JSON has none."""
    number = float(value)
    return number if math.isfinite(number) else str(number)
