"""The compiled headless engine gives the interpreted (Python) engine's records bit for
bit: both run the same kernels (core.kernels), so any difference is a bug of the
compiler or of a kernel that is not what numba can compile faithfully."""

import numpy as np
import pytest

from app.trials.headless import simulate
from core.control.base import make_controller
from core.errors import ParameterError
from core.robot import Friction, RobotModel, Stiffness
from core.trial import THESIS_SUBJECT
from device.loop.engine import run_trial
from device.loop.pipeline import TickPipeline, TrialPlan
from device.safety.supervisor import SafetySupervisor
from device.sim.patient_parameters import PATIENT_KINDS
from device.sim.simulator import SimulatorBackend

SHORT = THESIS_SUBJECT.replace(repetitions=1)


def assert_same_records(a: np.ndarray, b: np.ndarray) -> None:
    assert a.dtype == b.dtype
    assert len(a) == len(b)
    for name in a.dtype.names:
        equal = (np.array_equal(a[name], b[name], equal_nan=True)
                 if a[name].dtype.kind == "f" else np.array_equal(a[name], b[name]))
        assert equal, f"channel {name} differs between the engines"


def both(params, **options):
    fast = simulate(params, engine="compiled", **options)
    slow = simulate(params, engine="python", **options)
    return fast, slow


@pytest.mark.parametrize("controller", ["smc", "ctpid"])
@pytest.mark.parametrize("patient", PATIENT_KINDS)
def test_every_patient_and_controller_gives_the_python_records(patient, controller):
    fast, slow = both(SHORT.replace(controller=controller), patient=patient, seed=7)
    assert (fast.engine, slow.engine) == ("compiled", "python")
    assert fast.status == slow.status == "complete"
    assert fast.events == slow.events
    assert_same_records(fast.records, slow.records)


@pytest.mark.parametrize("patient", PATIENT_KINDS)
def test_the_as_needed_mode_gives_the_python_records(patient):
    fast, slow = both(SHORT.replace(assist="as-needed", repetitions=2), patient=patient,
                      seed=5)
    assert fast.status == slow.status == "complete"
    assert_same_records(fast.records, slow.records)
    assert np.array_equal(fast.feedforward_N, slow.feedforward_N)


@pytest.mark.parametrize("changes", [
    {"assist": "as-needed", "controller": "ctpid", "assistance_level": 0.3},
    {"assist": "as-needed", "shape": "reach", "centre_m": (-0.25, 0.40), "radius_m": 0.05},
    {"timing": "minimum_jerk", "repetitions": 2},
    {"assistance_level": 0.4, "tolerance_rad": 0.6, "clockwise": False},
    {"shape": "circle"},
    {"shape": "figure8", "radius_m": 0.06, "controller": "ctpid"},
    {"shape": "reach", "centre_m": (-0.25, 0.40), "radius_m": 0.05},
    {"shape": "targets", "n_targets": 4, "body_mass_kg": 60.0},
], ids=lambda c: ",".join(f"{k}={v}" for k, v in c.items()))
def test_other_exercises_and_settings_give_the_python_records(changes):
    params = SHORT.replace(**changes)
    fast, slow = both(params, patient="weak", seed=2)
    assert fast.engine == "compiled"
    assert_same_records(fast.records, slow.records)


def test_a_robot_with_handle_friction_and_joint_stiffness_gives_the_python_records():
    """The branches the thesis robot's defaults leave off: friction at the handle
    (smooth Coulomb and viscous) and a joint spring, in the plant and in both laws."""
    robot = RobotModel(
        friction=Friction(ee_coulomb_N=0.4, ee_viscous_Ns_m=0.8),
        stiffness=Stiffness(k11_Nm_rad=0.3, k12_Nm_rad=0.05, k22_Nm_rad=0.2,
                            q1_rest_rad=1.6, q2_rest_rad=0.9),
    )
    for controller in ("smc", "ctpid"):
        fast, slow = both(SHORT.replace(controller=controller), patient="spastic", seed=1,
                          robot=robot)
        assert fast.engine == "compiled"
        assert_same_records(fast.records, slow.records)


def test_a_fault_stops_both_engines_at_the_same_tick_with_the_same_event():
    """A subject pushing 50 N the wrong way overpowers the drives, which push back at
    their clamp for a second (H2) or lose the handle over the speed limit: the compiled
    and the interpreted ticks latch the same fault at the same tick, and the supervisor
    words it the same (it runs the same checks on the same numbers)."""
    options = {"patient": "wrong_way", "seed": 0, "patient_options": {
        "wrong_way_force_N": 50.0, "wrong_way_fraction": 0.9, "wrong_way_episode_s": 5.0}}
    fast, slow = both(SHORT, **options)
    assert fast.status == slow.status == "faulted"
    assert fast.events == slow.events
    assert fast.events[-1]["values"]["fault"] in ("joint_speed", "ee_speed",
                                                   "torque_saturated")
    assert_same_records(fast.records, slow.records)
    assert fast.records["fault"][-1] != 0
    np.testing.assert_array_equal(fast.records["torque_applied"][-1], 0.0)


def test_an_unknown_engine_is_refused_by_name():
    with pytest.raises(ParameterError, match="engine"):
        simulate(SHORT, engine="fortran")


class LearnedModel:
    """An inverse-dynamics model of chapter 4's kind: no constants for the kernels. It
    counts its calls and answers a torque the kernels' laws could not give."""

    max_joint_torque_Nm = (2.0, 2.0)

    def __init__(self):
        self.calls = 0

    def inverse_dynamics_terms(self, q1, q2, qd1, qd2, qdd1, qdd2, fx=0.0, fy=0.0):
        self.calls += 1
        return (0.0125, -0.0125)


def test_a_controller_the_kernels_do_not_know_runs_interpreted_through_its_own_step():
    plan = TrialPlan.build(SHORT)
    model = LearnedModel()
    controller = make_controller("ctpid", model)
    with pytest.raises(ParameterError, match="compiled") as error:
        TickPipeline(plan, controller=controller, compiled=True)
    assert "LearnedModel" in str(error.value)
    pipeline = TickPipeline(plan, controller=controller)
    simulator = SimulatorBackend.from_trial(SHORT, "healthy", robot=plan.robot,
                                            compiled=False)
    outcome = run_trial(simulator, pipeline, SafetySupervisor(plan.robot))
    assert outcome.status == "complete"
    # every tick asked the learned model, and its answer is the controller's torque
    assert model.calls == len(outcome.records)
    np.testing.assert_array_equal(outcome.records["torque_controller"],
                                  [[0.0125, -0.0125]] * len(outcome.records))


def test_a_headless_run_needs_one_flavour():
    plan = TrialPlan.build(SHORT)
    simulator = SimulatorBackend.from_trial(SHORT, "healthy", robot=plan.robot, compiled=True)
    with pytest.raises(ValueError, match="one flavour"):
        run_trial(simulator, TickPipeline(plan), SafetySupervisor(plan.robot))
