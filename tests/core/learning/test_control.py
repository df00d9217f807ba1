"""A learned model inside the computed-torque PID (eq. 4.8): trained on the robot's own
inverse dynamics (friction and stiffness included), it tracks as the exact model does and
better than the PID without a model; closed loop on the robot's forward dynamics.

The outer loop's poles are put at 4 rad/s here (the console's default is 20): with the
default gains the PID alone already tracks this slow swing to 2.6 mrad, as well as the
exact model (2.7 mrad), and no model could show what it adds."""

import math

import numpy as np
import pytest

from core.control.ctpid import ComputedTorquePID, CTPIDGains, DiagonalInertia
from core.learning import networks as nw
from core.learning.tick import LearnedInverseDynamics
from core.learning.training import TrainingOptions, make_spec, train
from core.robot import RobotModel

DT = 0.002
W = 4.0  # rad/s, the outer loop's triple pole
GAINS = CTPIDGains(kp_1_s2=(3 * W**2,) * 2, ki_1_s3=(W**3,) * 2, kd_1_s=(3 * W,) * 2)


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


@pytest.fixture(scope="module")
def q0(robot):
    return np.asarray(robot.ik([-0.30, 0.30]))


@pytest.fixture(scope="module")
def learned(robot, q0):
    rng = np.random.default_rng(0)
    n = 4000
    q = q0 + rng.uniform(-0.4, 0.4, (n, 2))
    qd = rng.normal(0.0, 1.0, (n, 2))
    qdd = rng.normal(0.0, 6.0, (n, 2))
    tau = np.stack(robot.inverse_dynamics_terms(q[:, 0], q[:, 1], qd[:, 0], qd[:, 1],
                                                qdd[:, 0], qdd[:, 1]), axis=-1)
    result = train(q, qd, qdd, tau, np.repeat(np.arange(40), 100),
                   TrainingOptions(kind="delan", epochs=100, batch_size=64, folds=1, seed=0,
                                   mass_scale=0.5))
    return LearnedInverseDynamics(result.spec, result.params, "delan-robot")


def tracking_rmse(robot, q0, model) -> float:
    controller = ComputedTorquePID(model, GAINS, torque_limit_Nm=robot.max_joint_torque_Nm)
    q, qd = q0.copy(), np.zeros(2)
    errors = []
    for k in range(1500):
        t = k * DT
        w = np.array([2 * math.pi * 0.5, 2 * math.pi * 0.7])
        r = q0 + 0.2 * np.sin(w * t)
        rd, rdd = 0.2 * w * np.cos(w * t), -0.2 * w**2 * np.sin(w * t)
        tau = controller.step(DT, q[0], q[1], qd[0], qd[1], r[0], r[1], rd[0], rd[1],
                              rdd[0], rdd[1])
        qdd = np.asarray(robot.forward_dynamics_terms(q[0], q[1], qd[0], qd[1], *tau))
        qd = qd + DT * qdd
        q = q + DT * qd
        errors.append(r - q)
    return float(np.sqrt(np.mean(np.square(errors))))


def test_learned_model_tracks_as_the_exact_model(robot, q0, learned):
    nominal = tracking_rmse(robot, q0, robot)
    with_learned = tracking_rmse(robot, q0, learned)
    without_model = tracking_rmse(robot, q0, DiagonalInertia(robot, q0))
    assert abs(with_learned - nominal) < 0.05 * nominal, (with_learned, nominal)
    assert with_learned < 0.8 * without_model, (with_learned, without_model)


def test_a_model_of_another_size_cannot_drive_the_robot():
    spec = {"kind": "fnn", "dof": 3, "hidden": [2], "position_inputs": [0, 1, 2],
            "input_mean": [0.0] * 9, "input_std": [1.0] * 9, "output_mean": [0.0] * 3,
            "output_std": [1.0] * 3}
    with pytest.raises(ValueError, match="3 coordinates cannot drive the 2-joint robot"):
        LearnedInverseDynamics(spec, {})


def test_the_controllers_reset_starts_a_recurrent_model_from_its_zero_state(robot, q0):
    # a trial's first tick must not depend on the last trial's: pipeline.begin resets the
    # controller, which resets its model
    rng = np.random.default_rng(1)
    q, qd, qdd = (rng.normal(size=(50, 2)) for _ in range(3))
    spec = make_spec(TrainingOptions(kind="rnn"), q, qd, qdd, q + qd)
    params = {k: rng.normal(scale=0.5, size=s) for k, s in nw.param_shapes(spec).items()}
    model = LearnedInverseDynamics(spec, params, "gru")
    controller = ComputedTorquePID(model, GAINS, torque_limit_Nm=(1e6, 1e6))  # unclipped
    args = (DT, *q0, 0.0, 0.0, *(q0 + 0.01), 0.1, 0.1, 0.0, 0.0)
    first = controller.step(*args)
    assert controller.step(*args) != first  # the state moved on
    controller.reset()
    assert not model.tick.h.any()
    assert controller.step(*args) == first
