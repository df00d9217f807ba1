"""The safety supervisor: every check trips on its cause and not on a rehabilitation exercise,
the torque is zero in the tick a fault is found, faults latch until cleared, and the clamp
keeps the torque within the drive's limit whatever comes in."""

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, strategies as st

from core.errors import ParameterError
from core.motor import MotorParameters
from core.robot import RobotModel
from core.trajectory import Trajectory, d_shape
from device.backend import SensorReading
from device.errors import BackendError, BackendTimeout, SensorRangeError, StateError
from device.safety.faults import Fault
from device.safety.limits import SafetyLimits
from device.safety.supervisor import SafetySupervisor

ROBOT = RobotModel()
PERIOD = 0.002
DRIVE_NM = 0.115 * 307 / 16  # Table 3.1: 1 A rated current through the 307:16 belt
SAFETY_MD = Path(__file__).resolve().parents[2] / "docs" / "safety.md"

# A comfortable pose in the middle of the thesis's D: links 90° apart.
HOME_Q1 = math.radians(170.0)
HOME_Q2 = math.radians(80.0)


def at_rest(t, q1=HOME_Q1, q2=HOME_Q2, fx=1.0, fy=-2.0, fz=8.0):
    return SensorReading(t, q1, q2, fx, fy, fz)


class Tick:
    """Drives a supervisor one 2 ms tick at a time with an at-rest, healthy default."""

    def __init__(self, supervisor, t0=0.0):
        self.sup = supervisor
        self.t = t0
        self.q1, self.q2 = HOME_Q1, HOME_Q2

    def __call__(self, reading=None, rates=(0.0, 0.0), torques=(1.0, -0.5), lateness=0.0002,
                 heartbeat=0.02, estop=False, lost=False, advance=True):
        if advance:
            self.t += PERIOD
        if reading is None:
            reading = at_rest(self.t, self.q1, self.q2)
        elif isinstance(reading, SensorReading) and math.isfinite(reading.q1_rad + reading.q2_rad):
            self.q1, self.q2 = reading.q1_rad, reading.q2_rad
        return self.sup.step(self.t, reading, rates[0], rates[1], torques[0], torques[1],
                             lateness, heartbeat, estop, lost)

    def warm(self, n=300):
        """Past the restart ramp (0.5 s), with nothing wrong."""
        for _ in range(n):
            out = self()
        assert out == (1.0, -0.5, Fault.NONE)
        return self


def warm_supervisor(limits=None, q=(HOME_Q1, HOME_Q2)):
    tick = Tick(SafetySupervisor(ROBOT, limits))
    tick.q1, tick.q2 = q
    return tick.warm()


def banner_is_filled(sup):
    message = sup.fault_message
    assert "{" not in message, message
    assert "?" not in message, message
    return message


# ------------------------------------------------------------------ fault codes
def test_fault_codes_are_stable_and_fit_the_u2_channel():
    pinned = {
        "NONE": 0, "ESTOP": 1, "HEARTBEAT_LOST": 2, "BACKEND_ERROR": 3, "BACKEND_TIMEOUT": 4,
        "SENSOR_STALE": 5, "ENCODER_JUMP": 6, "NOT_FINITE": 7, "SENSOR_RANGE": 8,
        "FORCE_LIMIT": 9, "JOINT_SPEED": 10, "EE_SPEED": 11, "WORKSPACE": 12, "LATE_TICK": 13,
        "RECORDING_LOST": 14, "TORQUE_SATURATED": 15,
    }
    assert {f.name: int(f) for f in Fault} == pinned
    assert all(0 <= f <= np.iinfo(np.uint16).max for f in Fault)
    assert np.array(list(Fault), dtype="u2").tolist() == list(pinned.values())


def test_every_fault_has_a_cause_an_action_and_a_row_in_safety_md():
    doc = SAFETY_MD.read_text(encoding="utf-8")
    for fault in Fault:
        if fault is Fault.NONE:
            continue
        assert fault.text.cause, fault
        assert fault.text.action, fault
        assert f"| {int(fault)} |" in doc, fault
        assert f"`{fault.name}`" in doc, fault
        # a banner never shows template braces, even without its values
        assert "{" not in fault.banner({})


def test_a_banner_shows_its_values_and_survives_bad_ones():
    assert Fault.FORCE_LIMIT.banner({"force_N": 63.2, "limit_N": 50.0}) == (
        "Force on the handle reached 63 N (limit 50 N) — check the patient, then clear the fault"
    )
    assert Fault.FORCE_LIMIT.banner({"force_N": "lots"}).startswith(
        "Force on the handle reached ? N (limit ? N) — ")
    assert Fault.NONE.banner() == "No fault"


# ------------------------------------------------------------------ limits
def test_default_limits_are_the_thesis_drive_and_documented_values():
    limits = SafetyLimits()
    assert limits.torque_limit_Nm == pytest.approx(DRIVE_NM)
    assert limits.torque_limit_Nm == pytest.approx(2.2066, abs=1e-4)
    assert limits.current_limit_A == pytest.approx(1.0)
    assert limits.force_limit_N == 50.0
    assert limits.force_ceiling_N == pytest.approx(200.0)
    assert limits.heartbeat_timeout_s == 0.5
    assert limits.late_tick_s == 0.010
    sup = SafetySupervisor()
    assert sup.torque_limits_Nm == pytest.approx((DRIVE_NM, DRIVE_NM))


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"force_limit_N": 201.0}, "force_limit_N"),
        ({"force_limit_N": 0.0}, "force_limit_N"),
        ({"force_limit_N": math.nan}, "force_limit_N"),
        ({"heartbeat_timeout_s": 10.0}, "heartbeat_timeout_s"),
        ({"late_tick_s": 0.001}, "late_tick_s"),
        ({"stale_samples": 0}, "stale_samples"),
        ({"stale_samples": 2.5}, "stale_samples"),
        ({"late_run_ticks": True}, "late_run_ticks"),
        ({"encoder_jump_rad": 0.03}, "encoder_jump_rad"),
        ({"joint_speed_limit_rad_s": -1.0}, "joint_speed_limit_rad_s"),
        ({"ee_speed_limit_m_s": math.inf}, "ee_speed_limit_m_s"),
        ({"torque_limit_Nm": 0.0}, "torque_limit_Nm"),
        ({"region_m": (0.1, -0.1, 0.0, 0.5)}, "region_m"),
        ({"region_m": (0.1, 0.2, 0.0)}, "region_m"),
    ],
)
def test_bad_limits_are_refused_naming_the_field(change, field):
    with pytest.raises(ParameterError) as err:
        SafetyLimits(**change)
    assert err.value.field == field
    assert "allowed" in str(err.value)


def test_the_force_limit_explains_its_ceiling_from_the_sensor_range():
    with pytest.raises(ParameterError, match=r"250 N range"):
        SafetyLimits(force_limit_N=220.0)
    # a sensor calibrated for half the range halves the ceiling
    assert SafetyLimits(sensor_planar_range_N=125.0).force_ceiling_N == pytest.approx(100.0)
    with pytest.raises(ParameterError):
        SafetyLimits(sensor_planar_range_N=125.0, force_limit_N=120.0)


def test_the_encoder_jump_must_exceed_a_real_movement_in_a_tolerated_stall():
    with pytest.raises(ParameterError, match=r"speed limit"):
        SafetyLimits(joint_speed_limit_rad_s=12.0)  # 12 rad/s × 10 ms > 0.1 rad


def test_limits_above_the_drive_rating_are_refused():
    with pytest.raises(ParameterError, match=r"rated") as err:
        SafetySupervisor(ROBOT, SafetyLimits(torque_limit_Nm=3.0))
    assert err.value.field == "torque_limit_Nm"
    with pytest.raises(ParameterError) as err:
        SafetySupervisor(ROBOT, SafetyLimits(current_limit_A=1.5))
    assert err.value.field == "current_limit_A"
    strong = dataclasses.replace(ROBOT, motors=(MotorParameters(peak_factor=2.0),) * 2)
    sup = SafetySupervisor(strong, SafetyLimits(torque_limit_Nm=4.0, current_limit_A=2.0))
    assert sup.torque_limits_Nm == pytest.approx((4.0, 4.0))


def test_a_workspace_margin_that_leaves_no_room_is_refused():
    small = dataclasses.replace(ROBOT, l2_m=0.10, l3_m=0.10, l4_m=0.11)  # reach 0.03–0.21 m
    with pytest.raises(ParameterError) as err:
        SafetySupervisor(small, SafetyLimits(workspace_margin_m=0.1))
    assert err.value.field == "workspace_margin_m"


def test_around_path_boxes_the_path_with_its_margin():
    points = d_shape((-0.30, 0.30), 0.10).points()
    limits = SafetyLimits().around_path(points, margin_m=0.05)
    assert limits.region_m == pytest.approx((-0.35, -0.15, 0.15, 0.45), abs=1e-9)
    with pytest.raises(ParameterError):
        SafetyLimits().around_path([[0.0, math.nan]])
    with pytest.raises(ParameterError):
        SafetyLimits().around_path(points, margin_m=0.0)


# ------------------------------------------------------------ normal exercise
def exercise_ticks(duration_s, timing="constant_speed", repetitions=3, seed=1):
    """Ticks of a patient walking the thesis's D: quantised encoders, a noisy rate
    estimate, ±5 N of hand force with 1/24 N resolution, the arm's weight on the
    handle, a controller's torque (the model's inverse dynamics and some feedback),
    loop jitter with a few stalls, a 10 Hz heartbeat."""
    rng = np.random.default_rng(seed)
    trajectory = Trajectory(d_shape((-0.30, 0.30), 0.10), duration_s, repetitions, timing)
    t = np.arange(0.0, trajectory.total_duration_s, PERIOD)
    q, qd, qdd = trajectory.joint_reference(ROBOT, t)
    motor = ROBOT.motors[0]
    q_meas = np.round(q / motor.joint_angle_resolution_rad) * motor.joint_angle_resolution_rad
    phase = 2 * math.pi * t / duration_s
    force = np.column_stack((5.0 * np.sin(phase), 5.0 * np.cos(3 * phase), 12 + np.sin(phase)))
    force += rng.normal(0.0, 0.1, force.shape)
    force = np.round(force * 24.0) / 24.0
    rates = qd + rng.normal(0.0, 0.02, qd.shape)
    torque = np.column_stack(ROBOT.inverse_dynamics_terms(
        q[:, 0], q[:, 1], qd[:, 0], qd[:, 1], qdd[:, 0], qdd[:, 1]))
    torque += 0.3 * np.sin(np.column_stack((phase, 2 * phase)))  # feedback on top
    lateness = rng.exponential(0.0002, t.size)
    for k in range(150, t.size - 5, 400):  # a 6 ms stall, then the catch-up
        lateness[k:k + 4] = (0.006, 0.0043, 0.0026, 0.0009)
    heartbeat = (t % 0.1) + 0.003
    return t, q_meas, force, rates, torque, lateness, heartbeat


def run_exercise(sup, ticks):
    t, q, force, rates, torque, lateness, heartbeat = ticks
    applied = np.empty_like(torque)
    for k in range(t.size):
        reading = SensorReading(t[k], q[k, 0], q[k, 1], *force[k])
        out1, out2, fault = sup.step(t[k], reading, rates[k, 0], rates[k, 1],
                                     torque[k, 0], torque[k, 1], lateness[k], heartbeat[k],
                                     False, False)
        assert fault is Fault.NONE, (t[k], sup.condition, sup.fault_message)
        applied[k] = (out1, out2)
    return applied


@pytest.mark.parametrize(
    ("duration_s", "timing"),
    [(4.0, "constant_speed"), (2.06, "constant_speed"), (1.03, "constant_speed"),
     (2.06, "minimum_jerk")],
    ids=["0.13 m/s (thesis)", "0.25 m/s", "0.5 m/s (fastest trial)", "0.48 m/s peak"],
)
def test_no_fault_along_a_rehabilitation_path(duration_s, timing):
    ticks = exercise_ticks(duration_s, timing)
    t, torque = ticks[0], ticks[4]
    assert np.abs(torque).max() < DRIVE_NM  # these exercises never need the clamp
    sup = SafetySupervisor(ROBOT)
    applied = run_exercise(sup, ticks)
    after_ramp = t >= SafetyLimits().restart_ramp_s
    np.testing.assert_array_equal(applied[after_ramp], torque[after_ramp])
    assert sup.condition is Fault.NONE
    assert math.isnan(sup.fault_time_s)
    assert sup.fault_detail == {}
    assert sup.fault_message == "No fault"


def test_an_exercise_beyond_the_drive_is_clamped_in_bursts_without_a_fault():
    # The minimum-jerk D in 1.03 s (0.5 m/s mean) asks up to 5.8 N·m of joint 2 while
    # it starts and stops each segment: more than the 2.21 N·m drive, in bursts of at
    # most 0.14 s, far shorter than the saturation time.
    ticks = exercise_ticks(1.03, "minimum_jerk")
    t, torque = ticks[0], ticks[4]
    over = np.abs(torque).max(axis=1) > DRIVE_NM
    assert over.mean() > 0.2
    applied = run_exercise(SafetySupervisor(ROBOT), ticks)
    assert np.abs(applied).max() <= DRIVE_NM
    np.testing.assert_array_equal(np.sign(applied[t > 0.5]), np.sign(torque[t > 0.5]))


def test_the_path_stays_inside_its_own_exercise_area():
    path = d_shape((-0.30, 0.30), 0.10)
    limits = SafetyLimits().around_path(path.points())
    t, q, force, rates, torque, lateness, heartbeat = exercise_ticks(2.06, repetitions=1)
    sup = SafetySupervisor(ROBOT, limits)
    for k in range(t.size):
        reading = SensorReading(t[k], q[k, 0], q[k, 1], *force[k])
        fault = sup.step(t[k], reading, rates[k, 0], rates[k, 1], torque[k, 0], torque[k, 1],
                         lateness[k], heartbeat[k], False, False)[2]
        assert fault is Fault.NONE, sup.fault_message


# ------------------------------------------------------- each check trips
def ik(x, y):
    q1, q2 = ROBOT.ik_terms(x, y)
    assert not math.isnan(q1)
    return q1, q2


RADIAL_BEARING_RAD = math.radians(120.0)


def radial(radius_m):
    """Joint angles for the handle `radius_m` from the motor axes, on a fixed bearing."""
    return ik(radius_m * math.cos(RADIAL_BEARING_RAD), radius_m * math.sin(RADIAL_BEARING_RAD))


def case_estop(tick):
    tick()
    return [dict(estop=True)]


def case_heartbeat(tick):
    return [dict(heartbeat=0.49), dict(heartbeat=0.51)]


def case_heartbeat_never(tick):
    return [dict(heartbeat=math.inf)]


def case_heartbeat_nan(tick):
    return [dict(heartbeat=math.nan)]


def case_backend_error(tick):
    return [dict(reading=BackendError("Q8 read failed (-113 invalid board handle)"))]


def case_sensor_range_error(tick):
    return [dict(reading=SensorRangeError("gauge 3 at 10 V"))]


def case_unexpected_exception(tick):
    return [dict(reading=RuntimeError("bug in a backend"))]


def case_not_a_reading(tick):
    return [dict(reading=("0.1", None))]


def case_timeout(tick):
    return [dict(reading=BackendTimeout("no sample within 5 ms"))]


def case_stale(tick):
    frozen = at_rest(tick.t + PERIOD)
    return [dict(reading=frozen)] + [dict(reading=frozen)] * 5  # 5th repeat trips


def case_stale_backwards(tick):
    return [dict(reading=at_rest(tick.t - 0.5))] * 5


def case_encoder_jump(tick):
    return [dict(reading=at_rest(tick.t + PERIOD, q1=HOME_Q1 + 0.11))]


def case_nan_angle(tick):
    return [dict(reading=at_rest(tick.t + PERIOD, q2=math.nan))]


def case_inf_force(tick):
    return [dict(reading=at_rest(tick.t + PERIOD, fy=-math.inf))]


def case_nan_time(tick):
    return [dict(reading=at_rest(math.nan))]


def case_nan_rate(tick):
    return [dict(rates=(0.0, math.nan))]


def case_nan_torque(tick):
    return [dict(torques=(math.nan, 0.5))]


def case_inf_torque(tick):
    return [dict(torques=(0.5, math.inf))]


def case_sensor_saturated_planar(tick):
    return [dict(reading=at_rest(tick.t + PERIOD, fx=-240.0))]


def case_sensor_saturated_normal(tick):
    return [dict(reading=at_rest(tick.t + PERIOD, fz=300.0)),  # leaning on it: fine
            dict(reading=at_rest(tick.t + 2 * PERIOD, fz=960.0))]


def case_force(tick):
    return [dict(reading=at_rest(tick.t + PERIOD, fx=30.0, fy=-39.9)),  # 49.9 N
            dict(reading=at_rest(tick.t + 2 * PERIOD, fx=30.0, fy=-40.1))]  # 50.1 N


LIMIT_POSE = (0.0015, math.radians(-40.0))  # joint 1 just above its 0° limit


def case_joint_limit(tick):
    q2 = LIMIT_POSE[1]
    return [dict(reading=at_rest(tick.t + PERIOD, q1=0.0005, q2=q2)),
            dict(reading=at_rest(tick.t + 2 * PERIOD, q1=-0.0005, q2=q2))]


RING_EDGE_M = ROBOT.reach_max_m - SafetyLimits().workspace_margin_m


def case_reach_ring(tick):
    # 0.2 mm per tick: slow enough not to be overspeed so close to the folded pose
    return [dict(reading=at_rest(tick.t + PERIOD * (k + 1), *radial(RING_EDGE_M + r)))
            for k, r in enumerate((-0.0003, -0.0001, 0.0001))]


def case_joint_speed_estimate(tick):
    return [dict(rates=(3.9, 3.9)), dict(rates=(4.1, 4.1))]


def case_joint_speed_difference(tick):
    t, q1, q2 = tick.t, tick.q1, tick.q2
    dq = 4.1 * PERIOD  # rigid turn: every joint at 4.1 rad/s, rate estimate stuck at 0
    return [dict(reading=at_rest(t + PERIOD, q1 + dq, q2 + dq))]


def case_ee_speed_estimate(tick):
    # links 90° apart: the handle moves at l4·θ̇1
    return [dict(rates=(2.6, 0.0)), dict(rates=(1.01 / ROBOT.l4_m, 0.0))]


def case_ee_speed_difference(tick):
    dq = 1.05 / ROBOT.l4_m * PERIOD
    return [dict(reading=at_rest(tick.t + PERIOD, tick.q1 + dq, tick.q2))]


def case_late_single(tick):
    return [dict(lateness=0.0099), dict(lateness=0.0101)]


def case_late_nan(tick):
    return [dict(lateness=math.nan)]


def case_late_run(tick):
    return [dict(lateness=0.0025)] * 10


def case_recording_lost(tick):
    return [dict(lost=True)]


SATURATION = SafetyLimits(saturation_time_s=0.999)  # the boundary falls between two ticks


def case_saturated(tick):
    return [dict(torques=(3.0, -1.0))] * 501  # clamped from the first; the 501st is 1 s on


def case_held_at_the_clamp(tick):
    # the SMC and the CT-PID clip their own output to the drive's limit: a command that
    # sits exactly there is the clamp acting (a timer started only above it never ran,
    # and a hold overpowered by a 40 N push sat at full torque for 6 s without a fault)
    _, limit2 = tick.sup.torque_limits_Nm
    return [dict(torques=(0.5, -limit2))] * 501


def case_one_way_joined_by_the_other_joint(tick):
    # joint 1 pushes one way from the first tick, joint 2 reaches its clamp half-way and
    # leaves it: one push, timed from its start
    return ([dict(torques=(3.0, 0.0))] * 250 + [dict(torques=(3.0, -3.0))] * 100
            + [dict(torques=(3.0, 0.5))] * 151)


HOME = (HOME_Q1, HOME_Q2)
TURNING = radial(0.20)  # a rigid turn of the links moves the handle at only 0.2 m per rad

# name: (ticks after warming up, the fault the last one latches, start pose, limits)
CASES = {
    "estop": (case_estop, Fault.ESTOP, HOME, None),
    "heartbeat": (case_heartbeat, Fault.HEARTBEAT_LOST, HOME, None),
    "heartbeat never seen": (case_heartbeat_never, Fault.HEARTBEAT_LOST, HOME, None),
    "heartbeat age NaN": (case_heartbeat_nan, Fault.HEARTBEAT_LOST, HOME, None),
    "backend error": (case_backend_error, Fault.BACKEND_ERROR, HOME, None),
    "sensor range error": (case_sensor_range_error, Fault.BACKEND_ERROR, HOME, None),
    "unexpected exception": (case_unexpected_exception, Fault.BACKEND_ERROR, HOME, None),
    "not a reading": (case_not_a_reading, Fault.BACKEND_ERROR, HOME, None),
    "timeout": (case_timeout, Fault.BACKEND_TIMEOUT, HOME, None),
    "stale": (case_stale, Fault.SENSOR_STALE, HOME, None),
    "stale, clock backwards": (case_stale_backwards, Fault.SENSOR_STALE, HOME, None),
    "encoder jump": (case_encoder_jump, Fault.ENCODER_JUMP, HOME, None),
    "NaN angle": (case_nan_angle, Fault.NOT_FINITE, HOME, None),
    "inf force": (case_inf_force, Fault.NOT_FINITE, HOME, None),
    "NaN time": (case_nan_time, Fault.NOT_FINITE, HOME, None),
    "NaN rate": (case_nan_rate, Fault.NOT_FINITE, HOME, None),
    "NaN torque": (case_nan_torque, Fault.NOT_FINITE, HOME, None),
    "inf torque": (case_inf_torque, Fault.NOT_FINITE, HOME, None),
    "sensor saturated x'": (case_sensor_saturated_planar, Fault.SENSOR_RANGE, HOME, None),
    "sensor saturated z'": (case_sensor_saturated_normal, Fault.SENSOR_RANGE, HOME, None),
    "force": (case_force, Fault.FORCE_LIMIT, HOME, None),
    "joint limit": (case_joint_limit, Fault.WORKSPACE, LIMIT_POSE, None),
    "reach ring": (case_reach_ring, Fault.WORKSPACE, radial(RING_EDGE_M - 0.0005), None),
    "joint speed (estimate)": (case_joint_speed_estimate, Fault.JOINT_SPEED, TURNING, None),
    "joint speed (encoders)": (case_joint_speed_difference, Fault.JOINT_SPEED, TURNING, None),
    "handle speed (estimate)": (case_ee_speed_estimate, Fault.EE_SPEED, HOME, None),
    "handle speed (encoders)": (case_ee_speed_difference, Fault.EE_SPEED, HOME, None),
    "late tick": (case_late_single, Fault.LATE_TICK, HOME, None),
    "lateness NaN": (case_late_nan, Fault.LATE_TICK, HOME, None),
    "late run": (case_late_run, Fault.LATE_TICK, HOME, None),
    "recording lost": (case_recording_lost, Fault.RECORDING_LOST, HOME, None),
    "torque saturated": (case_saturated, Fault.TORQUE_SATURATED, HOME, SATURATION),
    "torque held at the clamp": (case_held_at_the_clamp, Fault.TORQUE_SATURATED, HOME,
                                 SATURATION),
    "one push, the other joint joining": (case_one_way_joined_by_the_other_joint,
                                          Fault.TORQUE_SATURATED, HOME, SATURATION),
}


@pytest.mark.parametrize("name", list(CASES))
def test_each_check_trips_with_zero_torque_in_the_tick_it_is_found(name):
    make, expected, start, limits = CASES[name]
    tick = warm_supervisor(limits, q=start)
    sup = tick.sup
    *before, last = make(tick)
    for kwargs in before:
        out1, out2, fault = tick(**kwargs)
        assert fault is Fault.NONE, (name, sup.condition, sup.fault_message)
        assert (out1, out2) != (0.0, 0.0)
    out = tick(**last)
    assert out == (0.0, 0.0, expected), (name, sup.condition, sup.fault_message)
    assert sup.fault is expected
    assert sup.fault_time_s == tick.t
    assert sup.fault_detail["fault"] == expected.label
    assert sup.fault_detail["code"] == int(expected)
    banner_is_filled(sup)


def test_the_detail_carries_the_measured_value_and_the_limit():
    tick = warm_supervisor()
    tick(reading=at_rest(tick.t + PERIOD, fx=0.0, fy=63.0))
    detail = tick.sup.fault_detail
    assert detail["force_N"] == pytest.approx(63.0)
    assert detail["limit_N"] == 50.0
    assert tick.sup.fault_message.startswith("Force on the handle reached 63 N (limit 50 N)")
    assert "check the patient" in tick.sup.fault_message


def test_a_region_around_the_path_trips_when_the_handle_leaves_it():
    limits = SafetyLimits().around_path(d_shape((-0.30, 0.30), 0.10).points(), margin_m=0.05)
    x_max = limits.region_m[1]
    start = ik(x_max - 0.002, 0.30)
    tick = warm_supervisor(limits, q=start)
    assert tick(reading=at_rest(tick.t + PERIOD, *ik(x_max - 0.0005, 0.30)))[2] is Fault.NONE
    out = tick(reading=at_rest(tick.t + PERIOD, *ik(x_max + 0.0005, 0.30)))
    assert out == (0.0, 0.0, Fault.WORKSPACE)
    message = banner_is_filled(tick.sup)
    # in cm, as the window's positions are (clinic exploration 2 #3: it was in metres)
    x0, x1, y0, y1 = (f"{round(v * 100, 1):g}" for v in limits.region_m)
    assert message.startswith(
        f"The handle left the allowed region: it is at ({round((x_max + 0.0005) * 100, 1):g}"
        ", 30) cm, outside the exercise area x "
        f"{x0} to {x1} cm, y {y0} to {y1} cm — guide the handle back")


def test_a_long_sample_gap_is_a_late_tick_not_an_encoder_jump():
    # 50 ms between samples while joint 1 turned 0.12 rad at 2.4 rad/s: a real movement,
    # more than one sample's jump limit but not more than the gap allows
    tick = warm_supervisor()
    tick.t += 0.048
    assert tick(reading=at_rest(tick.t + PERIOD, q1=HOME_Q1 + 0.12))[2] is Fault.NONE
    tick = warm_supervisor()
    tick.t += 0.048
    out = tick(reading=at_rest(tick.t + PERIOD, q1=HOME_Q1 + 0.12), lateness=0.048)
    assert out[2] is Fault.LATE_TICK


def test_the_first_failing_check_names_the_fault():
    tick = warm_supervisor()
    out = tick(reading=at_rest(tick.t + PERIOD, fx=80.0), estop=True, heartbeat=2.0)
    assert out[2] is Fault.ESTOP


# ------------------------------------------------------------- latching
def test_a_fault_latches_through_normal_ticks():
    tick = warm_supervisor()
    tick(torques=(math.nan, 0.0))
    time_s, detail = tick.sup.fault_time_s, tick.sup.fault_detail
    for _ in range(50):
        assert tick() == (0.0, 0.0, Fault.NOT_FINITE)
    assert tick.sup.condition is Fault.NONE  # the cause has gone, the fault has not
    assert tick.sup.fault_time_s == time_s
    assert tick.sup.fault_detail is detail


def test_a_second_cause_does_not_replace_the_first():
    tick = warm_supervisor()
    tick(lost=True)
    tick(estop=True)
    assert tick.sup.fault is Fault.RECORDING_LOST
    assert tick.sup.condition is Fault.ESTOP


def test_clear_refuses_while_the_estop_is_held_and_says_so():
    tick = warm_supervisor()
    tick(estop=True)
    tick(estop=True)
    assert "Emergency stop" in tick.sup.clear_refusal()
    with pytest.raises(StateError, match=r"Emergency stop pressed"):
        tick.sup.clear()
    assert tick.sup.fault is Fault.ESTOP
    assert tick() == (0.0, 0.0, Fault.ESTOP)  # released, but still latched
    tick.sup.clear()
    assert tick.sup.fault is Fault.NONE
    assert math.isnan(tick.sup.fault_time_s)
    assert tick.sup.fault_detail == {}
    assert tick.sup.fault_message == "No fault"


def test_clear_refuses_until_a_tick_has_seen_the_cause_gone():
    tick = warm_supervisor()
    tick(reading=at_rest(tick.t + PERIOD, q1=math.nan))
    with pytest.raises(StateError, match=r"while its cause is present"):
        tick.sup.clear()
    tick()
    tick.sup.clear()
    assert tick()[2] is Fault.NONE


def test_clear_refuses_while_the_force_stays_over_its_limit_with_the_values():
    tick = warm_supervisor()
    for _ in range(3):
        tick(reading=at_rest(tick.t + PERIOD, fx=70.0, fy=0.0))
    with pytest.raises(StateError, match=r"70 N \(limit 50 N\)"):
        tick.sup.clear()
    tick()
    tick.sup.clear()


def test_clear_refuses_for_any_cause_present_not_only_the_latched_one():
    tick = warm_supervisor()
    tick(reading=at_rest(tick.t + PERIOD, fx=70.0))
    tick(heartbeat=0.8)
    with pytest.raises(StateError, match=r"console window stopped answering"):
        tick.sup.clear()


def test_an_encoder_jump_cannot_be_cleared_without_reconnecting():
    tick = warm_supervisor()
    tick(reading=at_rest(tick.t + PERIOD, q1=HOME_Q1 + 0.5))
    for _ in range(10):
        tick()
    assert tick.sup.condition is Fault.NONE
    with pytest.raises(StateError, match=r"[Rr]econnect"):
        tick.sup.clear()
    assert tick.sup.fault is Fault.ENCODER_JUMP


def test_a_controller_wound_up_while_faulted_does_not_block_the_clear():
    # While the torque is zero the command may sit at full strength (an integrator
    # winding up); that is not the robot pushing, so it neither blocks the clear nor
    # counts towards TORQUE_SATURATED afterwards.
    tick = warm_supervisor()
    tick(estop=True)
    for _ in range(round(2.0 / PERIOD)):
        assert tick(torques=(5.0, 0.0)) == (0.0, 0.0, Fault.ESTOP)
    assert tick.sup.clear_refusal() == ""
    tick.sup.clear()
    for _ in range(round(0.9 / PERIOD)):
        assert tick(torques=(5.0, 0.0))[2] is Fault.NONE


def test_clear_without_a_fault_does_nothing():
    tick = warm_supervisor()
    assert tick.sup.clear_refusal() == ""
    tick.sup.clear()
    assert tick() == (1.0, -0.5, Fault.NONE)


def test_torque_ramps_up_from_zero_at_start_and_after_a_clear():
    limits = SafetyLimits()
    tick = Tick(SafetySupervisor(ROBOT, limits))
    assert tick(torques=(2.0, -1.0))[:2] == (0.0, 0.0)  # first tick: the ramp starts
    ramp_ticks = round(limits.restart_ramp_s / PERIOD)
    for _ in range(ramp_ticks // 2 - 1):
        tick(torques=(2.0, -1.0))
    half = tick(torques=(2.0, -1.0))
    assert half[0] == pytest.approx(0.5 * DRIVE_NM)
    assert half[1] == pytest.approx(-0.25 * DRIVE_NM)
    tick.warm()
    tick(estop=True)
    tick()
    tick.sup.clear()
    assert tick()[:2] == (0.0, 0.0)
    for _ in range(ramp_ticks):
        tick()
    assert tick() == (1.0, -0.5, Fault.NONE)


def test_no_ramp_when_disabled():
    tick = Tick(SafetySupervisor(ROBOT, SafetyLimits(restart_ramp_s=0.0)))
    assert tick() == (1.0, -0.5, Fault.NONE)


# --------------------------------------------------------------- clamping
def test_torque_over_the_drive_limit_is_clamped_keeping_signs_and_direction():
    tick = warm_supervisor()
    out1, out2, fault = tick(torques=(5.0, -3.0))
    assert fault is Fault.NONE
    assert tick.sup.condition is Fault.NONE
    assert out1 == pytest.approx(DRIVE_NM)
    assert out2 == pytest.approx(-3.0 / 5.0 * DRIVE_NM)
    out1, out2, _ = tick(torques=(-0.5, -9.0))
    assert out2 == pytest.approx(-DRIVE_NM)
    assert out1 == pytest.approx(-0.5 / 9.0 * DRIVE_NM)


def test_the_current_limit_lowers_the_clamp():
    tick = warm_supervisor(SafetyLimits(current_limit_A=0.5))
    assert tick.sup.torque_limits_Nm == pytest.approx((DRIVE_NM / 2, DRIVE_NM / 2))
    out1, out2, fault = tick(torques=(-4.0, 0.0))
    assert (out1, out2, fault) == (pytest.approx(-DRIVE_NM / 2), 0.0, Fault.NONE)


def test_short_saturation_at_corners_is_not_a_fault():
    tick = warm_supervisor()
    n = round(0.9 / PERIOD)
    for _ in range(3):
        for _ in range(n):
            assert tick(torques=(4.0, 0.0))[2] is Fault.NONE
        assert tick(torques=(1.0, 0.0))[2] is Fault.NONE


@pytest.mark.parametrize("every_ticks", [1, 7, 100])
def test_a_clamp_that_turns_from_one_way_to_the_other_is_not_a_sustained_push(every_ticks):
    """H2 is a push one way against an arm for a second. A tracker catching a fast
    reference up chatters from one clamp to the other (the centre-out targets trial sat
    there 1.5 s turning every 0.05-0.2 s, and faulted every weak patient's trial): each
    turn starts the time again, and the same command one way for the whole second trips."""
    tick = warm_supervisor(SATURATION)
    for k in range(round(3.0 / PERIOD)):
        way = 1.0 if (k // every_ticks) % 2 == 0 else -1.0
        assert tick(torques=(4.0 * way, -4.0 * way))[2] is Fault.NONE, k
    for _ in range(round(1.0 / PERIOD) + 1):  # the push's first tick starts the time
        out = tick(torques=(4.0, 0.0))
    assert out[2] is Fault.TORQUE_SATURATED


# ------------------------------------------------------ property: any input
def number():
    return st.one_of(st.floats(), st.floats(-5.0, 5.0), st.sampled_from([0.0, math.nan, math.inf]))


def tick_inputs():
    reading = st.one_of(
        st.builds(SensorReading, number(), number(), number(), number(), number(), number()),
        st.builds(lambda d1, d2, f: SensorReading(0.0, HOME_Q1 + d1, HOME_Q2 + d2, f, 0.0, 5.0),
                  st.floats(-0.01, 0.01), st.floats(-0.01, 0.01), st.floats(-80.0, 80.0)),
        st.sampled_from([BackendError("x"), BackendTimeout("y"), ValueError("z")]),
    )
    return st.tuples(
        st.one_of(st.floats(0.0, 0.02), number()),  # step of the loop clock
        reading, number(), number(), number(), number(), number(), number(),
        st.booleans(), st.booleans(),
    )


@given(st.lists(tick_inputs(), min_size=1, max_size=40),
       st.floats(0.0, 0.5), st.sampled_from([0.25, 1.0]))
def test_whatever_comes_in_the_torque_is_finite_bounded_and_zero_under_a_fault(
        ticks, ramp_s, current_A):
    limits = SafetyLimits(restart_ramp_s=ramp_s, current_limit_A=current_A)
    sup = SafetySupervisor(ROBOT, limits)
    limit1, limit2 = sup.torque_limits_Nm
    now = 0.0
    latched = Fault.NONE
    for dt, reading, r1, r2, t1, t2, lateness, heartbeat, estop, lost in ticks:
        now = now + dt
        if isinstance(reading, SensorReading) and reading.time_s == 0.0:
            reading = reading._replace(time_s=now)
        out1, out2, fault = sup.step(now, reading, r1, r2, t1, t2, lateness, heartbeat,
                                     estop, lost)
        assert math.isfinite(out1)
        assert math.isfinite(out2)
        assert abs(out1) <= limit1
        assert abs(out2) <= limit2
        assert fault is sup.fault
        if latched is not Fault.NONE:
            assert fault is latched  # latched until cleared
        if fault is not Fault.NONE:
            assert (out1, out2) == (0.0, 0.0)
            assert sup.fault_detail["code"] == int(fault)
            assert "{" not in sup.fault_message
        else:
            # the clamp only scales the command down: signs and direction kept
            assert abs(out1) <= abs(t1)
            assert abs(out2) <= abs(t2)
            scale = out1 / t1 if t1 != 0.0 else (out2 / t2 if t2 != 0.0 else 0.0)
            assert 0.0 <= scale <= 1.0
            assert out1 == pytest.approx(t1 * scale, abs=1e-9)
            assert out2 == pytest.approx(t2 * scale, abs=1e-9)
        latched = fault


def test_detail_values_are_plain_json():
    import json

    tick = warm_supervisor()
    tick(reading=BackendTimeout("no answer"))
    text = json.dumps(tick.sup.fault_detail, allow_nan=False)
    assert "no answer" in text
    assert re.search(r'"fault": "backend_timeout"', text)
    for kwargs in ({"heartbeat": math.inf}, {"lateness": math.nan}, {"torques": (math.nan, 0)}):
        tick = warm_supervisor()
        tick(**kwargs)
        json.dumps(tick.sup.fault_detail, allow_nan=False)
