"""The live loop's compiled tick runs the same ticks as the Python objects, bit for bit,
hands every unusual tick back undone, and leaves the objects as Python would have."""

import math

import numpy as np
import pytest

from core.trial import THESIS_SUBJECT
from device.compiled.looptick import CompiledTick, unsupported_live
from device.loop.pipeline import TickPipeline, TrialPlan
from device.safety.faults import Fault
from device.safety.supervisor import SafetySupervisor
from device.sim.faultinjection import FaultInjectingBackend
from device.sim.simulator import NOISE_BLOCK, SimulatorBackend, snapshot

PARAMS = THESIS_SUBJECT.replace(repetitions=3)
PERIOD = 0.002


class Rig:
    """One connection's objects, driven tick by tick as DeviceLoop drives them."""

    def __init__(self, compiled: bool, patient: str = "healthy", params=PARAMS):
        self.plan = TrialPlan.build(params)
        self.backend = SimulatorBackend.from_trial(params, patient, seed=4,
                                                   robot=self.plan.robot, patient_waits=True)
        self.pipeline = TickPipeline(self.plan)
        self.supervisor = SafetySupervisor(self.plan.robot)
        self.backend.open()
        self.use_compiled = compiled
        self.compiled = None
        self.tick_index = 0
        self.handed_back = 0
        self.keep_noise = False

    def idle(self, loop_t):
        reading = self.backend.read(loop_t)
        out = self.supervisor.step(loop_t, reading, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, False, False)
        self.backend.write(*out[:2])
        return reading, out

    def start(self, reading):
        self.pipeline.begin(reading.q1_rad, reading.q2_rad)
        self.supervisor.restart_ramp()
        if self.use_compiled:
            self.compiled = CompiledTick(self.backend, self.pipeline, self.supervisor)
            assert self.compiled.take_over() == ""

    def running(self, loop_t, lateness=0.0, beat_age=0.0, estop=False, lost=False):
        """One running tick: (reading, torques written, fault, pipeline's last tick)."""
        k = self.tick_index
        compiled = self.compiled
        written = None
        if compiled is not None and compiled.active:
            written = compiled.tick(k, loop_t, lateness, beat_age, estop, lost)
            if written is None:
                self.handed_back += 1
        if written is not None:
            reading = compiled.reading()
            fault = Fault.NONE
            last = compiled.last_tick()
        else:
            reading = self.backend.read(loop_t)
            tau = self.pipeline.control(k, reading)
            *written, fault = self.supervisor.step(
                loop_t, reading, *self.pipeline.rates, *tau, lateness, beat_age, estop, lost)
            self.backend.write(*written)
            last = self.pipeline.last_tick
        self.tick_index += 1
        if self.tick_index == self.pipeline.approach_ticks:
            if compiled is not None:
                compiled.hand_back()
            self.backend.cue_patient()
        if compiled is not None and not compiled.active and fault is Fault.NONE:
            compiled.take_over()
        if compiled is not None and self.keep_noise:
            compiled.keep_noise()
        return tuple(reading), tuple(written), fault, last


def loop_times(n, seed=0):
    """Loop times with the jitter and one stall of a real loop."""
    rng = np.random.default_rng(seed)
    times = np.arange(n) * PERIOD + rng.uniform(0.0, 0.0003, n)
    times[n // 2:] += 0.007
    return times.tolist()


def same(a, b):
    return all((x == y) or (isinstance(x, float) and math.isnan(x) and math.isnan(y))
               for x, y in zip(a, b, strict=True))


def same_tick(a, b):
    """Two `Rig.running` results equal (NaN equal to NaN)."""
    return (same(a[0], b[0]) and same(a[1], b[1]) and a[2] == b[2]
            and same(a[3], b[3]))


def connect_and_start(rigs, idle_ticks=40):
    times = loop_times(idle_ticks + 6000)
    for t in times[:idle_ticks]:
        readings = [rig.idle(t) for rig in rigs]
    for rig, (reading, _) in zip(rigs, readings, strict=True):
        rig.start(reading)
    return times[idle_ticks:]


@pytest.mark.parametrize(("patient", "controller", "keep_noise"), [
    ("healthy", "smc", False), ("tremor", "ctpid", True)])
def test_a_whole_trial_matches_the_python_objects(patient, controller, keep_noise):
    """The approach, the cue, the exercise, a 7 ms stall and a noise block boundary
    (handed back for a new block, or topped up between ticks as the loop does): every
    reading, torque and record value equal, and the objects' state after hand_back
    equal to the Python objects' own."""
    params = PARAMS.replace(controller=controller)
    python, compiled = Rig(False, patient, params), Rig(True, patient, params)
    compiled.keep_noise = keep_noise
    times = connect_and_start([python, compiled])
    total = python.pipeline.total_ticks
    assert total > NOISE_BLOCK  # the compiled tick must hand one tick back for new noise
    for t in times[:total]:
        a = python.running(t)
        b = compiled.running(t)
        assert a[2] is b[2] is Fault.NONE
        assert same_tick(a, b), t
    assert compiled.handed_back == (0 if keep_noise else 1)
    compiled.compiled.hand_back()
    sa, sb = snapshot(python.backend), snapshot(compiled.backend)
    assert sa.steps == sb.steps
    assert sa.state == sb.state
    assert sa.last == sb.last
    # the same noise stream, however it was cut into blocks: the next rows agree
    assert [python.backend._noise() for _ in range(3)] == [
        compiled.backend._noise() for _ in range(3)]
    assert same(python.supervisor.history(), compiled.supervisor.history())
    assert [e.rate for e in python.pipeline.rate_estimators] == [
        e.rate for e in compiled.pipeline.rate_estimators]


@pytest.mark.parametrize(("changes", "fault"), [
    ({"estop": True}, Fault.ESTOP),
    ({"beat_age": 0.6}, Fault.HEARTBEAT_LOST),
    ({"lost": True}, Fault.RECORDING_LOST),
    ({"lateness": 0.011}, Fault.LATE_TICK),
])
def test_a_tripping_tick_is_handed_back_and_faults_in_python(changes, fault):
    python, compiled = Rig(False), Rig(True)
    times = connect_and_start([python, compiled])
    for t in times[:700]:
        assert same_tick(python.running(t), compiled.running(t))
    a = python.running(times[700], **changes)
    b = compiled.running(times[700], **changes)
    assert a[2] == b[2] == fault
    assert compiled.handed_back == 1
    assert not compiled.compiled.active
    assert python.supervisor.fault_detail == compiled.supervisor.fault_detail
    assert same(a[0], b[0])
    assert a[1] == b[1] == (0.0, 0.0)


def test_late_ticks_in_a_row_are_counted_across_the_hand_over():
    """Nine late ticks compiled, the tenth trips the run rule in Python: the count was
    carried over."""
    python, compiled = Rig(False), Rig(True)
    times = connect_and_start([python, compiled])
    for t in times[:100]:
        python.running(t)
        compiled.running(t)
    for t in times[100:109]:
        assert python.running(t, lateness=0.003)[2] is Fault.NONE
        assert compiled.running(t, lateness=0.003)[2] is Fault.NONE
    assert compiled.handed_back == 0
    assert python.running(times[109], lateness=0.003)[2] == Fault.LATE_TICK
    assert compiled.running(times[109], lateness=0.003)[2] == Fault.LATE_TICK


def test_warming_changes_nothing():
    python, compiled = Rig(False), Rig(True)
    times = connect_and_start([python, compiled])
    for i, t in enumerate(times[:300]):
        compiled.compiled.warm(compiled.tick_index, t)
        assert same_tick(python.running(t), compiled.running(t)), i


def test_only_the_plain_simulator_runs_compiled():
    rig = Rig(True)
    assert unsupported_live(rig.backend, rig.pipeline, rig.supervisor) == ""
    wrapped = FaultInjectingBackend(rig.backend, "stale", at_s=1.0)
    assert "FaultInjectingBackend" in unsupported_live(wrapped, rig.pipeline, rig.supervisor)
    with pytest.raises(ValueError, match="FaultInjectingBackend"):
        CompiledTick(wrapped, rig.pipeline, rig.supervisor)


def test_take_over_is_refused_while_a_fault_is_latched():
    python = Rig(True)
    (t, *_) = connect_and_start([python])
    python.running(t, estop=True)
    assert python.compiled.take_over() == "a fault is latched"
