"""The human–robot interaction model, eq. 3.26–3.38, and the coupled system's invariants."""

import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from core.arm import ArmModel
from core.errors import SingularityError
from core.interaction import (
    coupled_energy,
    coupled_forward_dynamics,
    global_to_sensor,
    sensor_to_global,
    subject_accelerations,
    subject_angles,
    subject_rates,
    subject_robot_torque,
    subject_state,
)
from core.robot import FRICTIONLESS, RobotModel
from core.trial import THESIS_SUBJECT

ROBOT = RobotModel()
ARM = ArmModel.from_subject(91.0, 0.3048, 0.3048, (-0.12, 0.73))


def test_hand_on_the_handle_eq_3_28():
    q = ROBOT.ik([-0.25, 0.32])
    ts, te = subject_angles(ROBOT, ARM, *q)
    np.testing.assert_allclose(ARM.position(ts, te), ROBOT.position(*q), atol=1e-12)


def test_rates_and_accelerations_keep_hand_and_handle_together():
    """eq. 3.30–3.33 against finite differences of the closure along a robot motion."""
    rng = np.random.default_rng(0)
    h = 1e-5
    for _ in range(30):
        q0 = ROBOT.ik(rng.uniform([-0.35, 0.22], [-0.2, 0.4]))
        qd = rng.normal(0, 0.5, 2)
        qdd = rng.normal(0, 2.0, 2)

        def angles(t, q0=q0, qd=qd, qdd=qdd):
            q = q0 + qd * t + 0.5 * qdd * t * t
            return np.array(subject_angles(ROBOT, ARM, *q))

        ts, te = angles(0.0)
        tsd, ted, damped = subject_rates(ROBOT, ARM, *q0, *qd, ts, te)
        assert not damped
        numeric_rate = (angles(h) - angles(-h)) / (2 * h)
        np.testing.assert_allclose([tsd, ted], numeric_rate, rtol=1e-6, atol=1e-8)
        tsdd, tedd, _ = subject_accelerations(ROBOT, ARM, *q0, *qd, *qdd, ts, te, tsd, ted)
        numeric_acc = (angles(h) - 2 * angles(0.0) + angles(-h)) / (h * h)
        np.testing.assert_allclose([tsdd, tedd], numeric_acc, rtol=1e-3, atol=1e-4)


def test_damped_pseudo_inverse_near_the_straight_arm():
    # Hand almost fully stretched from the shoulder (elbow bent ~1°): rates stay bounded.
    reach = ARM.reach_at_elbow_flexion(math.radians(1.0))
    direction = np.array([-0.6, -0.8])
    p = np.array([ARM.shoulder_x_m, ARM.shoulder_y_m]) + reach * direction
    ts, te = ARM.ik_terms(*p)
    q = ROBOT.ik(p, check_limits=False)
    tsd, ted, damped = subject_rates(ROBOT, ARM, *q, 0.3, -0.2, ts, te)
    assert damped
    assert abs(tsd) < 50
    assert abs(ted) < 50
    # and the flag is off with a bent elbow
    q = ROBOT.ik([-0.25, 0.32])
    ts, te = subject_angles(ROBOT, ARM, *q)
    assert not subject_rates(ROBOT, ARM, *q, 0.3, -0.2, ts, te)[2]


@given(
    f=st.tuples(st.floats(-250, 250), st.floats(-250, 250)),
    q1=st.floats(-6, 6),
    offset=st.floats(-1, 1),
)
def test_force_rotation_eq_3_35_round_trips_and_keeps_magnitude(f, q1, offset):
    g = sensor_to_global(*f, q1, offset)
    assert math.hypot(*g) == pytest.approx(math.hypot(*f), abs=1e-9)
    np.testing.assert_allclose(global_to_sensor(*g, q1, offset), f, atol=1e-9)


def test_force_rotation_matches_the_matrix_of_eq_3_36():
    q1 = math.radians(30.0)
    r = np.array([[math.cos(q1), -math.sin(q1)], [math.sin(q1), math.cos(q1)]])
    np.testing.assert_allclose(sensor_to_global(2.0, -1.0, q1), r @ [2.0, -1.0])


def test_subject_contribution_eq_3_34():
    q = ROBOT.ik([-0.3, 0.3])
    np.testing.assert_allclose(
        subject_robot_torque(ROBOT, *q, 1.0, 2.0), ROBOT.jacobian(q).T @ [1.0, 2.0]
    )


def test_static_push_gives_jacobian_transpose_torques():
    """At rest the subject's joint torques are J_Aᵀ F (eq. 3.27 with θ̇ = θ̈ = 0)."""
    q = ROBOT.ik([-0.28, 0.33])
    fx_s, fy_s = 5.0, -3.0
    state = subject_state(ROBOT, ARM, *q, 0, 0, 0, 0, fx_s, fy_s)
    force = np.array([state.force_x_N, state.force_y_N])
    theta = np.array([state.shoulder_rad, state.elbow_rad])
    np.testing.assert_allclose(
        [state.shoulder_torque_Nm, state.elbow_torque_Nm], ARM.jacobian(theta).T @ force
    )


def test_subject_state_vectorised_matches_per_sample():
    rng = np.random.default_rng(4)
    q = ROBOT.ik(rng.uniform([-0.35, 0.22], [-0.2, 0.4], (20, 2)))
    qd, qdd, f = rng.normal(0, 0.5, (3, 20, 2))
    arrays = subject_state(ROBOT, ARM, *q.T, *qd.T, *qdd.T, *f.T)
    for i in range(20):
        one = subject_state(ROBOT, ARM, *q[i], *qd[i], *qdd[i], *f[i])
        assert arrays.shoulder_torque_Nm[i] == pytest.approx(one.shoulder_torque_Nm)
        assert arrays.isb_elbow_rad[i] == pytest.approx(one.isb_elbow_rad)


def test_coupled_dynamics_satisfy_both_equations_of_motion():
    rng = np.random.default_rng(5)
    for _ in range(30):
        q = ROBOT.ik(rng.uniform([-0.35, 0.22], [-0.2, 0.4]))
        qd = rng.normal(0, 0.5, 2)
        tau_r = rng.normal(0, 1, 2)
        tau_a = rng.normal(0, 2, 2)
        qdd1, qdd2, fx, fy, ts, te, tsd, ted = coupled_forward_dynamics(
            ROBOT, ARM, *q, *qd, *tau_r, *tau_a
        )
        # robot: M θ̈ + h = τ_R + J_Rᵀ F
        np.testing.assert_allclose(
            ROBOT.forward_dynamics(q, qd, tau_r, [fx, fy]), [qdd1, qdd2], atol=1e-9
        )
        # arm: M_A θ̈_A + C_A θ̇_A = τ_A − J_Aᵀ F, with θ̈_A from the closure (eq. 3.33)
        tsdd, tedd, _ = subject_accelerations(ROBOT, ARM, *q, *qd, qdd1, qdd2, ts, te, tsd, ted)
        np.testing.assert_allclose(
            ARM.inverse_dynamics([ts, te], [tsd, ted], [tsdd, tedd], [fx, fy]), tau_a, atol=1e-9
        )


def test_coupled_robot_and_arm_conserve_energy():
    robot = RobotModel(friction=FRICTIONLESS)
    q0 = robot.ik([-0.27, 0.32])

    def f(y):
        qdd1, qdd2, *_ = coupled_forward_dynamics(robot, ARM, *y, 0.0, 0.0, 0.0, 0.0)
        return np.array([y[2], y[3], qdd1, qdd2])

    y = np.array([*q0, 0.05, -0.04])
    e0 = coupled_energy(robot, ARM, *y)
    h = 1e-3
    for _ in range(10_000):  # 10 s
        k1 = f(y)
        k2 = f(y + 0.5 * h * k1)
        k3 = f(y + 0.5 * h * k2)
        k4 = f(y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert abs(coupled_energy(robot, ARM, *y) - e0) / e0 < 1e-6
    # it really moved, and stayed where the arm is bent
    assert np.linalg.norm(robot.fk(y[:2]) - robot.fk(q0)) > 0.01


def test_straight_arm_is_refused_by_the_coupled_model():
    far = np.array([ARM.shoulder_x_m, ARM.shoulder_y_m]) + ARM.reach_max_m * np.array([-0.6, -0.8])
    q = ROBOT.ik(far, check_limits=False)
    with pytest.raises(SingularityError, match="straight"):
        coupled_forward_dynamics(ROBOT, ARM, *q, 0, 0, 0, 0, 0, 0)


@given(ts=st.floats(0.2, 1.4), bend=st.floats(0.4, 2.2),
       rates=st.lists(st.floats(-2.0, 2.0), min_size=4, max_size=4),
       fx=st.floats(-20.0, 20.0), fy=st.floats(-20.0, 20.0))
def test_the_torques_eq_3_27_gives_for_a_force_give_that_force_back(ts, bend, rates, fx, fy):
    """Eq. 5.1 solved for the hand's force (the EMG estimate's last step) inverts eq. 3.27
    wherever the arm is bent enough for the torques to tell the force (no damping)."""
    from core.interaction import subject_hand_force, subject_torques

    arm = THESIS_SUBJECT.arm()
    te = ts + bend
    tau = subject_torques(arm, ts, te, *rates, fx, fy)
    gx, gy, damped = subject_hand_force(arm, ts, te, *rates, *tau)
    if not damped:
        assert gx == pytest.approx(fx, abs=1e-9)
        assert gy == pytest.approx(fy, abs=1e-9)
    # arrays give the same as floats
    gxs, gys, _ = subject_hand_force(arm, np.array([ts]), np.array([te]),
                                     *(np.array([r]) for r in rates), np.array([tau[0]]),
                                     np.array([tau[1]]))
    assert (gxs[0], gys[0]) == pytest.approx((gx, gy), abs=1e-12)
