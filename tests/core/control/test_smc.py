"""Sliding-mode control: the law term by term, its Lyapunov derivative, its gains."""

import math

import numpy as np
import pytest

from core.control import SlidingModeController, SMCGains, make_controller
from core.errors import ParameterError
from core.robot import Friction, RobotModel, Stiffness

MODEL = RobotModel(
    stiffness=Stiffness(2.0, 0.4, 1.5, 2.6, 1.0),
    friction=Friction((0.05, 0.04), (0.02, 0.03), 0.01, 0.3, 0.5, 0.005),
)
WIDE = (100.0, 100.0)
GAINS = SMCGains()


def sat(x):
    return np.clip(x, -1.0, 1.0)


def smc_by_hand(model, gains, q, qd, r, rd, rdd):
    """τ = M q̈_r + C(q, q̇) q̇_r + K_R(q − q0) + f(q̇_r) + K_D s + K sat(s/Φ)."""
    lam, kd = np.asarray(gains.lambda_1_s), np.asarray(gains.k_d_Nms_rad)
    k, phi = np.asarray(gains.k_robust_Nm), np.asarray(gains.boundary_rad_s)
    e, ed = r - q, rd - qd
    s = ed + lam * e
    vr, ar = rd + lam * e, rdd + lam * ed
    st = model.stiffness
    K = np.array([[st.k11_Nm_rad, st.k12_Nm_rad], [st.k12_Nm_rad, st.k22_Nm_rad]])
    return (
        model.mass_matrix(q) @ ar
        + model.coriolis_matrix(q, qd) @ vr
        + K @ (q - [st.q1_rest_rad, st.q2_rest_rad])
        + model.friction_torque(q, vr)
        + kd * s
        + k * sat(s / phi)
    ), s


def random_state(rng):
    q = MODEL.ik(rng.uniform([-0.38, 0.22], [-0.22, 0.38]))
    qd = rng.normal(0.0, 0.5, 2)
    r = q + rng.normal(0.0, 0.004, 2)
    rd = qd + rng.normal(0.0, 0.1, 2)
    rdd = rng.normal(0.0, 1.0, 2)
    return q, qd, r, rd, rdd


def test_matches_the_slotine_li_law_by_hand():
    ctrl = make_controller("smc", MODEL, torque_limit_Nm=WIDE)
    rng = np.random.default_rng(7)
    inside = outside = 0
    for _ in range(50):
        q, qd, r, rd, rdd = random_state(rng)
        expected, s = smc_by_hand(MODEL, GAINS, q, qd, r, rd, rdd)
        np.testing.assert_allclose(
            ctrl.step(0.002, *q, *qd, *r, *rd, *rdd), expected, rtol=1e-10, atol=1e-12
        )
        np.testing.assert_allclose(ctrl.sliding_variable(*q, *qd, *r, *rd), s, rtol=1e-12)
        inside += int(np.sum(np.abs(s) < GAINS.boundary_rad_s))
        outside += int(np.sum(np.abs(s) > GAINS.boundary_rad_s))
    assert inside > 5
    assert outside > 5


def test_lyapunov_derivative_is_negative_on_the_exact_model():
    """V = ½ sᵀ M s: V̇ = −sᵀK_D s − sᵀK sat(s/Φ) − sᵀ(f(q̇_r) − f(q̇)) ≤ −sᵀK_D s − sᵀK sat."""
    ctrl = make_controller("smc", MODEL, torque_limit_Nm=WIDE)
    lam = np.asarray(GAINS.lambda_1_s)
    kd, k = np.asarray(GAINS.k_d_Nms_rad), np.asarray(GAINS.k_robust_Nm)
    phi = np.asarray(GAINS.boundary_rad_s)
    rng = np.random.default_rng(11)
    h = 1e-6
    for _ in range(200):
        q, qd, r, rd, rdd = random_state(rng)
        tau = np.array(ctrl.step(0.002, *q, *qd, *r, *rd, *rdd))
        qdd = MODEL.forward_dynamics(q, qd, tau)
        s = (rd - qd) + lam * (r - q)
        s_dot = (rdd - qdd) + lam * (rd - qd)
        m_dot = (MODEL.mass_matrix(q + h * qd) - MODEL.mass_matrix(q - h * qd)) / (2 * h)
        v_dot = s @ MODEL.mass_matrix(q) @ s_dot + 0.5 * s @ m_dot @ s
        vr = rd + lam * (r - q)
        friction_gap = s @ (MODEL.friction_torque(q, vr) - MODEL.friction_torque(q, qd))
        bound = -(s @ (kd * s)) - s @ (k * sat(s / phi))
        assert v_dot == pytest.approx(bound - friction_gap, rel=1e-6, abs=1e-9)
        assert friction_gap >= 0.0  # friction at q̇_r only ever dissipates
        assert v_dot <= bound + 1e-9


def test_zero_error_at_rest_gives_the_static_torque():
    q = MODEL.ik([-0.32, 0.27])
    ctrl = make_controller("smc", MODEL, torque_limit_Nm=WIDE)
    tau = ctrl.step(0.002, *q, 0.0, 0.0, *q, 0.0, 0.0, 0.0, 0.0)
    np.testing.assert_allclose(tau, MODEL.stiffness_terms(*q), rtol=1e-12)
    assert np.linalg.norm(tau) > 0.1


def test_robust_term_saturates_at_k_outside_the_boundary_layer():
    """With M, C, K_R, f and K_D switched off by a still reference, the torque is K sat(s/Φ)."""
    model = RobotModel(friction=Friction((0.0, 0.0), (0.0, 0.0)))
    gains = SMCGains(k_d_Nms_rad=(0.0, 0.0), k_robust_Nm=(0.3, 0.4), boundary_rad_s=(0.1, 0.2))
    ctrl = SlidingModeController(model, gains, torque_limit_Nm=WIDE)
    q = model.ik([-0.3, 0.3])
    # rates chosen so that q̈_r = Λė is cancelled by a matching reference acceleration
    for s1, s2 in ((1.0, -1.0), (0.05, -0.1), (-0.5, 0.02)):
        rdd = (-gains.lambda_1_s[0] * s1, -gains.lambda_1_s[1] * s2)
        tau = ctrl.step(0.002, *q, 0.0, 0.0, *q, s1, s2, *rdd)
        # C q̇_r with q̇ = 0 is zero, so only the robust term remains
        expected = (0.3 * max(-1.0, min(1.0, s1 / 0.1)), 0.4 * max(-1.0, min(1.0, s2 / 0.2)))
        np.testing.assert_allclose(tau, expected, rtol=1e-12, atol=1e-15)


def test_output_is_limited():
    ctrl = make_controller("smc", MODEL, torque_limit_Nm=(0.5, 0.7))
    q = MODEL.ik([-0.3, 0.3])
    assert ctrl.step(0.002, *q, 0.0, 0.0, q[0] + 1.0, q[1] - 1.0, 0, 0, 0, 0) == (0.5, -0.7)
    ctrl.reset()  # stateless: still the same law
    assert ctrl.step(0.002, *q, 0.0, 0.0, q[0] - 1.0, q[1] + 1.0, 0, 0, 0, 0) == (-0.5, 0.7)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"lambda_1_s": (0.0, 10.0)}, "lambda_1_s[0]"),
        ({"lambda_1_s": (10.0, 1000.0)}, "lambda_1_s[1]"),
        ({"k_d_Nms_rad": (-1.0, 1.0)}, "k_d_Nms_rad[0]"),
        ({"k_robust_Nm": (0.3, math.inf)}, "k_robust_Nm[1]"),
        ({"boundary_rad_s": (0.0, 0.1)}, "boundary_rad_s[0]"),
        ({"boundary_rad_s": (0.1,)}, "boundary_rad_s"),
        ({"lambda_1_s": ("fast", 10.0)}, "lambda_1_s[0]"),
    ],
)
def test_bad_gains_are_refused_by_name(kwargs, field):
    with pytest.raises(ParameterError) as info:
        SMCGains(**kwargs)
    assert info.value.field == field
    assert field in str(info.value)


def test_model_without_separate_terms_is_refused():
    class OnlyInverseDynamics:
        def inverse_dynamics_terms(self, *args):
            return (0.0, 0.0)

    with pytest.raises(ParameterError, match="model"):
        SlidingModeController(OnlyInverseDynamics(), torque_limit_Nm=WIDE)
