"""The subject's arm's formulas (eq. 3.16–3.20, 3.27), once, as kernels over its constants.

`ArmModel` (core.arm) validates and sizes the arm, builds the vector `a` below
(`ArmModel.constants`) and calls these for its component methods; the coupled dynamics
(core.interaction) and the simulator call them directly, interpreted or compiled
(core.kernels). Each takes plain floats, or numpy arrays through the ARRAYS flavour.
The convention (absolute angles, segments pointing from the shoulder to the hand along
−e(θ)) and the derivation of M_A and C_A are in core.arm.
"""

from __future__ import annotations

import math

from core.kernels import kernel, where

xp = math

# The constants vector a (ArmModel.constants): segment lengths, the shoulder's position,
# the inertia terms of M_A and the elbow's sign (+1 right arm, −1 left arm).
(ARM_LU, ARM_LF, ARM_SX, ARM_SY, ARM_A11, ARM_A22, ARM_K, ARM_SIGN, ARM_SIZE) = range(9)


@kernel
def position(a, ts, te):
    """Hand position (x, y), eq. 3.16."""
    return (a[ARM_SX] - a[ARM_LU] * xp.cos(ts) - a[ARM_LF] * xp.cos(te),
            a[ARM_SY] - a[ARM_LU] * xp.sin(ts) - a[ARM_LF] * xp.sin(te))


@kernel
def elbow_position(a, ts, te):
    """Elbow position (x, y); it does not depend on θ_e."""
    return (a[ARM_SX] - a[ARM_LU] * xp.cos(ts), a[ARM_SY] - a[ARM_LU] * xp.sin(ts))


@kernel
def jacobian_terms(a, ts, te):
    """J_A = ∂P_A/∂θ_A as (j11, j12, j21, j22), eq. 3.17."""
    lu = a[ARM_LU]
    lf = a[ARM_LF]
    return (lu * xp.sin(ts), lf * xp.sin(te), -lu * xp.cos(ts), -lf * xp.cos(te))


@kernel
def jacobian_dot_terms(a, ts, te, tsd, ted):
    """dJ_A/dt as (j11, j12, j21, j22), used in eq. 3.19."""
    lu = a[ARM_LU]
    lf = a[ARM_LF]
    return (lu * xp.cos(ts) * tsd, lf * xp.cos(te) * ted, lu * xp.sin(ts) * tsd,
            lf * xp.sin(te) * ted)


@kernel
def mass_terms(a, ts, te):
    """M_A as (m11, m12, m22), derived for the absolute angles of eq. 3.16."""
    d = te - ts
    return (a[ARM_A11] + 0.0 * d, a[ARM_K] * xp.cos(d), a[ARM_A22] + 0.0 * d)


@kernel
def coriolis_terms(a, ts, te, tsd, ted):
    """C_A as (c11, c12, c21, c22), Christoffel form (Ṁ_A − 2C_A skew)."""
    d = te - ts
    g = a[ARM_K] * xp.sin(d)
    zero = 0.0 * d
    return (zero, -g * ted, g * tsd, zero)


@kernel
def inverse_dynamics_terms(a, ts, te, tsd, ted, tsdd, tedd, fx, fy):
    """Net joint torques τ_A (shoulder, elbow) for a motion and the hand's force on the
    handle, eq. 3.27: τ_A = M_A θ̈_A + C_A θ̇_A + J_Aᵀ F_hand."""
    m11, m12, m22 = mass_terms(a, ts, te)
    _, c12, c21, _ = coriolis_terms(a, ts, te, tsd, ted)
    j11, j12, j21, j22 = jacobian_terms(a, ts, te)
    return (m11 * tsdd + m12 * tedd + c12 * ted + j11 * fx + j21 * fy,
            m12 * tsdd + m22 * tedd + c21 * tsd + j12 * fx + j22 * fy)


@kernel
def forward_dynamics_terms(a, ts, te, tsd, ted, tau_s, tau_e, fx, fy):
    """Joint accelerations θ̈_A for net joint torques and the hand's force (eq. 3.27)."""
    m11, m12, m22 = mass_terms(a, ts, te)
    _, c12, c21, _ = coriolis_terms(a, ts, te, tsd, ted)
    j11, j12, j21, j22 = jacobian_terms(a, ts, te)
    r1 = tau_s - c12 * ted - (j11 * fx + j21 * fy)
    r2 = tau_e - c21 * tsd - (j12 * fx + j22 * fy)
    det = m11 * m22 - m12 * m12
    return ((m22 * r1 - m12 * r2) / det, (m11 * r2 - m12 * r1) / det)


@kernel
def kinetic_energy_terms(a, ts, te, tsd, ted):
    """½ θ̇_Aᵀ M_A θ̇_A."""
    m11, m12, m22 = mass_terms(a, ts, te)
    return 0.5 * (m11 * tsd * tsd + 2.0 * m12 * tsd * ted + m22 * ted * ted)


@kernel
def ik_terms(a, x, y):
    """Joint angles (θ_s, θ_e) for a hand position on the anatomical branch (the elbow
    flexed the way an elbow bends). Unreachable points give NaN."""
    lu = a[ARM_LU]
    lf = a[ARM_LF]
    vx = a[ARM_SX] - x
    vy = a[ARM_SY] - y
    cos_elbow = (vx * vx + vy * vy - lu * lu - lf * lf) / (2.0 * lu * lf)
    cos_elbow = where(abs(cos_elbow) <= 1.0, cos_elbow, xp.nan)
    elbow = a[ARM_SIGN] * xp.acos(cos_elbow)
    ts = xp.atan2(vy, vx) - xp.atan2(lf * xp.sin(elbow), lu + lf * xp.cos(elbow))
    return (ts, ts + elbow)
