"""The robot model against eq. 3.1–3.14 and the invariants of rigid-body dynamics."""

import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from core.errors import ParameterError, UnreachableError
from core.robot import FRICTIONLESS, Link, RobotModel, Stiffness

ROBOT = RobotModel()


def workspace_points(n, seed=0):
    """Random points on the working branch, inside the joint limits."""
    rng = np.random.default_rng(seed)
    points = []
    while len(points) < n:
        p = rng.uniform([-0.55, 0.0], [0.45, 0.65])
        try:
            ROBOT.ik(p)
        except UnreachableError:
            continue
        points.append(p)
    return np.array(points)


def test_alphas_of_the_thesis_robot_by_hand():
    # eq. 3.11–3.14 with Tables 3.2–3.3
    a1 = (0.005**2) * 2.578 + 0.062 * 0.1**2 + (0.274**2 + 0.008**2) * 1.083 + 0.022 + 0.01
    a2 = 0.062 * 0.1 * 0.158 + 1.083 * 0.31 * 0.274
    a3 = 0.062 * 0.1 * 0.0 - 1.083 * 0.31 * 0.008
    a4 = (0.001**2) * 3.399 + 1.083 * 0.31**2 + (0.158**2) * 0.062 + 0.061 + 0.001
    assert ROBOT.alpha == pytest.approx((a1, a2, a3, a4), rel=1e-12)
    assert ROBOT.alpha == pytest.approx((0.1140611, 0.0929696, -0.0026858, 0.1676275), abs=1e-7)


def test_forward_kinematics_eq_3_2():
    q = np.array([math.radians(100.0), math.radians(30.0)])
    x = 0.31 * math.cos(q[1]) + 0.375 * math.cos(q[0])
    y = 0.31 * math.sin(q[1]) + 0.375 * math.sin(q[0])
    np.testing.assert_allclose(ROBOT.fk(q), [x, y], rtol=1e-14)


def test_fk_ik_round_trip_over_the_workspace():
    points = workspace_points(400)
    q = ROBOT.ik(points)
    np.testing.assert_allclose(ROBOT.fk(q), points, atol=1e-12)
    spread = q[:, 0] - q[:, 1]
    assert np.all((spread > 0) & (spread < math.pi)), "IK left the working branch"


def test_ik_fk_round_trip_from_joint_space():
    rng = np.random.default_rng(1)
    q2 = rng.uniform(-0.5, 2.5, 300)
    q = np.column_stack((q2 + rng.uniform(0.4, 2.7, 300), q2))
    np.testing.assert_allclose(ROBOT.ik(ROBOT.fk(q), check_limits=False), q, atol=1e-10)


def test_jacobian_matches_central_differences():
    h = 1e-6
    for q in ROBOT.ik(workspace_points(50, seed=2)):
        numeric = np.column_stack(
            [(ROBOT.fk(q + h * e) - ROBOT.fk(q - h * e)) / (2 * h) for e in np.eye(2)]
        )
        np.testing.assert_allclose(ROBOT.jacobian(q), numeric, atol=1e-9)


def test_jacobian_derivative_matches_central_differences():
    rng = np.random.default_rng(3)
    h = 1e-6
    for q in ROBOT.ik(workspace_points(50, seed=3)):
        qd = rng.normal(0, 1.0, 2)
        numeric = (ROBOT.jacobian(q + h * qd) - ROBOT.jacobian(q - h * qd)) / (2 * h)
        np.testing.assert_allclose(ROBOT.jacobian_dot(q, qd), numeric, atol=1e-8)


def test_mass_matrix_symmetric_positive_definite_over_the_workspace():
    q = ROBOT.ik(workspace_points(500, seed=4))
    m = ROBOT.mass_matrix(q)
    np.testing.assert_array_equal(m, np.swapaxes(m, -1, -2))
    assert np.all(np.linalg.eigvalsh(m) > 0.0)


def test_mass_matrix_from_link_kinetic_energy():
    """M_R against the kinetic energy of the four links computed point by point."""
    rng = np.random.default_rng(5)
    l1, l2 = ROBOT.l1_m, ROBOT.l2_m
    k1, k2, k3, k4 = ROBOT.links

    def energy(q, qd):
        e = lambda a: np.array([math.cos(a), math.sin(a)])  # noqa: E731
        de = lambda a: np.array([-math.sin(a), math.cos(a)])  # noqa: E731
        total = 0.0
        for link, angle, rate, base_vel in (
            (k1, q[0], qd[0], np.zeros(2)),
            (k2, q[1], qd[1], np.zeros(2)),
            (k3, q[1], qd[1], l1 * de(q[0]) * qd[0]),
            (k4, q[0], qd[0], l2 * de(q[1]) * qd[1]),
        ):
            r = link.cg_x_m * e(angle) + link.cg_y_m * de(angle)
            v = base_vel + rate * np.array([-r[1], r[0]])
            total += 0.5 * link.mass_kg * v @ v + 0.5 * link.inertia_kgm2 * rate**2
        return total

    for _ in range(20):
        q = rng.uniform(-3, 3, 2)
        qd = rng.normal(0, 2, 2)
        assert ROBOT.kinetic_energy(q, qd) == pytest.approx(energy(q, qd), rel=1e-12)


def test_mdot_minus_2c_is_skew_along_random_trajectories():
    rng = np.random.default_rng(6)
    h = 1e-6
    for _ in range(100):
        q = rng.uniform(-3, 3, 2)
        qd = rng.normal(0, 3, 2)
        m_dot = (ROBOT.mass_matrix(q + h * qd) - ROBOT.mass_matrix(q - h * qd)) / (2 * h)
        n = m_dot - 2 * ROBOT.coriolis_matrix(q, qd)
        np.testing.assert_allclose(n, -n.T, atol=1e-8)


def test_coriolis_is_the_christoffel_form_of_eq_3_8():
    _a1, a2, a3, _a4 = ROBOT.alpha
    q = np.array([2.1, 0.7])
    qd = np.array([0.3, -1.2])
    s12, c12 = math.sin(q[0] - q[1]), math.cos(q[0] - q[1])
    expected = [[0, (a2 * s12 - a3 * c12) * qd[1]], [(a3 * c12 - a2 * s12) * qd[0], 0]]
    np.testing.assert_allclose(ROBOT.coriolis_matrix(q, qd), expected, atol=1e-15)


@given(
    q=st.tuples(st.floats(-3, 3), st.floats(-3, 3)),
    qd=st.tuples(st.floats(-5, 5), st.floats(-5, 5)),
    qdd=st.tuples(st.floats(-50, 50), st.floats(-50, 50)),
    force=st.tuples(st.floats(-100, 100), st.floats(-100, 100)),
)
def test_inverse_of_forward_dynamics_is_identity(q, qd, qdd, force):
    tau = ROBOT.inverse_dynamics(q, qd, qdd, force)
    np.testing.assert_allclose(ROBOT.forward_dynamics(q, qd, tau, force), qdd, atol=1e-8)


def test_component_and_array_levels_agree():
    q, qd = (2.0, 0.6), (0.4, -0.9)
    assert ROBOT.position(*q) == pytest.approx(tuple(ROBOT.fk(q)))
    tau = ROBOT.inverse_dynamics_terms(*q, *qd, 1.0, -2.0, 3.0, 4.0)
    np.testing.assert_allclose(ROBOT.inverse_dynamics(q, qd, (1.0, -2.0), (3.0, 4.0)), tau)


def test_hand_force_maps_through_the_jacobian_transpose():
    q = ROBOT.ik([-0.25, 0.35])
    force = np.array([3.0, -4.0])
    np.testing.assert_allclose(
        ROBOT.joint_torque_from_force(q, force), ROBOT.jacobian(q).T @ force, rtol=1e-14
    )
    # virtual work: power at the handle equals power at the joints
    qd = np.array([0.5, -0.2])
    assert ROBOT.joint_torque_from_force(q, force) @ qd == pytest.approx(
        force @ (ROBOT.jacobian(q) @ qd)
    )


def rk4(f, y, h):
    k1 = f(y)
    k2 = f(y + 0.5 * h * k1)
    k3 = f(y + 0.5 * h * k2)
    k4 = f(y + h * k3)
    return y + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


@pytest.mark.parametrize("stiffness", [Stiffness(), Stiffness(0.8, 0.2, 0.5, 2.0, 0.9)])
def test_frictionless_robot_conserves_energy(stiffness):
    robot = RobotModel(friction=FRICTIONLESS, stiffness=stiffness)

    def f(y):
        return np.array([y[2], y[3], *robot.forward_dynamics_terms(*y, 0.0, 0.0)])

    def energy(y):
        return robot.kinetic_energy_terms(*y) + robot.potential_energy_terms(y[0], y[1])

    y = np.array([2.0, 0.8, 1.5, -2.0])
    e0 = energy(y)
    for _ in range(10_000):  # 10 s at 1 ms
        y = rk4(f, y, 1e-3)
    assert abs(energy(y) - e0) / e0 < 1e-6


def test_friction_only_removes_energy():
    robot = RobotModel()
    rng = np.random.default_rng(7)
    for _ in range(200):
        q, qd = rng.uniform(-3, 3, 2), rng.normal(0, 2, 2)
        assert robot.friction_torque(q, qd) @ qd >= 0.0


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"l1_m": 0.0}, "l1_m"),
        ({"l2_m": -0.3}, "l2_m"),
        ({"l4_m": float("nan")}, "l4_m"),
        ({"l2_m": 0.30, "l3_m": 0.31}, "l3_m"),
    ],
)
def test_bad_geometry_is_refused_by_name(kwargs, field):
    with pytest.raises(ParameterError, match=field):
        RobotModel(**kwargs)


@pytest.mark.parametrize(
    ("args", "field"),
    [((0.0, 0.01, 0.1, 0.0), "mass_kg"), ((1.0, -0.01, 0.1, 0.0), "inertia_kgm2"),
     ((1.0, 0.01, float("inf"), 0.0), "cg_x_m")],
)
def test_bad_link_is_refused_by_name(args, field):
    with pytest.raises(ParameterError, match=field):
        Link(*args)


def test_unreachable_point_names_the_point_and_the_reach():
    with pytest.raises(UnreachableError, match=r"\(0\.900, 0\.000\) m is 0\.900 m.*0\.685 m"):
        ROBOT.ik([0.9, 0.0])


def test_point_beyond_the_spread_limit_is_refused():
    # Nearly fully stretched: the parallelogram would fold flat.
    with pytest.raises(UnreachableError, match="fold"):
        ROBOT.ik([0.0, 0.684])


def test_other_robots_are_describable():
    other = RobotModel(l1_m=0.08, l2_m=0.4, l3_m=0.4, l4_m=0.45)
    q = other.ik([-0.2, 0.5])
    np.testing.assert_allclose(other.fk(q), [-0.2, 0.5], atol=1e-12)
    assert other.alpha != ROBOT.alpha


def test_the_closed_form_2x2_solve_is_numpy_s_to_rounding():
    """core.arrays.solve2, which the references use in place of numpy.linalg.solve (whose
    last bits depend on the CPU's LAPACK kernels)."""
    from core.arrays import solve2

    rng = np.random.default_rng(0)
    a = rng.normal(size=(200, 2, 2)) + 3 * np.eye(2)
    b = rng.normal(size=(200, 2))
    np.testing.assert_allclose(solve2(a, b), np.linalg.solve(a, b[..., None])[..., 0],
                               rtol=1e-12, atol=1e-12)


_angle = st.one_of(st.floats(-7.0, 7.0), st.just(math.nan))


@given(st.lists(st.tuples(_angle, _angle), min_size=1, max_size=40))
def test_the_limits_checked_on_a_whole_array_are_the_scalar_check_point_by_point(pairs):
    """RobotModel.ik checks every point in one array call of limit_violation (issue 31:
    the per-point loop cost a headless trial a third of its run); the array flavour gives
    each point the scalar kernel's code, NaN and the limits' edges included."""
    from core import robot_terms
    from core.kernels import suited

    robot = RobotModel()
    lim = robot.limits
    pairs = [*pairs, (lim.q1_min_rad, lim.q2_min_rad), (lim.q1_max_rad, lim.q2_max_rad)]
    q = np.array(pairs, dtype=float)
    codes = suited(robot_terms.limit_violation, q[:, 0])(robot.constants, q[:, 0], q[:, 1])
    assert list(codes) == [robot_terms.limit_violation(robot.constants, a, b) for a, b in pairs]


def test_ik_names_the_first_point_beyond_a_joint_limit_in_words():
    robot = RobotModel()
    inside = np.array([-0.3, 0.3])  # the thesis's D's line centre
    q = robot.ik(inside)
    # links 7.5° apart: the parallelogram folds flat
    folded = robot.fk(np.array([q[1] + robot.branch * 0.5 * robot.limits.spread_min_rad, q[1]]))
    far = np.array([1.5, 0.0])
    assert robot.limit_problem(*robot.ik(folded, check_limits=False))
    with pytest.raises(UnreachableError, match=r"point \(0\.117, 0\.673\) m: the robot's "
                                               r"links would be 7\.5° apart"):
        robot.ik(np.array([inside, folded, folded]))
    with pytest.raises(UnreachableError, match=r"point \(1\.500, 0\.000\) m is"):
        robot.ik(np.array([inside, far, folded]))
    assert robot.ik(np.array([inside, folded]), check_limits=False).shape == (2, 2)
