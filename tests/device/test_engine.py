"""The live loop's tick engine: compiled and interpreted it is the same code, so the same
ticks, records and faults bit for bit; and it does a tick in the loop's order, with the
supervisor's last word."""

import math

import numpy as np
import pytest

from core.trial import THESIS_SUBJECT
from device.errors import BackendError
from device.loop.engine import TickEngine
from device.loop.pipeline import TickPipeline, TrialPlan
from device.safety.faults import Fault
from device.safety.supervisor import SafetySupervisor
from device.sim.faultinjection import FaultInjectingBackend
from device.sim.simulator import SimulatorBackend

PARAMS = THESIS_SUBJECT.replace(repetitions=3)
PERIOD = 0.002


class Rig:
    """One connection's objects, ticked as DeviceLoop ticks them."""

    def __init__(self, compiled: bool, patient: str = "healthy", params=PARAMS,
                 scenario: str | None = None):
        self.plan = TrialPlan.build(params)
        self.backend = SimulatorBackend.from_trial(params, patient, seed=4, robot=self.plan.robot,
                                                   patient_waits=True, compiled=compiled)
        if scenario is not None:
            self.backend = FaultInjectingBackend(self.backend, scenario, at_s=1.5)
        self.pipeline = TickPipeline(self.plan, compiled=compiled)
        self.supervisor = SafetySupervisor(self.plan.robot)
        self.engine = TickEngine(self.backend, self.pipeline, self.supervisor)
        self.backend.open()
        self.trial_tick = None

    rehearse = False

    def tick(self, k, now, lateness=0.0, beat_age=0.0, estop=False, lost=False):
        """One tick: (torques, fault, record) as the loop keeps them (rehearsed first in the
        slack before its deadline when `rehearse`, as the loop does)."""
        if self.rehearse:
            self.engine.rehearse(self.trial_tick, now)
        done = self.engine.step(self.trial_tick, now, lateness, beat_age, estop, lost)
        self.reading = done.reading
        running = self.trial_tick is not None
        record = self.engine.record(done, self.trial_tick if running else k, now, lateness, 3,
                                    running)
        if running:
            self.trial_tick += 1
            if self.trial_tick == self.pipeline.approach_ticks:
                self.backend.cue_patient()
        return (done.torque1_Nm, done.torque2_Nm), done.fault, record[:5] + record[6:]

    def start(self):
        """Start a trial from the last reading, as the loop's Start does."""
        if self.trial_tick is None and not hasattr(self, "reading"):
            self.tick(0, 0.0)
        self.pipeline.begin(self.reading.q1_rad, self.reading.q2_rad,
                            still_s=self.supervisor.limits.restart_ramp_s)
        self.supervisor.restart_ramp()
        self.trial_tick = 0


def same(a, b):
    return all((x == y) or (isinstance(x, float) and math.isnan(x) and math.isnan(y))
               for x, y in zip(a, b, strict=True))


def run_both(ticks, changes=None, rehearse=False, **rig_options):
    """Idle ticks after Connect, then a trial, on both engines, with the jitter and one
    stall of a real loop's robot times; every tick compared. `changes` maps a tick to
    what is different on it (lateness, heartbeat age, e-stop, lost recording)."""
    rigs = Rig(True, **rig_options), Rig(False, **rig_options)
    rigs[0].rehearse = rehearse
    rng = np.random.default_rng(0)
    times = (np.arange(ticks + 40) * PERIOD + rng.uniform(0.0, 0.0003, ticks + 40))
    times[len(times) // 2:] += 0.007
    outputs = []
    for k, now in enumerate(times.tolist()):
        if k == 40:
            for rig in rigs:
                rig.start()
        extra = (changes or {}).get(k, {})
        a, b = (rig.tick(k, now, **extra) for rig in rigs)
        assert a[1] == b[1], k
        assert same(a[0], b[0]), k
        assert same(a[2], b[2]), k
        outputs.append(a)
    return rigs, outputs


@pytest.mark.parametrize(("patient", "controller", "assist"), [
    ("healthy", "smc", "thesis"), ("tremor", "ctpid", "thesis"),
    ("wrong_way", "smc", "as-needed"), ("tremor", "smc", "transparent")])
def test_a_whole_trial_is_the_same_compiled_and_interpreted(patient, controller, assist):
    """The approach, the cue, the exercise, a 7 ms stall: every torque, fault and record
    value equal, and the objects' state after it."""
    params = PARAMS.replace(controller=controller, assist=assist)
    (fast, slow), outputs = run_both(2500, patient=patient, params=params)
    assert all(fault is Fault.NONE for _, fault, _ in outputs)
    assert max(abs(t) for torques, _, _ in outputs for t in torques) > 0.1  # it did work
    np.testing.assert_array_equal(fast.supervisor.state, slow.supervisor.state)
    assert np.asarray(fast.pipeline.vectors.rates).tolist() == list(slow.pipeline.vectors.rates)
    assert fast.backend.truth == slow.backend.truth
    assert np.asarray(fast.pipeline.vectors.guided).tolist() == list(
        slow.pipeline.vectors.guided)


def test_a_transparent_trial_through_its_hold_is_the_same_compiled_and_interpreted():
    """The transparent mode runs its law in the hold too (core.control.transparent): a
    short trial to its end, every tick equal."""
    params = PARAMS.replace(assist="transparent", repetitions=1, duration_s=2.0)
    (fast, slow), outputs = run_both(2300, params=params)
    phases = {record[3] for _, _, record in outputs}
    assert {2, 3} <= phases  # the exercise and the hold ran (the handle starts at the start)
    np.testing.assert_array_equal(fast.supervisor.state, slow.supervisor.state)
    assert fast.backend.truth == slow.backend.truth


@pytest.mark.parametrize(("change", "fault"), [
    ({"estop": True}, Fault.ESTOP),
    ({"beat_age": 0.6}, Fault.HEARTBEAT_LOST),
    ({"lost": True}, Fault.RECORDING_LOST),
    ({"lateness": 0.011}, Fault.LATE_TICK),
])
def test_a_fault_is_latched_the_same_with_the_same_detail(change, fault):
    (fast, slow), outputs = run_both(800, changes={700: change})
    assert outputs[699][1] is Fault.NONE
    assert outputs[700][1] == fault
    assert outputs[700][0] == (0.0, 0.0)
    assert all(out[1] == fault and out[0] == (0.0, 0.0) for out in outputs[700:])
    assert fast.supervisor.fault_detail == slow.supervisor.fault_detail
    assert fast.supervisor.fault_message == slow.supervisor.fault_message


@pytest.mark.parametrize("assist", ["thesis", "as-needed", "transparent"])
def test_rehearsing_each_tick_changes_nothing(assist):
    """The rehearsal runs the coming tick on copies: the ticks that follow are the same
    as without it (the interpreted engine never rehearses)."""
    run_both(1500, rehearse=True, changes={1200: {"estop": True}},
             params=PARAMS.replace(assist=assist))


def test_late_ticks_in_a_row_trip_the_run_rule_on_the_tenth():
    changes = {k: {"lateness": 0.003} for k in range(600, 610)}
    _, outputs = run_both(700, changes=changes)
    assert [out[1] for out in outputs[600:609]] == [Fault.NONE] * 9
    assert outputs[609][1] == Fault.LATE_TICK


@pytest.mark.parametrize("scenario", ["nan", "exception", "encoder_jump", "force_spike"])
def test_a_misbehaving_backend_is_latched_the_same(scenario):
    """Through the fault-injecting wrapper (the generic read → kernel → write path): the
    fault, its detail and every record equal on both engines."""
    (fast, slow), outputs = run_both(1200, scenario=scenario)
    faults = [out[1] for out in outputs if out[1] is not Fault.NONE]
    assert faults, scenario
    assert fast.supervisor.fault_detail == slow.supervisor.fault_detail


def test_a_failed_read_zeroes_the_torque_and_still_leaves_a_record():
    rig = Rig(True, scenario="exception")
    rig.start()
    for k in range(1000):
        torques, fault, record = rig.tick(k, (k + 1) * PERIOD)
        if fault:
            break
    assert fault == Fault.BACKEND_ERROR
    assert torques == (0.0, 0.0)
    assert math.isnan(record[6])  # no angle was read
    assert "injected" in rig.supervisor.fault_detail["error"]


def test_a_write_that_fails_puts_the_backend_in_its_safe_state():
    """A backend other than the simulator (a vendor's, here the fault-injecting wrapper)
    is written to by the engine, which must catch its failure."""
    rig = Rig(True, scenario="nan")

    def broken(torque1, torque2):
        raise BackendError("the amplifier did not answer")

    zeroed = []
    rig.backend.write = broken
    rig.backend.safe_state = lambda: zeroed.append(True)
    rig.tick(0, 0.0)
    assert zeroed == [True]
