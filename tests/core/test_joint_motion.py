"""core.arrays.joint_motion takes the sines and cosines once for J and J̇, and matrix2 puts
the entries in place: both give the numbers the separate calls and the nested stacks gave,
bit for bit (a trial's reference rows and a virtual patient's plan are made of them)."""

import numpy as np
import pytest

from core.arrays import joint_motion, matrix2, solve2
from core.robot import RobotModel
from core.trial import THESIS_SUBJECT


def separately(model, position, velocity, acceleration):
    """joint_motion as it was: J and J̇ each from its own sines."""
    q = model.ik(position)
    jac = model.jacobian(q)
    qd = solve2(jac, velocity)
    rhs = acceleration - np.einsum("nij,nj->ni", model.jacobian_dot(q, qd), qd)
    return q, qd, solve2(jac, rhs)


def nested_stacks(terms):
    a, b, c, d = np.broadcast_arrays(*(np.asarray(t, dtype=float) for t in terms))
    return np.stack((np.stack((a, b), axis=-1), np.stack((c, d), axis=-1)), axis=-2)


@pytest.mark.parametrize("model", [RobotModel(), THESIS_SUBJECT.arm(),
                                   THESIS_SUBJECT.replace(side="left").arm()],
                         ids=["robot", "right arm", "left arm"])
def test_joint_motion_is_the_separate_jacobians_bit_for_bit(model):
    rng = np.random.default_rng(1)
    trajectory = THESIS_SUBJECT.replace(repetitions=2, timing="minimum_jerk").trajectory()
    sample = trajectory.sample(np.arange(4_001) * 0.002)
    velocity = sample.velocity_m_s + rng.normal(0.0, 0.01, sample.velocity_m_s.shape)
    acceleration = sample.acceleration_m_s2 * 1.5
    position = sample.position_m  # the handle's path: in the robot's and the arm's reach
    got = joint_motion(model, position, velocity, acceleration)
    want = separately(model, position, velocity, acceleration)
    for a, b in zip(got, want, strict=True):
        assert a.tobytes() == b.tobytes()


def test_matrix2_is_the_nested_stacks_bit_for_bit():
    rng = np.random.default_rng(2)
    terms = (rng.normal(size=50), -0.0, rng.normal(size=50), np.nan)
    assert matrix2(terms).tobytes() == nested_stacks(terms).tobytes()
    assert matrix2((1.0, 2.0, 3.0, 4.0)).tobytes() == nested_stacks((1.0, 2.0, 3.0,
                                                                      4.0)).tobytes()
