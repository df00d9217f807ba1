"""The compiled headless engine gives the Python engine's records bit for bit, and hands
anything out of the ordinary back to it."""

import numpy as np
import pytest

from app.trials.headless import simulate
from core.control.base import make_controller
from core.errors import ParameterError
from core.robot import Friction, RobotModel, Stiffness
from core.trial import THESIS_SUBJECT
from device.compiled import trial as compiled
from device.loop.pipeline import TickPipeline, TrialPlan
from device.safety.supervisor import SafetySupervisor
from device.sim.patients import PATIENT_KINDS
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


@pytest.mark.parametrize("changes", [
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


def test_a_fault_is_handed_to_the_python_engine_which_reports_it():
    """A subject pushing 50 N the wrong way drives the handle over the speed limit: the
    compiled run stops at that tick and the Python engine replays the trial to write
    the fault with its values."""
    options = {"patient": "wrong_way", "seed": 0, "patient_options": {
        "wrong_way_force_N": 50.0, "wrong_way_fraction": 0.9, "wrong_way_episode_s": 5.0}}
    auto = simulate(SHORT, **options)
    slow = simulate(SHORT, engine="python", **options)
    assert slow.status == "faulted"
    assert auto.engine == "python"
    fault_tick = slow.events[-1]["tick"]
    assert auto.handed_over == f"tick {fault_tick}: a safety check tripped"
    assert auto.events == slow.events
    assert_same_records(auto.records, slow.records)


def test_an_unknown_engine_is_refused_by_name():
    with pytest.raises(ParameterError, match="engine"):
        simulate(SHORT, engine="fortran")


def objects(**simulator_options):
    plan = TrialPlan.build(SHORT)
    backend = SimulatorBackend.from_trial(SHORT, "healthy", robot=plan.robot,
                                          **simulator_options)
    return plan, backend, TickPipeline(plan), SafetySupervisor(plan.robot)


def test_configurations_without_a_compiled_form_are_named():
    plan, backend, pipeline, supervisor = objects()
    assert compiled.unsupported(backend, pipeline, supervisor) == ""

    _, rk4, _, _ = objects(integrator="rk4")
    assert "rk4" in compiled.unsupported(rk4, pipeline, supervisor)

    _, waiting, _, _ = objects(patient_waits=True)
    assert "waits" in compiled.unsupported(waiting, pipeline, supervisor)

    class LearnedModel:  # an inverse-dynamics model of chapter 4's kind
        max_joint_torque_Nm = (2.0, 2.0)

        def inverse_dynamics_terms(self, q1, q2, qd1, qd2, qdd1, qdd2, fx=0.0, fy=0.0):
            return (0.0, 0.0)

    learned = TickPipeline(plan, controller=make_controller("ctpid", LearnedModel()))
    assert "LearnedModel" in compiled.unsupported(backend, learned, supervisor)
    outcome = compiled.run(backend, learned, supervisor)
    assert isinstance(outcome, compiled.Abandoned)
    assert outcome.tick == 0
