"""The safety supervisor's limits, in SI units, each with the reason for its default.

`SafetyLimits` is what a trial's Build carries (the therapist may lower the force limit,
say); the supervisor (device.safety.supervisor) checks every tick against it, and
docs/safety.md gives the hazard behind each limit.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError, check_positive, check_range
from core.motor import MotorParameters
from core.robot import WORKSPACE_MARGIN_M

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
    workspace_margin_m: float = WORKSPACE_MARGIN_M
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
