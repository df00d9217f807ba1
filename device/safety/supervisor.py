"""The safety supervisor: the last word between the controller and the motors, every 2 ms tick.

The loop calls `SafetySupervisor.step` once per tick with what it measured and
what the controller (after the performance-based assistance) wants to command.
`step` returns the torques to write and the latched fault code:

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

The per-tick path uses plain floats and preallocated state: no numpy, no
logging, no dict or list unless a check fails (the fault's detail). Which
check wins when several fail in one tick, and why each limit has its default,
is in docs/safety.md.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError, check_positive, check_range
from core.motor import MotorParameters
from core.robot import RobotModel
from device.backend import SensorReading
from device.errors import BackendError, BackendTimeout, StateError
from device.safety.faults import Fault

_THESIS_MOTOR = MotorParameters()

THESIS_SENSOR_PLANAR_RANGE_N = 250.0
"""Table 3.1: the Nano25's horizontal (x', y') range as calibrated on the thesis robot."""
THESIS_SENSOR_NORMAL_RANGE_N = 1000.0
"""Table 3.1: the Nano25's normal (z') range."""

FORCE_CEILING_FRACTION = 0.8
"""The therapist's force limit may be raised to at most this share of the sensor's planar
range: above it a short spike between two samples can already drive the sensor into
saturation, where its reading is clipped and the limit would no longer be seen."""

SENSOR_SATURATION_FRACTION = 0.95
"""A reading beyond this share of the sensor's range on any axis is treated as saturated:
the strain gauges are at the end of their span and the other axes are no longer trusted."""

_NONE = Fault.NONE


@dataclass(frozen=True, slots=True)
class SafetyLimits:
    """The supervisor's limits, in SI units. Defaults are for the thesis robot (Table 3.1)
    and a seated adult stroke patient; docs/safety.md gives the reasoning for each.

    torque_limit_Nm, current_limit_A
        Per joint. The drive's rated motor torque 115 mN·m at K_T = 0.115 N·m/A is 1 A,
        which through the 307:16 belt is 2.21 N·m at the joint. Commands above the lower
        of the two are clamped (not a fault). Neither may exceed the drive's rating.
    saturation_time_s
        A clamp that lasts this long without a break is a fault (TORQUE_SATURATED): the
        robot has been pushing as hard as it can without getting where it wants, which
        means the patient resists (spasm, pain), something blocks the arm, or the
        controller has run away. 1 s is far longer than a corner of the D (tens of ms)
        and short enough that no one is pushed at full strength for long.
    restart_ramp_s
        The torque limit ramps from 0 to full over this time after start and after a
        clear. 0 disables the ramp.
    joint_speed_limit_rad_s
        4 rad/s: twice the fastest joint rate of the D at the fastest path the console
        allows (1.9 rad/s at 0.5 m/s); the far end of link l2 then moves at ≤ 1.24 m/s.
    ee_speed_limit_m_s
        1 m/s: twice the fastest path speed a trial may ask for (0.5 m/s). Unloaded, the
        robot at full torque reaches it in about 0.15 s (a runaway is caught within a
        few centimetres).
    force_limit_N
        50 N on the handle in the table plane: ten times the forces of the thesis's
        healthy subject (ranges of 0.8 and 2.5 N), above what the drives can push on
        the D (at most 14 N), well below the quasi-static contact limits for the hand and
        forearm in ISO/TS 15066 (140–160 N) and the sensor's 250 N range. The
        therapist may lower it for a fragile arm or raise it to `force_ceiling_N`.
    sensor_planar_range_N, sensor_normal_range_N
        The force sensor's calibrated range (Table 3.1: 250 N, 1000 N). Take them from
        the sensor's calibration file: a Nano25 calibrated SI-125-3 has half the range.
    encoder_jump_rad
        A joint-angle change between two samples that no motion could make: 0.1 rad
        (5.7°, 1222 encoder counts at the joint). At the speed limit a joint moves
        0.04 rad in the 10 ms the loop may stall, so a real movement never reaches it;
        a lost index, a counter wrap or a noisy cable does. Longer sample gaps scale
        it in proportion, so a stall is reported as a late tick, not a jump.
    stale_samples
        5 samples in a row whose time stamp did not advance (10 ms, the same age of
        data as the longest tolerated stall).
    late_tick_s, late_run_ticks
        A tick that starts more than 10 ms (5 periods) late, or 10 ticks in a row that
        each start more than one period late. A single stall below 10 ms leaves at most
        9 late ticks behind it while the loop catches up (with up to 1 ms of compute),
        so the run rule only trips on a loop that keeps losing time.
    heartbeat_timeout_s
        0.5 s without a heartbeat from the console window: the GUI has died or hung,
        and no one can see the banner or press its stop button.
    workspace_margin_m
        The handle must stay this far inside the robot's reach ring (radially), so it
        stops before the parallelogram folds flat at the 15°/165° spread limits.
    region_m
        Optional (x_min, x_max, y_min, y_max) box for the handle, in the global frame.
        `around_path` builds it from the exercise's path with a margin.
    """

    period_s: float = 0.002
    torque_limit_Nm: float = _THESIS_MOTOR.max_joint_torque_Nm
    current_limit_A: float = _THESIS_MOTOR.max_current_A
    saturation_time_s: float = 1.0
    restart_ramp_s: float = 0.5
    joint_speed_limit_rad_s: float = 4.0
    ee_speed_limit_m_s: float = 1.0
    force_limit_N: float = 50.0
    sensor_planar_range_N: float = THESIS_SENSOR_PLANAR_RANGE_N
    sensor_normal_range_N: float = THESIS_SENSOR_NORMAL_RANGE_N
    encoder_jump_rad: float = 0.1
    stale_samples: int = 5
    late_tick_s: float = 0.010
    late_run_ticks: int = 10
    heartbeat_timeout_s: float = 0.5
    workspace_margin_m: float = 0.02
    region_m: tuple[float, float, float, float] | None = None

    def __post_init__(self) -> None:
        check_range("period_s", self.period_s, 0.0, 0.1, "s",
                    "the supervisor runs once per control tick", low_open=True)
        check_positive("torque_limit_Nm", self.torque_limit_Nm, "N·m",
                       "the drive's limit; checked against the robot's drives when used")
        check_positive("current_limit_A", self.current_limit_A, "A",
                       "the motor current limit; checked against the drives when used")
        check_range("saturation_time_s", self.saturation_time_s, 0.1, 10.0, "s",
                    "long enough for a corner of the path, short enough that no one is "
                    "pushed at full strength for long")
        check_range("restart_ramp_s", self.restart_ramp_s, 0.0, 5.0, "s",
                    "0 disables the ramp; longer ramps only delay the exercise")
        check_range("joint_speed_limit_rad_s", self.joint_speed_limit_rad_s, 0.0, 20.0,
                    "rad/s", "faster joints belong to a runaway, not to an exercise",
                    low_open=True)
        check_range("ee_speed_limit_m_s", self.ee_speed_limit_m_s, 0.0, 2.0, "m/s",
                    "2 m/s is beyond a healthy adult's fast reach", low_open=True)
        check_positive("sensor_planar_range_N", self.sensor_planar_range_N, "N")
        check_positive("sensor_normal_range_N", self.sensor_normal_range_N, "N")
        ceiling = self.force_ceiling_N
        check_range("force_limit_N", self.force_limit_N, 0.0, ceiling, "N",
                    f"at most {FORCE_CEILING_FRACTION:.0%} of the force sensor's "
                    f"{self.sensor_planar_range_N:g} N range, where its reading is still "
                    "trustworthy", low_open=True)
        lowest_jump = self.joint_speed_limit_rad_s * self.late_tick_s
        check_range("encoder_jump_rad", self.encoder_jump_rad, lowest_jump, 1.0, "rad",
                    f"above what a joint at the speed limit moves in a tolerated stall "
                    f"({self.joint_speed_limit_rad_s:g} rad/s × {self.late_tick_s:g} s), "
                    "so a real movement never looks like a jump", low_open=True)
        _check_int("stale_samples", self.stale_samples, 1, 50,
                   "samples in a row with the same time stamp before the data is stale")
        check_range("late_tick_s", self.late_tick_s, self.period_s, 0.1, "s",
                    "longer than one period, and short enough that the handle cannot move "
                    "far unobserved", low_open=True)
        _check_int("late_run_ticks", self.late_run_ticks, 2, 100,
                   "one late tick is already covered by late_tick_s")
        check_range("heartbeat_timeout_s", self.heartbeat_timeout_s, 0.05, 5.0, "s",
                    "the console's heartbeat comes every few tens of ms; after a few "
                    "seconds no one would be watching the patient")
        check_range("workspace_margin_m", self.workspace_margin_m, 0.0, 0.1, "m",
                    "radial margin inside the robot's reach")
        if self.region_m is not None:
            _check_region(self.region_m)

    @property
    def force_ceiling_N(self) -> float:
        """The highest force limit allowed: 200 N for the thesis's 250 N sensor."""
        return FORCE_CEILING_FRACTION * self.sensor_planar_range_N

    def replace(self, **changes) -> SafetyLimits:
        return dataclasses.replace(self, **changes)

    def for_sensor(self, planar_range_N: float, normal_range_N: float,
                   source: str = "the force sensor's calibration") -> SafetyLimits:
        """These limits with the sensor's rated ranges (from its calibration file, say).
        Refused by name when the force limit is above the new ceiling, so a therapist's
        limit is never above what the sensor can still measure."""
        planar = check_positive("sensor_planar_range_N", planar_range_N, "N", source)
        normal = check_positive("sensor_normal_range_N", normal_range_N, "N", source)
        ceiling = FORCE_CEILING_FRACTION * planar
        if self.force_limit_N > ceiling:
            raise ParameterError(
                "force_limit_N", self.force_limit_N,
                f"at most {ceiling:g} N ({FORCE_CEILING_FRACTION:.0%} of the sensor's range)",
                f"{source} rates the sensor for {planar:g} N in the plane; lower the force "
                "limit in the Parameters tab, or fit a sensor with a larger range",
            )
        return dataclasses.replace(self, sensor_planar_range_N=planar,
                                   sensor_normal_range_N=normal)

    def around_path(self, points_m, margin_m: float = 0.10) -> SafetyLimits:
        """These limits with `region_m` the bounding box of the path's points plus a margin.

        0.10 m lets the patient stray a hand's width from the path without a fault,
        and stops the handle long before it reaches the patient's body or the table's
        edge if the exercise runs away.
        """
        check_range("margin_m", margin_m, 0.02, 0.5, "m",
                    "room to stray from the path without a fault")
        points = np.asarray(points_m, dtype=float)
        if points.ndim != 2 or points.shape[1] != 2 or points.shape[0] == 0:
            raise ParameterError("points_m", f"an array of shape {points.shape}",
                                 "shape (N, 2), N ≥ 1")
        if not np.isfinite(points).all():
            raise ParameterError("points_m", "a non-finite point", "finite positions in m")
        low = points.min(axis=0) - margin_m
        high = points.max(axis=0) + margin_m
        region = (float(low[0]), float(high[0]), float(low[1]), float(high[1]))
        return dataclasses.replace(self, region_m=region)


class SafetySupervisor:
    """Checks every tick, clamps the torque, latches faults until cleared.

    Create one per connection to the robot: an ENCODER_JUMP can only be left by
    reconnecting (the angles may be offset since), which means a new supervisor.
    """

    __slots__ = (
        "_condition",
        "_condition_detail",
        "_ee_speed_limit",
        "_fault",
        "_fault_detail",
        "_fault_time_s",
        "_full1",
        "_full2",
        "_half_period",
        "_late_run",
        "_limits",
        "_prev_q1",
        "_prev_q2",
        "_prev_t",
        "_prev_valid",
        "_prev_x",
        "_prev_y",
        "_ramp_since_s",
        "_reach_max",
        "_reach_min",
        "_region",
        "_robot",
        "_sat_since_s",
        "_stale_run",
    )

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
        self._full1, self._full2 = full
        self._reach_min = self._robot.reach_min_m + lim.workspace_margin_m
        self._reach_max = self._robot.reach_max_m - lim.workspace_margin_m
        if self._reach_min >= self._reach_max:
            raise ParameterError(
                "workspace_margin_m", lim.workspace_margin_m,
                f"< {(self._robot.reach_max_m - self._robot.reach_min_m) / 2:g} m",
                "the margin would leave no room inside the robot's reach",
            )
        self._region = lim.region_m
        self._ee_speed_limit = lim.ee_speed_limit_m_s
        self._half_period = 0.5 * lim.period_s
        self._fault = _NONE
        self._fault_time_s = math.nan
        self._fault_detail: dict = {}
        self._condition = _NONE
        self._condition_detail: dict = {}
        self._late_run = 0
        self._stale_run = 0
        self._prev_valid = False
        self._prev_t = self._prev_q1 = self._prev_q2 = self._prev_x = self._prev_y = 0.0
        self._sat_since_s = math.nan
        self._ramp_since_s = math.nan

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
        return (self._full1, self._full2)

    @property
    def reach_band_m(self) -> tuple[float, float]:
        """Distances from the motor axes the handle must stay within (the reach ring less
        the workspace margin)."""
        return (self._reach_min, self._reach_max)

    @property
    def fault(self) -> Fault:
        """The latched fault, Fault.NONE when the torque is allowed through."""
        return self._fault

    @property
    def fault_time_s(self) -> float:
        """Loop time of the tick that latched the fault; NaN when none."""
        return self._fault_time_s

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
        return self._fault.banner(self._fault_detail)

    @property
    def condition(self) -> Fault:
        """What the last tick found, latched or not: Fault.NONE when every check passed."""
        return self._condition

    def clear_refusal(self) -> str:
        """Why `clear` would be refused now, or '' when it would succeed."""
        if self._fault is _NONE:
            return ""
        if not self._fault.clearable:
            return (f"This fault cannot be cleared: {self.fault_message}. "
                    "Reconnect the robot to start again.")
        if self._condition is not _NONE:
            return ("The fault cannot be cleared while its cause is present: "
                    f"{self._condition.banner(self._condition_detail)}.")
        return ""

    def clear(self) -> None:
        """Release the latched fault; the torque then ramps up from zero.

        Raises StateError (with the reason) while the cause is still present as of
        the last tick (e-stop held, force still over its limit, handle still outside
        its region, …) or for a fault that needs a reconnection. Clearing with no
        fault latched does nothing. The loop should also reset the controller's
        integrators, which have been running against zero torque.
        """
        if self._fault is _NONE:
            return
        reason = self.clear_refusal()
        if reason:
            raise StateError(reason)
        self._fault = _NONE
        self._fault_time_s = math.nan
        self._fault_detail = {}
        self._sat_since_s = math.nan
        self._ramp_since_s = math.nan

    _HISTORY = ("_prev_valid", "_prev_t", "_prev_q1", "_prev_q2", "_prev_x", "_prev_y",
                "_stale_run", "_sat_since_s", "_ramp_since_s", "_late_run")

    def history(self) -> tuple:
        """What `step` carries from tick to tick while no fault is latched (previous
        sample, stale and late counts, saturation and ramp start times), in the order
        of device.compiled.guard's state, for the compiled tick to take over."""
        return tuple(getattr(self, name) for name in self._HISTORY)

    def restore_history(self, values) -> None:
        """Take back the history the compiled tick carried on (see `history`). The
        condition of the last tick is then 'no fault': the compiled tick only runs
        ticks on which every check passed."""
        prev_valid, *floats, stale, sat, ramp, late = values
        self._prev_valid = bool(prev_valid)
        self._prev_t, self._prev_q1, self._prev_q2, self._prev_x, self._prev_y = (
            float(v) for v in floats)
        self._stale_run = int(stale)
        self._sat_since_s = float(sat)
        self._ramp_since_s = float(ramp)
        self._late_run = int(late)
        self._condition = _NONE

    def restart_ramp(self) -> None:
        """Ramp the torque limit up from zero again, as after a clear: the loop calls it
        when a trial starts, after ticks spent connected at zero torque."""
        self._ramp_since_s = math.nan

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
    ) -> tuple[float, float, Fault]:
        """One tick: check everything, return (torque1_Nm, torque2_Nm, fault) to write.

        now_s: loop time. reading: this tick's SensorReading, or the exception the
        backend's read raised. rate*_rad_s: the loop's joint-rate estimate.
        torque*_Nm: the command after the assistance. lateness_s: how late this tick
        started. heartbeat_age_s: time since the console's last heartbeat (inf if
        none yet). estop: the e-stop is held (a level, not an edge). recording_lost:
        the recorder is behind by more than the ring holds.
        """
        lim = self._limits
        isfinite = math.isfinite
        code = _NONE
        detail = None

        if lateness_s > lim.period_s:
            self._late_run += 1
        else:
            self._late_run = 0

        exc = reading if isinstance(reading, BaseException) else None
        bad_field = None
        bad_value = 0.0
        if exc is None:
            try:
                t, q1, q2, fx, fy, fz = reading
                finite = (isfinite(now_s) and isfinite(t) and isfinite(q1) and isfinite(q2)
                          and isfinite(fx) and isfinite(fy) and isfinite(fz)
                          and isfinite(rate1_rad_s) and isfinite(rate2_rad_s)
                          and isfinite(torque1_Nm) and isfinite(torque2_Nm))
            except (TypeError, ValueError):
                # Not a reading of numbers: a bug upstream, handled like a failed read.
                exc = BackendError(f"the loop passed {reading!r:.100} as the sensor reading")
            else:
                if not finite:
                    bad_field, bad_value = _first_not_finite(
                        now_s=now_s, time_s=t, q1_rad=q1, q2_rad=q2,
                        force_x_N=fx, force_y_N=fy, force_z_N=fz,
                        rate1_rad_s=rate1_rad_s, rate2_rad_s=rate2_rad_s,
                        torque1_Nm=torque1_Nm, torque2_Nm=torque2_Nm,
                    )

        # Sample history: kept up to date whatever the outcome, so the checks are sound
        # again on the tick after a clear.
        jump_joint = 0
        jump_change = jump_limit = sample_dt = 0.0
        diff_rate1 = diff_rate2 = diff_speed = 0.0
        x = y = 0.0
        if exc is None and bad_field is None:
            x, y = self._robot.position(q1, q2)
            if not self._prev_valid:
                self._set_prev(t, q1, q2, x, y)
                self._stale_run = 0
            else:
                sample_dt = t - self._prev_t
                if sample_dt <= 0.0:
                    self._stale_run += 1
                else:
                    self._stale_run = 0
                    dq1 = q1 - self._prev_q1
                    dq2 = q2 - self._prev_q2
                    jump_limit = lim.encoder_jump_rad * max(1.0, sample_dt / lim.late_tick_s)
                    if abs(dq1) > jump_limit:
                        jump_joint, jump_change = 1, dq1
                    elif abs(dq2) > jump_limit:
                        jump_joint, jump_change = 2, dq2
                    # Samples closer than half a period would turn one encoder count
                    # into a large rate: difference over a longer span instead.
                    if sample_dt >= self._half_period or jump_joint:
                        diff_rate1 = dq1 / sample_dt
                        diff_rate2 = dq2 / sample_dt
                        diff_speed = math.hypot(x - self._prev_x, y - self._prev_y) / sample_dt
                        self._set_prev(t, q1, q2, x, y)
        else:
            self._prev_valid = False
            self._stale_run = 0

        # Timed only while the torque is applied: the faulted return below resets it, so
        # a controller winding up against zero torque does not count.
        if abs(torque1_Nm) > self._full1 or abs(torque2_Nm) > self._full2:
            if math.isnan(self._sat_since_s):
                self._sat_since_s = now_s
        else:
            self._sat_since_s = math.nan

        # The checks, most informative cause first (docs/safety.md, "Which fault wins").
        if estop:
            code, detail = Fault.ESTOP, {}
        elif exc is not None:
            code = Fault.BACKEND_TIMEOUT if isinstance(exc, BackendTimeout) else Fault.BACKEND_ERROR
            detail = {"error": (str(exc) or type(exc).__name__)[:300],
                      "error_type": type(exc).__name__}
        elif bad_field is not None:
            code, detail = Fault.NOT_FINITE, {"field": bad_field, "value": str(bad_value)}
        elif not lateness_s <= lim.late_tick_s:
            code = Fault.LATE_TICK
            detail = {
                "lateness_s": _json_number(lateness_s), "limit_s": lim.late_tick_s,
                "late_ticks": self._late_run,
                "reason": f"one tick started {lateness_s * 1e3:.1f} ms late "
                          f"(limit {lim.late_tick_s * 1e3:.1f} ms)",
            }
        elif self._late_run >= lim.late_run_ticks:
            code = Fault.LATE_TICK
            detail = {
                "lateness_s": _json_number(lateness_s), "limit_s": lim.period_s,
                "late_ticks": self._late_run,
                "reason": f"{self._late_run} ticks in a row started more than one period "
                          f"({lim.period_s * 1e3:.1f} ms) late",
            }
        elif self._stale_run >= lim.stale_samples:
            code = Fault.SENSOR_STALE
            detail = {"repeats": self._stale_run, "limit": lim.stale_samples, "time_s": t}
        elif jump_joint:
            code = Fault.ENCODER_JUMP
            detail = {"joint": jump_joint, "change_rad": abs(jump_change),
                      "limit_rad": jump_limit, "sample_dt_s": sample_dt}
        elif (abs(fx) > SENSOR_SATURATION_FRACTION * lim.sensor_planar_range_N
              or abs(fy) > SENSOR_SATURATION_FRACTION * lim.sensor_planar_range_N
              or abs(fz) > SENSOR_SATURATION_FRACTION * lim.sensor_normal_range_N):
            code, detail = Fault.SENSOR_RANGE, _saturation_detail(lim, fx, fy, fz)
        elif math.hypot(fx, fy) > lim.force_limit_N:
            # The planar magnitude is the same in the sensor's frame and the global one,
            # so no rotation is needed to compare it.
            code = Fault.FORCE_LIMIT
            detail = {"force_N": math.hypot(fx, fy), "limit_N": lim.force_limit_N,
                      "force_x_sensor_N": fx, "force_y_sensor_N": fy}
        elif (problem := self._workspace_problem(q1, q2, x, y)):
            code = Fault.WORKSPACE
            detail = {"problem": problem, "q1_rad": q1, "q2_rad": q2, "x_m": x, "y_m": y}
        elif (joint := _over(rate1_rad_s, rate2_rad_s, lim.joint_speed_limit_rad_s)):
            code = Fault.JOINT_SPEED
            speed = abs(rate1_rad_s if joint == 1 else rate2_rad_s)
            detail = {"joint": joint, "speed_rad_s": speed,
                      "limit_rad_s": lim.joint_speed_limit_rad_s, "source": "rate estimate"}
        elif (joint := _over(diff_rate1, diff_rate2, lim.joint_speed_limit_rad_s)):
            code = Fault.JOINT_SPEED
            speed = abs(diff_rate1 if joint == 1 else diff_rate2)
            detail = {"joint": joint, "speed_rad_s": speed,
                      "limit_rad_s": lim.joint_speed_limit_rad_s,
                      "source": "encoder difference"}
        elif (speed := self._ee_speed(q1, q2, rate1_rad_s, rate2_rad_s)) > self._ee_speed_limit:
            code = Fault.EE_SPEED
            detail = {"speed_m_s": speed, "limit_m_s": self._ee_speed_limit,
                      "source": "rate estimate"}
        elif diff_speed > self._ee_speed_limit:
            code = Fault.EE_SPEED
            detail = {"speed_m_s": diff_speed, "limit_m_s": self._ee_speed_limit,
                      "source": "encoder difference"}
        elif not heartbeat_age_s <= lim.heartbeat_timeout_s:
            code = Fault.HEARTBEAT_LOST
            detail = {"heartbeat_age_s": _json_number(heartbeat_age_s),
                      "limit_s": lim.heartbeat_timeout_s,
                      "heartbeat": f"last heartbeat {heartbeat_age_s:.2f} s ago"
                      if math.isfinite(heartbeat_age_s) else "no heartbeat received"}
        elif recording_lost:
            code, detail = Fault.RECORDING_LOST, {}
        elif now_s - self._sat_since_s >= lim.saturation_time_s:
            code = Fault.TORQUE_SATURATED
            detail = {"duration_s": now_s - self._sat_since_s,
                      "torque1_Nm": torque1_Nm, "torque2_Nm": torque2_Nm,
                      "limit1_Nm": self._full1, "limit2_Nm": self._full2}

        if code is _NONE:
            self._condition = _NONE
        else:
            detail["fault"] = code.label
            detail["code"] = int(code)
            self._condition = code
            self._condition_detail = detail
            if self._fault is _NONE:
                self._fault = code
                self._fault_time_s = now_s
                self._fault_detail = detail
        if self._fault is not _NONE:
            self._sat_since_s = math.nan
            return (0.0, 0.0, self._fault)

        limit1, limit2 = self._full1, self._full2
        if lim.restart_ramp_s > 0.0:
            if math.isnan(self._ramp_since_s):
                self._ramp_since_s = now_s
            share = (now_s - self._ramp_since_s) / lim.restart_ramp_s
            if share < 1.0:
                share = max(share, 0.0)
                limit1 *= share
                limit2 *= share
        # One factor for both joints keeps the direction of the force on the hand.
        scale = 1.0
        size1, size2 = abs(torque1_Nm), abs(torque2_Nm)
        if size1 > limit1:
            scale = limit1 / size1
        if size2 * scale > limit2:
            scale = limit2 / size2
        out1 = max(-limit1, min(limit1, torque1_Nm * scale))
        out2 = max(-limit2, min(limit2, torque2_Nm * scale))
        return (out1, out2, _NONE)

    # ---------------------------------------------------------------- helpers
    def _set_prev(self, t: float, q1: float, q2: float, x: float, y: float) -> None:
        self._prev_valid = True
        self._prev_t, self._prev_q1, self._prev_q2 = t, q1, q2
        self._prev_x, self._prev_y = x, y

    def _workspace_problem(self, q1: float, q2: float, x: float, y: float) -> str:
        problem = self._robot.limit_problem(q1, q2)
        if problem:
            return problem
        radius = math.hypot(x, y)
        if not self._reach_min <= radius <= self._reach_max:
            return (f"the handle is {radius:.3f} m from the robot's motor axes; it must stay "
                    f"within {self._reach_min:.3f}–{self._reach_max:.3f} m")
        region = self._region
        if region is not None and not (region[0] <= x <= region[1] and region[2] <= y <= region[3]):
            return (f"the handle at ({x:.3f}, {y:.3f}) m is outside the exercise area "
                    f"x {region[0]:.3f}…{region[1]:.3f} m, y {region[2]:.3f}…{region[3]:.3f} m")
        return ""

    def _ee_speed(self, q1: float, q2: float, rate1: float, rate2: float) -> float:
        j11, j12, j21, j22 = self._robot.jacobian_terms(q1, q2)
        return math.hypot(j11 * rate1 + j12 * rate2, j21 * rate1 + j22 * rate2)


def _over(value1: float, value2: float, limit: float) -> int:
    """1 or 2: the first of two joints over the limit; 0 if neither."""
    if abs(value1) > limit:
        return 1
    if abs(value2) > limit:
        return 2
    return 0


def _json_number(value) -> float | str:
    """A float for the event's JSON, or its name ('nan', 'inf') where strict JSON has none."""
    number = float(value)
    return number if math.isfinite(number) else str(number)


def _first_not_finite(**values: float) -> tuple[str, float]:
    for name, value in values.items():
        if not math.isfinite(value):
            return name, value
    return "", 0.0


def _saturation_detail(lim: SafetyLimits, fx: float, fy: float, fz: float) -> dict:
    planar = SENSOR_SATURATION_FRACTION * lim.sensor_planar_range_N
    if abs(fx) > planar:
        return {"axis": "x'", "force_N": fx, "range_N": lim.sensor_planar_range_N}
    if abs(fy) > planar:
        return {"axis": "y'", "force_N": fy, "range_N": lim.sensor_planar_range_N}
    return {"axis": "z'", "force_N": fz, "range_N": lim.sensor_normal_range_N}


def _check_int(field: str, value, low: int, high: int, why: str) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ParameterError(field, value, f"a whole number in [{low}, {high}]", why)


def _check_region(region) -> None:
    try:
        x_min, x_max, y_min, y_max = (float(v) for v in region)
    except (TypeError, ValueError):
        raise ParameterError("region_m", region, "(x_min, x_max, y_min, y_max) in m") from None
    for name, value in (("x_min", x_min), ("x_max", x_max), ("y_min", y_min), ("y_max", y_max)):
        check_range(f"region_m.{name}", value, -1.5, 1.5, "m",
                    "the robot's table lies well inside ±1.5 m")
    if not (x_min < x_max and y_min < y_max):
        raise ParameterError("region_m", region, "x_min < x_max and y_min < y_max",
                             "the box must have an inside")
