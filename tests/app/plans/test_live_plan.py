"""A plan of three blocks run end to end on the simulator through the live loop and recorder
(issue 30, what the tests must prove): the right trials, counts and rests for the healthy,
weak and passive virtual patients; Stop and E-STOP in a block and in a rest end the plan
at once with the robot made safe, and nothing runs after. Trials are short (two laps of
a 5 cm D and one of a 5 cm circle, 1 s each; a reach of 2 s: in a 1 s reach the passive
arm is not brought back in time to count its return; rests of 0.5 s)."""

import itertools
import math

import pytest

from app.plans.dose import run_dose, trial_dose
from app.plans.live import LivePlan, PlanRefused
from app.records.datadir import DataDir
from app.records.registry import Registry
from core.plan import Block, Plan
from device.loop.client import DeviceClient
from device.loop.messages import BackendConfig
from device.loop.states import State

pytestmark = pytest.mark.slow

REST_S = 0.5
PLAN = Plan("Three short blocks", (
    Block(shape="d", repetitions=2, duration_s=1.0, rest_s=REST_S, radius_m=0.05, name="D"),
    Block(shape="circle", repetitions=1, duration_s=1.0, rest_s=REST_S, radius_m=0.05,
          name="Circle"),
    Block(shape="reach", repetitions=1, duration_s=2.0, rest_s=0.0, radius_m=0.06,
          name="Reach"),
))
PLANNED = (2, 1, 2)  # movements: two laps of the D, one circle, a reach out and back


@pytest.fixture(scope="module")
def client():
    with DeviceClient() as c:
        yield c


@pytest.fixture
def ready(client):
    """The loop as a new plan finds it: no emergency stop held, no fault latched."""
    client.estop(False)
    if client.state == State.FAULTED:
        client.wait_for_samples(2)  # a whole tick has seen the stop released
        assert client.clear_fault().ok
    return client


@pytest.fixture
def registry(tmp_path):
    return Registry(DataDir(tmp_path / "data"))


def patient_with_plan(registry, plan=PLAN):
    code = registry.create_patient("Ada", "Example", body_mass_kg=91.0, upper_arm_m=0.3048,
                                   forearm_m=0.3048, side="right",
                                   shoulder_m=(-0.12, 0.73)).code
    return registry.save_plan(code, plan)


def run(registry, client, kind="healthy", watch=None):
    live = LivePlan(registry, patient_with_plan(registry), client,
                    BackendConfig(patient=kind, seed=3))
    return live, live.run(watch, timeout_s=600.0)


@pytest.mark.parametrize("kind", ["healthy", "weak", "passive"])
def test_a_plan_of_three_blocks_runs_whole_with_its_counts_rests_and_trials(
        registry, ready, kind):
    live, result = run(registry, ready, kind)
    assert (result.outcome, result.reason) == ("complete", "")
    stored = registry.plan_run(result.run_id)
    assert stored.status == "complete"
    assert [(s.kind, s.block, s.round) for s in stored.steps] == [
        ("trial", 1, 1), ("rest", 1, 1), ("trial", 2, 1), ("rest", 2, 1), ("trial", 3, 1)]
    # one trial per block, each registered complete with its file, linked to its block
    trials = [registry.trial(s.trial_id) for s in stored.trial_steps()]
    assert [t.status for t in trials] == ["complete"] * 3
    assert [t.parameters["shape"] for t in trials] == ["d", "circle", "reach"]
    assert [t.parameters["repetitions"] for t in trials] == [2, 1, 1]
    assert tuple(result.trial_ids) == tuple(t.id for t in trials)
    # the counts are what the files say, and what the plan prescribed
    files = [trial_dose(registry.trial_path(t)) for t in trials]
    assert tuple(f.movements for f in files) == PLANNED
    assert [c.movements for c in live.runner.counts] == list(PLANNED)
    dose = run_dose(registry, result.run_id)
    assert [b.movements for b in dose.blocks] == list(PLANNED)
    assert dose.movements == dose.planned_movements == 5
    for f, block in zip(files, PLAN.blocks, strict=True):
        # the exercise ran its laps at least (the patient may lag behind in as-needed)
        assert f.active_s >= block.laps * block.duration_s - 0.01
    assert dose.active_s == pytest.approx(sum(f.active_s for f in files))
    # each rest was whole before the next block began
    assert [s.taken_s for s in stored.steps if s.kind == "rest"] == [REST_S, REST_S]
    assert dose.rest_s == 2 * REST_S
    for before, after in itertools.pairwise(trials):
        assert (after.started_at - before.ended_at).total_seconds() >= REST_S - 0.05


def pressed(what, when):
    """A watch that presses `what` ('stop' or 'estop') once `when(state)` holds."""
    done = []

    def watch(live, state):
        if not done and when(state):
            done.append(state)
            (live.press_stop if what == "stop" else live.press_estop)()
    return watch, done


def in_block_2(state):
    return state.phase == "running" and state.block == 2


def in_the_first_rest(state):
    return state.phase == "resting" and state.block == 1


@pytest.mark.parametrize(("what", "when", "outcome", "robot"), [
    ("stop", in_block_2, "stopped", State.CONNECTED),
    ("stop", in_the_first_rest, "stopped", State.CONNECTED),
    ("estop", in_block_2, "emergency_stop", State.FAULTED),
    ("estop", in_the_first_rest, "emergency_stop", State.FAULTED),
], ids=["stop in a block", "stop in a rest", "e-stop in a block", "e-stop in a rest"])
def test_stop_and_the_emergency_stop_end_the_plan_at_once_and_safely(
        registry, ready, what, when, outcome, robot):
    watch, done = pressed(what, when)
    _, result = run(registry, ready, watch=watch)
    assert done, "the moment to press never came"
    assert result.outcome == outcome
    stored = registry.plan_run(result.run_id)
    assert stored.status == outcome
    kinds = [(s.kind, s.block) for s in stored.steps]
    trials = [registry.trial(s.trial_id) for s in stored.trial_steps()]
    if when is in_block_2:
        assert kinds == [("trial", 1), ("rest", 1), ("trial", 2)]
        assert trials[1].status == ("stopped_early" if what == "stop" else "faulted")
    else:
        assert kinds == [("trial", 1), ("rest", 1)]
        assert stored.steps[1].taken_s < REST_S  # the rest as it was when the plan ended
    assert trials[0].status == "complete"
    assert all(t.finished for t in trials)  # every trial finished into the registry
    # the robot is safe: connected at zero torque after a Stop, latched after an E-STOP
    ready.wait_state(robot, 30.0)
    assert ready.state == robot
    # and nothing ran after the end: no trial of the patient beyond the run's
    assert len(registry.trials_for_patient(stored.patient_code)) == len(trials)


def test_a_plan_a_block_of_which_the_patient_cannot_reach_is_refused_before_anything_runs(
        registry, client):
    far = PLAN.with_block(2, PLAN.blocks[2].replace(radius_m=0.2))
    stored = patient_with_plan(registry, far)
    with pytest.raises(PlanRefused, match=r"block 3 \(Reach\): point"):
        LivePlan(registry, stored, client, BackendConfig(patient="healthy", seed=3))
    assert registry.plan_runs_for_patient(stored.patient_code) == []
    assert registry.trials_for_patient(stored.patient_code) == []


def test_pause_and_stop_mid_movement_leave_the_robot_connected_without_a_fault(
        registry, ready):
    """A window's walk through a plan: Pause, then the robot's Stop, during a plan's trial
    latched "the handle moved at 1.01 m/s (limit 1.00 m/s)". The trial's end told the
    virtual patient to rest, and it rested holding the path's start posture: from the far
    side of the D its stiffness threw the handle back there at up to 1.3 m/s, the robot at
    zero torque. Both are pressed here with the hand far from the start (17 cm and more
    of the D's 20), wherever the loaded machine's ticks put that moment; the patient now
    rests its hand where it is, and the plan pauses, resumes and stops without a fault."""
    plan = Plan("Stopped mid-movement", (
        Block(shape="d", repetitions=3, duration_s=2.0, assist="transparent", rest_s=0.0,
              name="D"),))
    stored = patient_with_plan(registry, plan)
    live = LivePlan(registry, stored, ready, BackendConfig(patient="healthy", seed=3))
    pressed: list[str] = []
    seen = {"start": None, "paused_at": None, "faults": set()}

    def hand_far() -> bool:
        far = False
        for r in ready.live_records():
            seen["faults"].add(int(r["fault"]))
            if r["phase"] != 2:
                seen["start"] = None
            elif seen["start"] is None:
                seen["start"] = r["position_desired"].copy()
            elif math.dist(r["position"], seen["start"]) >= 0.17:
                far = True
        return far

    def watch(live, state):
        far = hand_far()
        if state.phase == "running" and far:
            if not pressed:
                pressed.append("pause")
                seen["paused_at"] = live.clock()
                live.press_pause()
            elif pressed == ["pause", "resume"]:
                pressed.append("stop")
                live.press_stop()
        elif state.phase == "paused" and pressed == ["pause"] and (
                live.clock() - seen["paused_at"] > 3.0):
            # longer than the old throw back to the start took: nothing latched meanwhile
            pressed.append("resume")
            live.press_resume()

    ready.live_records()  # what the module's earlier tests left (their e-stops)
    result = live.run(watch, timeout_s=600.0)
    assert pressed == ["pause", "resume", "stop"]
    assert result.outcome == "stopped", result.reason
    trials = [registry.trial(t) for t in result.trial_ids]
    assert [t.status for t in trials] == ["stopped_early", "stopped_early"]
    # and the idle robot after the Stop: two seconds at zero torque, nothing latched
    ready.wait_for_samples(1000)
    hand_far()
    assert seen["faults"] == {0}
    assert ready.state == State.CONNECTED
