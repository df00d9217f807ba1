"""Fault injection: each scenario starts at the requested loop time and makes the supervisor
latch its fault in a loop like the real one; before that, and outside its window, the
wrapped backend's readings pass through untouched."""

import itertools
import math
import threading
import time

import pytest

from core.errors import ParameterError
from core.robot import RobotModel
from core.trajectory import Trajectory, d_shape
from device.backend import REAL_TIME, Backend, SensorReading
from device.errors import BackendError, BackendTimeout
from device.safety.faults import Fault
from device.safety.supervisor import SafetySupervisor
from device.sim.faultinjection import (
    EXPECTED_FAULT,
    LOOP_SCENARIOS,
    SCENARIOS,
    FaultInjectingBackend,
    LoopFaultInjection,
)

ROBOT = RobotModel()
PERIOD = 0.002
AT_S = 0.7  # past the supervisor's start ramp, in the middle of the D's straight line


class PathBackend:
    """A robot whose handle walks the thesis's D at 0.25 m/s with a light hand on it."""

    name = "path"
    timing = REAL_TIME

    def __init__(self):
        self.trajectory = Trajectory(d_shape((-0.30, 0.30), 0.10), 2.06, 100)
        self.calls = []
        self.reads = 0

    def open(self):
        self.calls.append("open")

    def read(self, now_s):
        self.reads += 1
        x, y, *_ = self.trajectory.at(now_s)
        q1, q2 = ROBOT.ik_terms(x, y)
        motor = ROBOT.motors[0]
        phase = 2 * math.pi * now_s / 2.06
        return SensorReading(now_s, motor.quantise_joint_angle(q1), motor.quantise_joint_angle(q2),
                             3.0 * math.sin(phase), -2.0 * math.cos(phase), 10.0)

    def write(self, torque1_Nm, torque2_Nm):
        self.calls.append(("write", torque1_Nm, torque2_Nm))

    def safe_state(self):
        self.calls.append("safe_state")

    def close(self):
        self.calls.append("close")


def first_tick_at_or_after(at_s):
    return next(k * PERIOD for k in itertools.count() if k * PERIOD >= at_s)


class ManualClock:
    """The loop's time spent in reads, in these tests: it moves only when a read sleeps
    (the `late` scenario's `sleep`), so a tick's lateness is what the test injected,
    never how promptly this machine woke up."""

    def __init__(self):
        self.slept_s = 0.0

    def sleep(self, seconds):
        self.slept_s += seconds


def run_loop(backend, until_s=3.0, injection=None, clock=None):
    """The loop's order on a simulated clock: read → rates by difference → supervisor →
    write. A read that overruns its period (on `clock`) makes the next tick late by the
    overrun. Returns (time of the tick that latched a fault or None, supervisor)."""
    clock = clock or ManualClock()
    sup = SafetySupervisor(ROBOT)
    backend.open()
    previous = None
    rate1 = rate2 = 0.0
    lateness = 0.0
    for k in range(round(until_s / PERIOD)):
        now = k * PERIOD
        started = clock.slept_s
        try:
            reading = backend.read(now)
        except BackendError as exc:
            reading = exc
        overrun = clock.slept_s - started - PERIOD
        if isinstance(reading, SensorReading):
            if previous is not None and reading.time_s > previous.time_s:
                dt = reading.time_s - previous.time_s
                rate1 = (reading.q1_rad - previous.q1_rad) / dt
                rate2 = (reading.q2_rad - previous.q2_rad) / dt
            previous = reading
        heartbeat, estop, lost = 0.03, False, False
        if injection is not None:
            heartbeat = injection.heartbeat_age_s(now, heartbeat)
            estop = injection.estop(now, estop)
            lost = injection.recording_lost(now, lost)
        out1, out2, fault = sup.step(now, reading, rate1, rate2, 0.4, -0.3, lateness,
                                     heartbeat, estop, lost)
        backend.write(out1, out2)
        if fault is not Fault.NONE:
            assert (out1, out2) == (0.0, 0.0)
            return now, sup
        lateness = max(0.0, overrun)
    backend.close()
    return None, sup


def test_the_wrapper_is_a_backend():
    assert isinstance(FaultInjectingBackend(PathBackend(), "nan", AT_S), Backend)


def test_without_the_fault_the_loop_runs_clean():
    detected, sup = run_loop(PathBackend(), until_s=2.5)
    assert detected is None, sup.fault_message


# How long after the first affected read each fault may take to show.
DETECTION_BOUND_S = {
    "stale": 5 * PERIOD,  # five samples in a row with the same time stamp
    "late": PERIOD,  # the tick after the slow read starts late
    "stalls": PERIOD,  # the same, at the first stall
    "workspace_exit": 1.5,  # the links fold at 1 rad/s
    "overspeed": PERIOD,  # the ramp starts from zero at the first affected read
}


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_each_scenario_latches_its_fault_in_the_loop(scenario):
    options = {"block_s": 0.02} if scenario == "hang" else {}
    clock = ManualClock()
    backend = FaultInjectingBackend(PathBackend(), scenario, AT_S, sleep=clock.sleep, **options)
    detected, sup = run_loop(backend, clock=clock)
    assert detected is not None, f"{scenario}: no fault"
    first = first_tick_at_or_after(AT_S)
    assert backend.fired_at_s == first
    assert sup.fault is EXPECTED_FAULT[scenario] == backend.expected_fault, sup.fault_message
    assert first <= detected <= first + DETECTION_BOUND_S.get(scenario, 0.0) + 1e-12
    assert sup.fault_time_s == detected
    written = [c for c in backend.inner.calls if c[0] == "write"]
    assert written[-1] == ("write", 0.0, 0.0)


@pytest.mark.parametrize("scenario", list(LOOP_SCENARIOS))
def test_each_loop_scenario_latches_its_fault(scenario):
    injection = LoopFaultInjection(scenario, AT_S)
    detected, sup = run_loop(PathBackend(), injection=injection)
    assert sup.fault is injection.expected_fault, sup.fault_message
    bound = sup.limits.heartbeat_timeout_s + PERIOD if scenario == "heartbeat_lost" else PERIOD
    assert AT_S <= detected <= AT_S + bound


def test_loop_injection_passes_the_real_values_outside_its_window():
    estop = LoopFaultInjection("estop", 1.0, duration_s=0.5)
    assert estop.estop(0.99, False) is False
    assert estop.estop(1.2, False) is True
    assert estop.estop(1.6, False) is False
    assert estop.estop(1.6, True) is True  # a real e-stop always goes through
    assert estop.heartbeat_age_s(1.2, 0.03) == 0.03
    assert estop.recording_lost(1.2, False) is False
    silent = LoopFaultInjection("heartbeat_lost", 1.0)
    assert silent.heartbeat_age_s(0.9, 0.03) == 0.03
    assert silent.heartbeat_age_s(1.7, 0.03) == pytest.approx(0.7)
    assert silent.heartbeat_age_s(1.01, 0.03) == 0.03  # the last real one is still fresh
    stalled = LoopFaultInjection("recorder_stalled", 2.0)
    assert stalled.recording_lost(1.9, False) is False
    assert stalled.recording_lost(2.1, False) is True


def test_readings_pass_through_before_the_fault_and_calls_always():
    reference = PathBackend()
    backend = FaultInjectingBackend(PathBackend(), "force_spike", AT_S)
    assert backend.name == "path+force_spike"
    backend.open()
    for k in range(round(AT_S / PERIOD)):
        now = k * PERIOD
        assert backend.read(now) == reference.read(now)
    assert backend.fired_at_s is None
    backend.write(0.5, -0.25)
    backend.safe_state()
    backend.close()
    assert backend.inner.calls == ["open", ("write", 0.5, -0.25), "safe_state", "close"]


def test_a_spike_lasts_its_duration_then_readings_pass_through_again():
    reference = PathBackend()
    backend = FaultInjectingBackend(PathBackend(), "force_spike", 1.0, duration_s=0.01,
                                    force_N=120.0)
    spiked = []
    for k in range(400, 520):
        now = k * PERIOD
        got, want = backend.read(now), reference.read(now)
        if got != want:
            assert got.force_x_N == pytest.approx(want.force_x_N + 120.0)
            assert got._replace(force_x_N=want.force_x_N) == want
            spiked.append(now)
    assert spiked == pytest.approx([1.0 + k * PERIOD for k in range(5)])


@pytest.mark.parametrize("scenario", ["nan", "exception", "late"])
def test_a_glitch_affects_exactly_one_read(scenario):
    reference = PathBackend()
    backend = FaultInjectingBackend(PathBackend(), scenario, 0.5, sleep_s=0.001)
    affected = []
    for k in range(200, 300):
        now = k * PERIOD
        try:
            got = backend.read(now)
        except BackendError:
            affected.append(now)
            continue
        if got != reference.read(now) or (scenario == "late" and now == backend.fired_at_s):
            affected.append(now)
    assert affected == [first_tick_at_or_after(0.5)]


def test_nan_can_hit_any_field():
    backend = FaultInjectingBackend(PathBackend(), "nan", 0.0, field="force_z_N")
    reading = backend.read(0.0)
    assert math.isnan(reading.force_z_N)
    assert math.isfinite(reading.q1_rad)


def test_stale_freezes_the_whole_reading_while_the_robot_moves_on():
    backend = FaultInjectingBackend(PathBackend(), "stale", 0.1)
    readings = [backend.read(k * PERIOD) for k in range(40, 80)]
    frozen = readings[10]
    assert frozen.time_s == pytest.approx(0.1)
    assert all(r == frozen for r in readings[10:])
    assert len(set(readings[:11])) == 11
    assert backend.inner.reads == 40  # the wrapped device is still sampled


def test_an_encoder_jump_leaves_its_offset():
    reference = PathBackend()
    backend = FaultInjectingBackend(PathBackend(), "encoder_jump", 0.2, jump_rad=-0.3)
    for now in (0.198, 0.2, 0.3, 1.0):
        expected = reference.read(now)
        if now >= 0.2:
            expected = expected._replace(q1_rad=expected.q1_rad - 0.3)
        assert backend.read(now) == expected


@pytest.mark.parametrize(("scenario", "rate"), [("overspeed", 8.0), ("workspace_exit", 1.0)])
def test_ramps_drive_joint_1_at_their_rate(scenario, rate):
    reference = PathBackend()
    backend = FaultInjectingBackend(PathBackend(), scenario, 0.4)
    for now in (0.3, 0.4, 0.5, 0.9):
        offset = backend.read(now).q1_rad - reference.read(now).q1_rad
        assert offset == pytest.approx(rate * max(0.0, now - 0.4))


def test_a_lateness_sleep_is_at_least_what_was_asked():
    backend = FaultInjectingBackend(PathBackend(), "late", 0.0, sleep_s=0.015)
    started = time.perf_counter()
    backend.read(0.0)
    assert time.perf_counter() - started >= 0.015


def test_a_lateness_sleeps_once():
    slept = []
    backend = FaultInjectingBackend(PathBackend(), "late", 0.0, sleep_s=0.015,
                                    sleep=slept.append)
    for k in range(3):
        backend.read(k * PERIOD)
    assert slept == [0.015]


def test_stalls_sleep_once_every_so_often_and_pass_the_readings_through():
    """The host's stalls of a shared machine: one read every `every_s` of loop time sleeps
    `sleep_s`, the readings are the inner backend's own."""
    slept = []
    reference = PathBackend()
    backend = FaultInjectingBackend(PathBackend(), "stalls", 0.5, sleep_s=0.05, every_s=1.0,
                                    sleep=slept.append)
    for k in range(1600):  # 3.2 s of loop time
        now = k * PERIOD
        assert backend.read(now) == reference.read(now)
    assert slept == [0.05] * 3  # at 0.5, 1.5 and 2.5 s


def test_a_hung_read_times_out_and_keeps_timing_out():
    backend = FaultInjectingBackend(PathBackend(), "hang", 0.0, block_s=0.01)
    for now in (0.0, PERIOD, 1.0):
        started = time.perf_counter()
        with pytest.raises(BackendTimeout, match=r"did not answer within 0.01 s"):
            backend.read(now)
        assert time.perf_counter() - started >= 0.01


def test_release_wakes_a_hung_read_so_a_test_cannot_hang():
    backend = FaultInjectingBackend(PathBackend(), "hang", 0.0, block_s=30.0)
    outcome = []

    def reader():
        try:
            backend.read(0.0)
        except BackendTimeout as exc:
            outcome.append(exc)

    thread = threading.Thread(target=reader, daemon=True)
    thread.start()
    thread.join(0.05)
    assert thread.is_alive()  # the loop's watchdog would see a read that does not return
    backend.release()
    thread.join(5.0)
    assert not thread.is_alive()
    assert isinstance(outcome[0], BackendTimeout)
    with pytest.raises(BackendTimeout):
        backend.read(PERIOD)  # released: later reads fail at once


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"scenario": "meteor"}, "scenario"),
        ({"at_s": -1.0}, "at_s"),
        ({"at_s": math.nan}, "at_s"),
        ({"duration_s": -0.1}, "duration_s"),
        ({"field": "q3_rad"}, "field"),
        ({"block_s": math.inf}, "block_s"),
        ({"sleep_s": 0.0}, "sleep_s"),
        ({"rate_rad_s": 100.0}, "rate_rad_s"),
    ],
)
def test_bad_parameters_are_refused(kwargs, field):
    args = {"scenario": "nan", "at_s": 1.0} | kwargs
    with pytest.raises(ParameterError) as err:
        FaultInjectingBackend(PathBackend(), **args)
    assert err.value.field == field


def test_bad_loop_scenarios_are_refused():
    with pytest.raises(ParameterError) as err:
        LoopFaultInjection("stale", 1.0)
    assert err.value.field == "scenario"


def test_the_injector_passes_the_exercise_s_cue_to_the_virtual_patient():
    """The loop cues a virtual patient when the exercise starts (device.loop.process): a
    wrapped simulator's patient must start too, or it holds the path's start all trial
    against a robot driving the D (every injected fault then fell on a clamped robot)."""

    class Waiting(PathBackend):
        cued = None

        def cue_patient(self, at_s=None):
            self.cued = ("cued", at_s)

    inner = Waiting()
    FaultInjectingBackend(inner, "late", at_s=AT_S).cue_patient(1.25)
    assert inner.cued == ("cued", 1.25)
    FaultInjectingBackend(PathBackend(), "late", at_s=AT_S).cue_patient()  # a robot: nothing
