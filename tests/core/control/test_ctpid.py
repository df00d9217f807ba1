"""Computed-torque PID, eq. 4.1–4.8: the law term by term, the integral and its guards."""

import math

import numpy as np
import pytest

from core.control import ComputedTorquePID, CTPIDGains, make_controller
from core.errors import ParameterError
from core.robot import Friction, RobotModel, Stiffness

# Every term of eq. 4.8 non-zero: stiffness, joint and end-effector friction.
MODEL = RobotModel(
    stiffness=Stiffness(2.0, 0.4, 1.5, 2.6, 1.0),
    friction=Friction((0.05, 0.04), (0.02, 0.03), 0.01, 0.3, 0.5, 0.005),
)
WIDE = (100.0, 100.0)  # no saturation where the law itself is checked


def eq_4_8(model, gains, q, qd, r, rd, rdd, integral):
    """u = M(θ̈_d + K_p e + K_i ∫e + K_d ė) + C θ̇ + f, from the matrices."""
    q, qd, r, rd, rdd, integral = map(np.asarray, (q, qd, r, rd, rdd, integral))
    e, ed = r - q, rd - qd
    kp, ki, kd = map(np.asarray, (gains.kp_1_s2, gains.ki_1_s3, gains.kd_1_s))
    M = model.mass_matrix(q)
    C = model.coriolis_matrix(q, qd)
    k = MODEL.stiffness
    K = np.array([[k.k11_Nm_rad, k.k12_Nm_rad], [k.k12_Nm_rad, k.k22_Nm_rad]])
    f = K @ (q - [k.q1_rest_rad, k.q2_rest_rad]) + model.friction_torque(q, qd)
    return M @ (rdd + kp * e + ki * integral + kd * ed) + C @ qd + f


def test_matches_eq_4_8_with_m_and_c_by_hand():
    gains = CTPIDGains()
    ctrl = make_controller("ctpid", MODEL, torque_limit_Nm=WIDE)
    rng = np.random.default_rng(3)
    integral = np.zeros(2)
    for dt in (0.002, 0.0021, 0.0019):
        q = MODEL.ik([-0.28, 0.31]) + rng.normal(0.0, 0.01, 2)
        qd = rng.normal(0.0, 0.5, 2)
        r = q + rng.normal(0.0, 0.005, 2)
        rd, rdd = rng.normal(0.0, 0.5, 2), rng.normal(0.0, 1.0, 2)
        integral += (r - q) * dt
        tau = ctrl.step(dt, *q, *qd, *r, *rd, *rdd)
        np.testing.assert_allclose(ctrl.integral_rad_s, integral, rtol=1e-12)
        np.testing.assert_allclose(
            tau, eq_4_8(MODEL, gains, q, qd, r, rd, rdd, integral), rtol=1e-10, atol=1e-12
        )


def test_zero_error_at_rest_gives_the_static_torque():
    q = MODEL.ik([-0.32, 0.27])
    ctrl = make_controller("ctpid", MODEL, torque_limit_Nm=WIDE)
    for _ in range(5):  # the integral stays zero with zero error
        tau = ctrl.step(0.002, *q, 0.0, 0.0, *q, 0.0, 0.0, 0.0, 0.0)
    np.testing.assert_allclose(tau, MODEL.stiffness_terms(*q), rtol=1e-12)
    assert np.linalg.norm(tau) > 0.1


class RecordingModel:
    """Stands in for a learned inverse-dynamics model (chapter 4)."""

    def __init__(self):
        self.calls = []

    def inverse_dynamics_terms(self, q1, q2, qd1, qd2, qdd1, qdd2, fx=0.0, fy=0.0):
        self.calls.append((q1, q2, qd1, qd2, qdd1, qdd2))
        return (0.1 * qdd1 + q1, 0.2 * qdd2 - qd2)


def test_any_inverse_dynamics_model_plugs_in():
    model = RecordingModel()
    gains = CTPIDGains(kp_1_s2=(100.0, 200.0), ki_1_s3=(0.0, 50.0), kd_1_s=(20.0, 10.0))
    ctrl = ComputedTorquePID(model, gains, torque_limit_Nm=WIDE)
    state = (1.0, 0.5, 0.2, -0.1)
    ref = (1.01, 0.49, 0.3, -0.2, 2.0, -1.0)
    tau = ctrl.step(0.002, *state, *ref)
    e = (0.01, -0.01)
    a1 = 2.0 + 100.0 * e[0] + 20.0 * (0.3 - 0.2)
    a2 = -1.0 + 200.0 * e[1] + 50.0 * e[1] * 0.002 + 10.0 * (-0.2 + 0.1)
    assert model.calls == [pytest.approx((*state, a1, a2))]
    assert tau == pytest.approx((0.1 * a1 + 1.0, 0.2 * a2 + 0.1))
    assert ctrl.integral_rad_s == (0.0, pytest.approx(-0.01 * 0.002))  # K_i = 0: unused


def test_integral_is_clamped_at_its_limit():
    gains = CTPIDGains(integral_limit_rad_s2=(2.0, 3.0))
    ctrl = make_controller("ctpid", MODEL, torque_limit_Nm=WIDE, gains=gains)
    q = MODEL.ik([-0.3, 0.3])
    for _ in range(2000):  # a constant error: the unclamped integral would reach 0.04 rad·s
        ctrl.step(0.002, *q, 0.0, 0.0, q[0] + 0.01, q[1] - 0.01, 0.0, 0.0, 0.0, 0.0)
    z = np.array(ctrl.integral_rad_s) * gains.ki_1_s3
    np.testing.assert_allclose(z, [2.0, -3.0], rtol=1e-12)


def test_saturated_output_stops_winding_but_may_unwind():
    ctrl = make_controller("ctpid", MODEL)  # the thesis drive: 2.21 N·m
    q = MODEL.ik([-0.3, 0.3])
    big = (q[0], q[1] + 0.2)  # K_p e M ≫ 2.21 N·m on joint 2
    first = None
    for _ in range(500):
        tau = ctrl.step(0.002, *q, 0.0, 0.0, *big, 0.0, 0.0, 0.0, 0.0)
        first = ctrl.integral_rad_s if first is None else first
        assert abs(tau[1]) == pytest.approx(2.2065625)
    # only the first tick (before the loop knew it saturated) counted
    assert ctrl.integral_rad_s[1] == pytest.approx(first[1]) == pytest.approx(0.2 * 0.002)
    # an error the other way unwinds it even while still saturated
    ctrl.step(0.002, *q, 0.0, 0.0, q[0], q[1] - 0.3, 0.0, 0.0, 0.0, 0.0)
    ctrl.step(0.002, *q, 0.0, 0.0, q[0], q[1] - 0.3, 0.0, 0.0, 0.0, 0.0)
    assert ctrl.integral_rad_s[1] < first[1]


def test_outputs_are_limited_and_nan_does_not_poison_the_integral():
    ctrl = make_controller("ctpid", MODEL, torque_limit_Nm=(0.5, 0.7))
    q = MODEL.ik([-0.3, 0.3])
    tau = ctrl.step(0.002, *q, 0.0, 0.0, q[0] + 1.0, q[1] - 1.0, 0.0, 0.0, 0.0, 0.0)
    assert tau == (0.5, -0.7)
    ctrl = make_controller("ctpid", MODEL, torque_limit_Nm=WIDE)
    ctrl.step(0.002, math.nan, q[1], 0.0, 0.0, *q, 0.0, 0.0, 0.0, 0.0)
    ctrl.step(-0.002, *q, 0.0, 0.0, q[0] + 0.01, q[1], 0.0, 0.0, 0.0, 0.0)
    assert ctrl.integral_rad_s == (0.0, 0.0)
    ctrl.step(0.002, *q, 0.0, 0.0, q[0] + 0.01, q[1], 0.0, 0.0, 0.0, 0.0)
    assert ctrl.integral_rad_s[0] == pytest.approx(0.01 * 0.002)
    ctrl.reset()
    assert ctrl.integral_rad_s == (0.0, 0.0)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"kp_1_s2": (0.0, 100.0)}, "kp_1_s2[0]"),
        ({"kd_1_s": (10.0, -1.0)}, "kd_1_s[1]"),
        ({"ki_1_s3": (-1.0, 0.0)}, "ki_1_s3[0]"),
        ({"ki_1_s3": (1200.0 * 60.0, 10.0)}, "ki_1_s3[0]"),  # on the Routh–Hurwitz edge
        ({"integral_limit_rad_s2": (0.0, 1.0)}, "integral_limit_rad_s2[0]"),
        ({"kp_1_s2": (math.nan, 1.0)}, "kp_1_s2[0]"),
        ({"kp_1_s2": 400.0}, "kp_1_s2"),
    ],
)
def test_bad_gains_are_refused_by_name(kwargs, field):
    with pytest.raises(ParameterError) as info:
        CTPIDGains(**kwargs)
    assert info.value.field == field


def test_default_gains_place_a_stable_triple_pole():
    g = CTPIDGains()
    for i in range(2):
        poles = np.roots([1.0, g.kd_1_s[i], g.kp_1_s2[i], g.ki_1_s3[i]])
        assert np.all(poles.real < 0.0)
        # critically damped: one repeated real pole, no oscillation from the PID
        np.testing.assert_allclose(poles, np.full(3, poles.real.mean()), atol=1e-3 * 20)
