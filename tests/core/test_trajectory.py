"""Paths and timing laws: geometry, continuity and derivative consistency."""

import math

import numpy as np
import pytest

from core.errors import ParameterError
from core.robot import RobotModel
from core.trajectory import (
    Trajectory,
    centre_out,
    circle,
    d_shape,
    figure_eight,
    make_path,
    straight_reach,
)

D = d_shape((-0.3, 0.3), 0.1)


def test_d_shape_geometry():
    assert D.length == pytest.approx(0.2 + math.pi * 0.1)
    pts = D.points()
    assert pts[:, 0].min() == pytest.approx(-0.3)
    assert pts[:, 0].max() == pytest.approx(-0.2, abs=1e-6)
    assert pts[:, 1].min() == pytest.approx(0.2)
    assert pts[:, 1].max() == pytest.approx(0.4)
    np.testing.assert_allclose(pts[0], pts[-1], atol=1e-12)  # closed


@pytest.mark.parametrize(
    "path",
    [D, d_shape((-0.3, 0.3), 0.1, clockwise=False), circle((0, 0.4), 0.1),
     figure_eight((-0.2, 0.35), 0.06), centre_out((-0.2, 0.35), 0.08, 4),
     straight_reach((-0.2, 0.45), 0.15)],
)
@pytest.mark.parametrize("timing", ["constant_speed", "minimum_jerk"])
def test_velocity_and_acceleration_are_derivatives_of_position(path, timing):
    traj = Trajectory(path, 4.0, 2, timing)
    h = 1e-5
    # avoid the instants where constant speed switches segment (velocity jumps there)
    t = np.linspace(0.013, 7.987, 157)
    s = traj.sample(t)
    sp, sm = traj.sample(t + h), traj.sample(t - h)
    same = (sp.segment == sm.segment) & (sp.repetition == sm.repetition)
    num_v = (sp.position_m - sm.position_m) / (2 * h)
    num_a = (sp.velocity_m_s - sm.velocity_m_s) / (2 * h)
    np.testing.assert_allclose(s.velocity_m_s[same], num_v[same], atol=1e-6)
    np.testing.assert_allclose(s.acceleration_m_s2[same], num_a[same], atol=1e-4)


def test_constant_speed_walks_the_path_at_its_mean_speed():
    traj = Trajectory(D, 4.0)
    s = traj.sample(np.linspace(0.01, 3.99, 300))
    np.testing.assert_allclose(np.linalg.norm(s.velocity_m_s, axis=1), D.length / 4.0)


def test_minimum_jerk_rests_at_every_corner_and_peaks_at_15_8():
    traj = Trajectory(D, 4.0, timing="minimum_jerk")
    corners = np.array(traj.segment_times_s)
    s = traj.sample(corners[:-1])
    np.testing.assert_allclose(s.velocity_m_s, 0.0, atol=1e-12)
    t = np.linspace(0, 4, 40001)
    speed = np.linalg.norm(traj.sample(t).velocity_m_s, axis=1)
    assert speed.max() == pytest.approx(traj.peak_speed_m_s, rel=1e-4)


def test_scalar_at_matches_vectorised_sample():
    traj = Trajectory(figure_eight((-0.2, 0.35), 0.06), 5.0, 3, "minimum_jerk")
    times = np.linspace(-1.0, 16.0, 97)
    s = traj.sample(times)
    for i, t in enumerate(times):
        one = traj.at(float(t))
        np.testing.assert_allclose(one[0:2], s.position_m[i], atol=1e-12)
        np.testing.assert_allclose(one[2:4], s.velocity_m_s[i], atol=1e-12)
        np.testing.assert_allclose(one[4:6], s.acceleration_m_s2[i], atol=1e-9)
        np.testing.assert_allclose(one[6:8], s.direction[i], atol=1e-12)


def test_after_the_last_repetition_the_target_rests_at_the_start():
    traj = Trajectory(D, 4.0, 2)
    s = traj.sample([8.0, 9.0, 100.0])
    np.testing.assert_allclose(s.position_m, [[-0.3, 0.2]] * 3, atol=1e-12)
    np.testing.assert_allclose(s.velocity_m_s, 0.0)


def test_figure_eight_tangent_is_continuous_at_the_crossing():
    path = figure_eight((0.0, 0.4), 0.05)
    first_end = path.segments[0].geometry(path.segments[0].length)
    second_start = path.segments[1].geometry(0.0)
    np.testing.assert_allclose(first_end[:4], second_start[:4], atol=1e-12)


def test_joint_reference_is_consistent_with_the_robot():
    robot = RobotModel()
    traj = Trajectory(D, 4.0, timing="minimum_jerk")
    t = np.linspace(0.0, 4.0, 401)
    q, qd, qdd = traj.joint_reference(robot, t)
    s = traj.sample(t)
    np.testing.assert_allclose(robot.fk(q), s.position_m, atol=1e-12)
    v = np.einsum("nij,nj->ni", robot.jacobian(q), qd)
    np.testing.assert_allclose(v, s.velocity_m_s, atol=1e-12)
    a = np.einsum("nij,nj->ni", robot.jacobian(q), qdd) + np.einsum(
        "nij,nj->ni", robot.jacobian_dot(q, qd), qd
    )
    np.testing.assert_allclose(a, s.acceleration_m_s2, atol=1e-9)


def test_bad_inputs():
    with pytest.raises(ParameterError, match="shape"):
        make_path("square", (0, 0), 0.1)
    with pytest.raises(ParameterError, match="duration_s"):
        Trajectory(D, 0.0)
    with pytest.raises(ParameterError, match="timing"):
        Trajectory(D, 4.0, timing="fast")
