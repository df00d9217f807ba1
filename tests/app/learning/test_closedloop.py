"""A learned model in the computed-torque PID (eq. 4.8), closed loop on the simulator's
realistic plant (app.learning.closedloop; the full comparison: bench/learning_control.py).

What learning adds there is what no model of the robot alone has: the passive arm on the
handle (bench/learning_control.py: the plant's own parameters track no better than the
nominal model). A feed-forward network trained on the robot-and-arm torque of three
trials must track a held-out circle (another place, size and speed) at least 20 % better than PID
alone and better than the nominal model; the same network with its weights zeroed (a
constant torque) must not pass that bar, so the bar tests the model's content.
"""

import numpy as np
import pytest

from app.learning import closedloop as cl
from core.learning.tick import LearnedInverseDynamics
from core.learning.training import TrainingOptions, train
from core.robot import RobotModel

GAINS = cl.soft_gains(5.0)  # softer than the console's 20 rad/s: the model's share shows
HELD_OUT = cl.HELD_OUT_TRIALS[1].replace(repetitions=1, controller="ctpid")


@pytest.fixture(scope="module")
def nominal():
    return RobotModel()


@pytest.fixture(scope="module")
def plant(nominal):
    return cl.unknown_plant(nominal)


@pytest.fixture(scope="module")
def learned(nominal, plant):
    trials = (cl.TRAINING_TRIALS[0], cl.TRAINING_TRIALS[2], cl.TRAINING_TRIALS[4])
    runs = cl.training_runs(plant, trials, robot=nominal)
    data = cl.samples_of(runs, nominal, without_hand_force=False)
    result = train(*data, TrainingOptions(kind="fnn", epochs=30, folds=1, seed=0))
    return result


def error_mm(nominal, plant, model) -> float:
    tracking = cl.Tracking.of(cl.run_on_plant(HELD_OUT, plant, cl.ctpid(model, GAINS, nominal),
                                              robot=nominal))
    assert tracking.status == "complete"
    return float(np.hypot(*tracking.rmse_m) * 1e3)


def test_a_learned_model_of_robot_and_arm_tracks_a_held_out_trial(nominal, plant, learned):
    pid = error_mm(nominal, plant, cl.pid_alone(nominal))
    analytic = error_mm(nominal, plant, nominal)
    model = LearnedInverseDynamics(learned.spec, learned.params, "fnn")
    with_model = error_mm(nominal, plant, model)
    zeroed = LearnedInverseDynamics(
        learned.spec, {k: np.zeros_like(v) for k, v in learned.params.items()}, "zeroed")
    without_content = error_mm(nominal, plant, zeroed)
    assert with_model < 0.8 * pid, (with_model, pid)
    assert with_model < analytic, (with_model, analytic)
    assert not without_content < 0.8 * pid, (without_content, pid)


def test_the_compiled_loop_runs_the_learned_model_as_the_interpreted_one(nominal, plant,
                                                                        learned):
    # the loop runs an FNN or a DeLaN compiled (core.learning.kernel), headless runs and
    # the bench interpreted (core.learning.tick): the same trial either way
    from device.compiled.warmup import load_kernels

    load_kernels(("headless",))
    model = LearnedInverseDynamics(learned.spec, learned.params, "fnn")
    runs = [cl.run_on_plant(HELD_OUT, plant, cl.ctpid(model, GAINS, nominal), robot=nominal,
                            compiled=compiled) for compiled in (False, True)]
    assert [r.status for r in runs] == ["complete", "complete"]
    interpreted, fast = (r.records for r in runs)
    assert np.max(np.abs(fast["position"] - interpreted["position"])) < 1e-9  # m
    assert np.max(np.abs(fast["torque_applied"] - interpreted["torque_applied"])) < 1e-6


def test_the_unknown_robot_is_not_the_model(nominal, plant):
    # the comparison is worth something only if the plant differs from the nominal model
    # in what eq. 4.9 leaves to learn: friction, stiffness, drive delay
    described = plant.describe()
    assert plant.robot != nominal
    assert min(described["joint_coulomb_Nm"]) > max(nominal.friction.joint_coulomb_Nm)
    assert min(described["joint_stiffness_Nm_rad"]) > 0.0
    assert described["actuator_delay_periods"] == 1


def test_inertia_scaled_scales_the_mass_matrix(nominal):
    q = nominal.ik(cl.REST_M)
    assert np.allclose(cl.inertia_scaled(nominal, 1.2).mass_matrix(q),
                       1.2 * nominal.mass_matrix(q), rtol=1e-12)
