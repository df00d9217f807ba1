"""The robot's formulas (eq. 3.1–3.14), once, as kernels over its constants vector.

`RobotModel` (core.robot) validates the parameters, builds the vector `r` below
(`RobotModel.constants`) and calls these for its component methods; the controllers,
the assistance, the supervisor and the simulator call them directly, interpreted or
compiled (core.kernels). Each kernel takes plain floats, or numpy arrays through the
ARRAYS flavour (every branch on a value is a `where`); the equations, sign
conventions and frames are documented in core.robot.
"""

from __future__ import annotations

import math

from core.kernels import kernel, where

xp = math

# The constants vector r (RobotModel.constants): link lengths, α of eq. 3.11–3.14,
# friction, stiffness, the inverse kinematics' branch and the joint limits.
(R_L2, R_L4, R_A1, R_A2, R_A3, R_A4, R_FC1, R_FC2, R_FV1, R_FV2, R_VS, R_EE_C, R_EE_V,
 R_EE_VS, R_K11, R_K12, R_K22, R_Q10, R_Q20, R_BRANCH, R_Q1_MIN, R_Q1_MAX, R_Q2_MIN,
 R_Q2_MAX, R_SPREAD_MIN, R_SPREAD_MAX, R_SIZE) = range(27)

# What `limit_violation` found.
WITHIN_LIMITS, SPREAD_OUTSIDE, Q1_OUTSIDE, Q2_OUTSIDE = range(4)

_TWO_PI = 2.0 * math.pi
_SPEED_AT_REST_M_S = 1e-12


# What `trig` gives, the sines and cosines every term below is made of.
T_S1, T_C1, T_S2, T_C2, T_SD, T_CD = range(6)


@kernel
def trig(q1, q2):
    """(sin θ1, cos θ1, sin θ2, cos θ2, sin(θ1 − θ2), cos(θ1 − θ2)): computed once per
    state, so that a tick that needs several terms (the coupled dynamics, a controller)
    does not take the same sine again for each (the `*_of` kernels take it)."""
    d = q1 - q2
    return (xp.sin(q1), xp.cos(q1), xp.sin(q2), xp.cos(q2), xp.sin(d), xp.cos(d))


@kernel
def position_of(r, t):
    """End-effector position (x, y), eq. 3.2."""
    return (r[R_L2] * t[T_C2] + r[R_L4] * t[T_C1], r[R_L2] * t[T_S2] + r[R_L4] * t[T_S1])


@kernel
def jacobian_of(r, t):
    """J_R = ∂P_R/∂θ_R as (j11, j12, j21, j22), eq. 3.3, columns in joint order."""
    return (-r[R_L4] * t[T_S1], -r[R_L2] * t[T_S2], r[R_L4] * t[T_C1], r[R_L2] * t[T_C2])


@kernel
def jacobian_dot_of(r, t, qd1, qd2):
    """dJ_R/dt as (j11, j12, j21, j22), used in eq. 3.5."""
    return (-r[R_L4] * t[T_C1] * qd1, -r[R_L2] * t[T_C2] * qd2, -r[R_L4] * t[T_S1] * qd1,
            -r[R_L2] * t[T_S2] * qd2)


@kernel
def mass_of(r, t):
    """M_R as (m11, m12, m22), eq. 3.7 with c12, s12 of eq. 3.9–3.10."""
    cd = t[T_CD]
    return (r[R_A1] + 0.0 * cd, r[R_A2] * cd + r[R_A3] * t[T_SD], r[R_A4] + 0.0 * cd)


@kernel
def coriolis_of(r, t, qd1, qd2):
    """C_R as (c11, c12, c21, c22), eq. 3.8 (Christoffel form: Ṁ − 2C is skew)."""
    g = r[R_A2] * t[T_SD] - r[R_A3] * t[T_CD]
    zero = 0.0 * t[T_SD]
    return (zero, g * qd2, -g * qd1, zero)


@kernel
def tanh_over(speed, scale):
    """tanh(speed/scale)/speed, finite (→ 1/scale) at rest."""
    moving = speed > _SPEED_AT_REST_M_S
    return where(moving, xp.tanh(speed / scale) / where(moving, speed, 1.0), 1.0 / scale)


@kernel
def friction_of(r, t, qd1, qd2):
    """Joint torques of joint friction f_RJ plus end-effector friction J_Rᵀ f_RE
    (core.robot.Friction)."""
    f1 = r[R_FC1] * xp.tanh(qd1 / r[R_VS]) + (r[R_FV1] * qd1)
    f2 = r[R_FC2] * xp.tanh(qd2 / r[R_VS]) + (r[R_FV2] * qd2)
    if r[R_EE_C] == 0.0 and r[R_EE_V] == 0.0:
        return (f1, f2)
    j11, j12, j21, j22 = jacobian_of(r, t)
    vx = j11 * qd1 + j12 * qd2
    vy = j21 * qd1 + j22 * qd2
    speed = xp.sqrt(vx * vx + vy * vy)
    coulomb_gain = r[R_EE_C] * tanh_over(speed, r[R_EE_VS])
    fx = (coulomb_gain + r[R_EE_V]) * vx
    fy = (coulomb_gain + r[R_EE_V]) * vy
    return (f1 + j11 * fx + j21 * fy, f2 + j12 * fx + j22 * fy)


@kernel
def stiffness_terms(r, q1, q2):
    """K_R (θ_R − θ_R0) of eq. 3.6."""
    e1 = q1 - r[R_Q10]
    e2 = q2 - r[R_Q20]
    return (r[R_K11] * e1 + r[R_K12] * e2, r[R_K12] * e1 + r[R_K22] * e2)


@kernel
def bias_of(r, t, q1, q2, qd1, qd2):
    """Everything in eq. 3.6 but M_R θ̈: C_R θ̇ + K_R(θ − θ_R0) + J_Rᵀ f_RE + f_RJ."""
    _, c12, c21, _ = coriolis_of(r, t, qd1, qd2)
    k1, k2 = stiffness_terms(r, q1, q2)
    f1, f2 = friction_of(r, t, qd1, qd2)
    return (c12 * qd2 + k1 + f1, c21 * qd1 + k2 + f2)


@kernel
def inverse_dynamics_of(r, t, q1, q2, qd1, qd2, qdd1, qdd2, fx, fy):
    """Joint torques τ_R for a motion and a hand force on the handle (eq. 3.26)."""
    m11, m12, m22 = mass_of(r, t)
    h1, h2 = bias_of(r, t, q1, q2, qd1, qd2)
    j11, j12, j21, j22 = jacobian_of(r, t)
    return (m11 * qdd1 + m12 * qdd2 + h1 - (j11 * fx + j21 * fy),
            m12 * qdd1 + m22 * qdd2 + h2 - (j12 * fx + j22 * fy))


@kernel
def forward_dynamics_of(r, t, q1, q2, qd1, qd2, tau1, tau2, fx, fy):
    """Joint accelerations θ̈_R for torques and a hand force on the handle (eq. 3.26)."""
    m11, m12, m22 = mass_of(r, t)
    h1, h2 = bias_of(r, t, q1, q2, qd1, qd2)
    j11, j12, j21, j22 = jacobian_of(r, t)
    r1 = tau1 + j11 * fx + j21 * fy - h1
    r2 = tau2 + j12 * fx + j22 * fy - h2
    det = m11 * m22 - m12 * m12
    return ((m22 * r1 - m12 * r2) / det, (m11 * r2 - m12 * r1) / det)


@kernel
def joint_torque_of(r, t, fx, fy):
    """J_Rᵀ F: the joint torques a force F at the end effector produces (eq. 3.34)."""
    j11, j12, j21, j22 = jacobian_of(r, t)
    return (j11 * fx + j21 * fy, j12 * fx + j22 * fy)


@kernel
def kinetic_energy_of(r, t, qd1, qd2):
    """½ θ̇ᵀ M_R θ̇."""
    m11, m12, m22 = mass_of(r, t)
    return 0.5 * (m11 * qd1 * qd1 + 2.0 * m12 * qd1 * qd2 + m22 * qd2 * qd2)


@kernel
def potential_energy_terms(r, q1, q2):
    """½ (θ − θ_R0)ᵀ K_R (θ − θ_R0): the energy the joint stiffness stores."""
    e1 = q1 - r[R_Q10]
    e2 = q2 - r[R_Q20]
    return 0.5 * (r[R_K11] * e1 * e1 + 2 * r[R_K12] * e1 * e2 + r[R_K22] * e2 * e2)


# The same terms of joint angles, for one term at a time (RobotModel's methods).
@kernel
def position(r, q1, q2):
    return position_of(r, trig(q1, q2))


@kernel
def jacobian_terms(r, q1, q2):
    return jacobian_of(r, trig(q1, q2))


@kernel
def jacobian_dot_terms(r, q1, q2, qd1, qd2):
    return jacobian_dot_of(r, trig(q1, q2), qd1, qd2)


@kernel
def mass_terms(r, q1, q2):
    return mass_of(r, trig(q1, q2))


@kernel
def coriolis_terms(r, q1, q2, qd1, qd2):
    return coriolis_of(r, trig(q1, q2), qd1, qd2)


@kernel
def friction_terms(r, q1, q2, qd1, qd2):
    return friction_of(r, trig(q1, q2), qd1, qd2)


@kernel
def bias_terms(r, q1, q2, qd1, qd2):
    return bias_of(r, trig(q1, q2), q1, q2, qd1, qd2)


@kernel
def inverse_dynamics_terms(r, q1, q2, qd1, qd2, qdd1, qdd2, fx, fy):
    return inverse_dynamics_of(r, trig(q1, q2), q1, q2, qd1, qd2, qdd1, qdd2, fx, fy)


@kernel
def forward_dynamics_terms(r, q1, q2, qd1, qd2, tau1, tau2, fx, fy):
    return forward_dynamics_of(r, trig(q1, q2), q1, q2, qd1, qd2, tau1, tau2, fx, fy)


@kernel
def joint_torque_terms(r, q1, q2, fx, fy):
    return joint_torque_of(r, trig(q1, q2), fx, fy)


@kernel
def kinetic_energy_terms(r, q1, q2, qd1, qd2):
    return kinetic_energy_of(r, trig(q1, q2), qd1, qd2)


@kernel
def ik_terms(r, x, y):
    """Joint angles (θ_R1, θ_R2) for an end-effector position, closed form (eq. 3.1):
    the law of cosines on |P|² = l2² + l4² + 2 l2 l4 cos(θ_R1 − θ_R2), on the working
    branch, θ_R2 wrapped into [q2_min, q2_min + 2π). Unreachable points give NaN."""
    l2 = r[R_L2]
    l4 = r[R_L4]
    cos_spread = (x * x + y * y - l2 * l2 - l4 * l4) / (2.0 * l2 * l4)
    cos_spread = where(abs(cos_spread) <= 1.0, cos_spread, xp.nan)
    spread = r[R_BRANCH] * xp.acos(cos_spread)
    q2 = xp.atan2(y, x) - xp.atan2(l4 * xp.sin(spread), l2 + l4 * xp.cos(spread))
    low = r[R_Q2_MIN]
    q2 = low + (q2 - low) % _TWO_PI
    return (q2 + spread, q2)


@kernel
def limit_violation(r, q1, q2):
    """Which software joint limit (θ_R1, θ_R2) violates, first in this order: the
    spread θ_R1 − θ_R2 on the working branch (the parallelogram folding flat), then
    joint 1, then joint 2; WITHIN_LIMITS when none (RobotModel.limit_problem words it).
    A NaN angle is outside. Written with `where` so that it runs on whole arrays too
    (RobotModel.ik checks a trial's every reference row in one call)."""
    spread = (q1 - q2) * r[R_BRANCH]
    joint2 = where((q2 >= r[R_Q2_MIN]) & (q2 <= r[R_Q2_MAX]), WITHIN_LIMITS, Q2_OUTSIDE)
    joint1 = where((q1 >= r[R_Q1_MIN]) & (q1 <= r[R_Q1_MAX]), joint2, Q1_OUTSIDE)
    return where((spread < r[R_SPREAD_MIN]) | (spread > r[R_SPREAD_MAX]), SPREAD_OUTSIDE,
                 joint1)
