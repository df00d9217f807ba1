"""The subject's arm: Winter's table, eq. 3.16–3.20 in the absolute-angle convention."""

import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from core.arm import ArmModel
from core.errors import ParameterError, UnreachableError

INCH = 0.0254
ARM = ArmModel.from_subject(91.0, 12 * INCH, 12 * INCH, (-0.12, 0.73))


def reachable_points(arm, n, seed=0):
    rng = np.random.default_rng(seed)
    r = rng.uniform(arm.reach_at_elbow_flexion(2.4), arm.reach_at_elbow_flexion(0.2), n)
    a = rng.uniform(-math.pi, 0.0, n)
    return np.column_stack(
        (arm.shoulder_x_m + r * np.cos(a), arm.shoulder_y_m + r * np.sin(a))
    )


def test_winter_segments_for_the_thesis_subject():
    lu = lf = 12 * INCH
    bare = ArmModel.from_subject(91.0, lu, lf, (0, 0), hand="none")
    assert bare.upper_arm_mass_kg == pytest.approx(0.028 * 91)
    assert bare.upper_arm_com_m == pytest.approx(0.436 * lu)
    assert bare.upper_arm_inertia_kgm2 == pytest.approx(0.028 * 91 * (0.322 * lu) ** 2)
    assert bare.forearm_mass_kg == pytest.approx(0.016 * 91)
    assert bare.forearm_com_m == pytest.approx(0.430 * lf)
    # the hand lumped at the handle end of the forearm link
    assert ARM.forearm_mass_kg == pytest.approx(0.022 * 91)
    assert ARM.forearm_com_m == pytest.approx((0.016 * 0.430 + 0.006 * 1.0) / 0.022 * lf)


def test_slender_rod_inertia_reproduces_the_thesis_coefficients():
    # eq. 3.21, 3.23: 12817/46875 m_u l_u² and β1 = 8047/30000 m_f l_f²
    arm = ArmModel.from_subject(80.0, 0.3, 0.28, (0, 0), hand="none", inertia="slender_rod")
    mu, mf = 0.028 * 80, 0.016 * 80
    assert arm.a22 == pytest.approx(8047 / 30000 * mf * 0.28**2, rel=1e-12)
    assert arm.a11 == pytest.approx(12817 / 46875 * mu * 0.3**2 + mf * 0.3**2, rel=1e-12)
    # β2's coefficient 43/100 l_f m_f l_u is the coupling k
    assert arm.coupling == pytest.approx(0.43 * 0.28 * mf * 0.3, rel=1e-12)


def test_forward_kinematics_eq_3_16():
    ts, te = 0.4, 1.9
    x = -0.12 - ARM.upper_arm_m * math.cos(ts) - ARM.forearm_m * math.cos(te)
    y = 0.73 - ARM.upper_arm_m * math.sin(ts) - ARM.forearm_m * math.sin(te)
    np.testing.assert_allclose(ARM.fk([ts, te]), [x, y], rtol=1e-14)


@pytest.mark.parametrize("side", ["right", "left"])
def test_fk_ik_round_trip_on_the_anatomical_branch(side):
    arm = ArmModel.from_subject(70.0, 0.29, 0.27, (0.1, 0.7), side=side)
    points = reachable_points(arm, 300)
    theta = arm.ik(points)
    np.testing.assert_allclose(arm.fk(theta), points, atol=1e-12)
    isb = arm.isb_angles(theta)
    assert np.all(isb[:, 1] > 0.0), "the elbow must flex, not hyper-extend"


def test_left_arm_is_the_mirror_of_the_right():
    right = ArmModel.from_subject(70.0, 0.3, 0.3, (0.1, 0.7), side="right")
    left = ArmModel.from_subject(70.0, 0.3, 0.3, (-0.1, 0.7), side="left")
    p = np.array([-0.15, 0.35])
    mirrored = np.array([0.15, 0.35])
    np.testing.assert_allclose(
        right.isb_angles(right.ik(p)), left.isb_angles(left.ik(mirrored)), atol=1e-12
    )


def test_isb_angles_eq_3_37_3_38():
    theta = np.array([math.radians(20.0), math.radians(110.0)])
    np.testing.assert_allclose(np.degrees(ARM.isb_angles(theta)), [70.0, 90.0])


def test_jacobian_and_derivative_match_central_differences():
    rng = np.random.default_rng(1)
    h = 1e-6
    for theta in ARM.ik(reachable_points(ARM, 50, seed=1)):
        numeric = np.column_stack(
            [(ARM.fk(theta + h * e) - ARM.fk(theta - h * e)) / (2 * h) for e in np.eye(2)]
        )
        np.testing.assert_allclose(ARM.jacobian(theta), numeric, atol=1e-9)
        rate = rng.normal(0, 1, 2)
        numeric_dot = (ARM.jacobian(theta + h * rate) - ARM.jacobian(theta - h * rate)) / (2 * h)
        np.testing.assert_allclose(ARM.jacobian_dot(theta, rate), numeric_dot, atol=1e-8)


def test_mass_matrix_symmetric_positive_definite_and_from_kinetic_energy():
    rng = np.random.default_rng(2)
    lu = ARM.upper_arm_m
    for _ in range(200):
        theta = rng.uniform(-math.pi, math.pi, 2)
        rate = rng.normal(0, 2, 2)
        m = ARM.mass_matrix(theta)
        assert m[0, 1] == m[1, 0]
        assert np.all(np.linalg.eigvalsh(m) > 0)
        # kinetic energy of the two segments computed from their centres of mass
        de = lambda a: np.array([-math.sin(a), math.cos(a)])  # noqa: E731
        v_u = -ARM.upper_arm_com_m * de(theta[0]) * rate[0]
        v_f = -lu * de(theta[0]) * rate[0] - ARM.forearm_com_m * de(theta[1]) * rate[1]
        t = (
            0.5 * ARM.upper_arm_mass_kg * v_u @ v_u
            + 0.5 * ARM.upper_arm_inertia_kgm2 * rate[0] ** 2
            + 0.5 * ARM.forearm_mass_kg * v_f @ v_f
            + 0.5 * ARM.forearm_inertia_kgm2 * rate[1] ** 2
        )
        assert 0.5 * rate @ m @ rate == pytest.approx(t, rel=1e-12)


def test_mdot_minus_2c_is_skew():
    rng = np.random.default_rng(3)
    h = 1e-6
    for _ in range(100):
        theta = rng.uniform(-math.pi, math.pi, 2)
        rate = rng.normal(0, 3, 2)
        m_dot = (ARM.mass_matrix(theta + h * rate) - ARM.mass_matrix(theta - h * rate)) / (2 * h)
        n = m_dot - 2 * ARM.coriolis_matrix(theta, rate)
        np.testing.assert_allclose(n, -n.T, atol=1e-8)


@given(
    theta=st.tuples(st.floats(-3, 3), st.floats(-3, 3)),
    rate=st.tuples(st.floats(-5, 5), st.floats(-5, 5)),
    acc=st.tuples(st.floats(-50, 50), st.floats(-50, 50)),
    force=st.tuples(st.floats(-100, 100), st.floats(-100, 100)),
    body=st.floats(20, 250),
    lengths=st.tuples(st.floats(0.2, 0.45), st.floats(0.2, 0.45)),
)
def test_inverse_of_forward_dynamics_is_identity(theta, rate, acc, force, body, lengths):
    arm = ArmModel.from_subject(body, *lengths, (0.0, 0.7))
    tau = arm.inverse_dynamics(theta, rate, acc, force)
    np.testing.assert_allclose(arm.forward_dynamics(theta, rate, tau, force), acc, atol=1e-7)


def test_free_arm_conserves_energy():
    def f(y):
        return np.array([y[2], y[3], *ARM.forward_dynamics_terms(*y, 0.0, 0.0)])

    def rk4(y, h):
        k1 = f(y)
        k2 = f(y + 0.5 * h * k1)
        k3 = f(y + 0.5 * h * k2)
        k4 = f(y + h * k3)
        return y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    y = np.array([0.3, 1.8, 1.0, -1.5])
    e0 = ARM.kinetic_energy_terms(*y)
    for _ in range(10_000):
        y = rk4(y, 1e-3)
    assert abs(ARM.kinetic_energy_terms(*y) - e0) / e0 < 1e-6


def test_unreachable_point_message():
    arm = ArmModel.from_subject(91.0, 12 * INCH, 12 * INCH, (0.12, 0.73))
    with pytest.raises(
        UnreachableError, match=r"point \(-0\.30, 0\.20\) m is 0\.68 m from the shoulder; "
        r"this arm reaches 0\.61 m"
    ):
        arm.ik([[-0.3, 0.4], [-0.3, 0.2]])


@pytest.mark.parametrize(
    ("args", "field", "allowed"),
    [
        ((0.0, 0.3, 0.3, (0, 0)), "body_mass_kg", r"\[20, 250\] kg"),
        ((-5.0, 0.3, 0.3, (0, 0)), "body_mass_kg", r"\[20, 250\] kg"),
        ((300.0, 0.3, 0.3, (0, 0)), "body_mass_kg", r"\[20, 250\] kg"),
        ((float("nan"), 0.3, 0.3, (0, 0)), "body_mass_kg", "finite"),
        ((70.0, 0.0, 0.3, (0, 0)), "upper_arm_m", r"\[0.15, 0.5\] m"),
        ((70.0, 0.3, -0.2, (0, 0)), "forearm_m", r"\[0.15, 0.5\] m"),
        ((70.0, 0.3, float("inf"), (0, 0)), "forearm_m", "finite"),
        ((70.0, 0.3, 0.3, (float("nan"), 0)), "shoulder_x_m", "finite"),
        ((70.0, 0.3, 0.3, 5), "shoulder_xy_m", "pair"),
    ],
)
def test_bad_subject_is_refused_with_field_value_and_range(args, field, allowed):
    with pytest.raises(ParameterError, match=field) as info:
        ArmModel.from_subject(*args)
    assert info.match(allowed)
