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


# What `trig` gives, the sines and cosines every term below is made of.
T_SS, T_CS, T_SE, T_CE, T_SD, T_CD = range(6)


@kernel
def trig(ts, te):
    """(sin θ_s, cos θ_s, sin θ_e, cos θ_e, sin(θ_e − θ_s), cos(θ_e − θ_s)): computed once
    per state for the `*_of` kernels (see core.robot_terms.trig)."""
    d = te - ts
    return (xp.sin(ts), xp.cos(ts), xp.sin(te), xp.cos(te), xp.sin(d), xp.cos(d))


@kernel
def position_of(a, t):
    """Hand position (x, y), eq. 3.16."""
    return (a[ARM_SX] - a[ARM_LU] * t[T_CS] - a[ARM_LF] * t[T_CE],
            a[ARM_SY] - a[ARM_LU] * t[T_SS] - a[ARM_LF] * t[T_SE])


@kernel
def elbow_position_of(a, t):
    """Elbow position (x, y)."""
    return (a[ARM_SX] - a[ARM_LU] * t[T_CS], a[ARM_SY] - a[ARM_LU] * t[T_SS])


@kernel
def jacobian_of(a, t):
    """J_A = ∂P_A/∂θ_A as (j11, j12, j21, j22), eq. 3.17."""
    lu = a[ARM_LU]
    lf = a[ARM_LF]
    return (lu * t[T_SS], lf * t[T_SE], -lu * t[T_CS], -lf * t[T_CE])


@kernel
def jacobian_dot_of(a, t, tsd, ted):
    """dJ_A/dt as (j11, j12, j21, j22), used in eq. 3.19."""
    lu = a[ARM_LU]
    lf = a[ARM_LF]
    return (lu * t[T_CS] * tsd, lf * t[T_CE] * ted, lu * t[T_SS] * tsd, lf * t[T_SE] * ted)


@kernel
def mass_of(a, t):
    """M_A as (m11, m12, m22), derived for the absolute angles of eq. 3.16."""
    cd = t[T_CD]
    return (a[ARM_A11] + 0.0 * cd, a[ARM_K] * cd, a[ARM_A22] + 0.0 * cd)


@kernel
def coriolis_of(a, t, tsd, ted):
    """C_A as (c11, c12, c21, c22), Christoffel form (Ṁ_A − 2C_A skew)."""
    g = a[ARM_K] * t[T_SD]
    zero = 0.0 * t[T_SD]
    return (zero, -g * ted, g * tsd, zero)


@kernel
def inverse_dynamics_of(a, t, tsd, ted, tsdd, tedd, fx, fy):
    """Net joint torques τ_A (shoulder, elbow) for a motion and the hand's force on the
    handle, eq. 3.27: τ_A = M_A θ̈_A + C_A θ̇_A + J_Aᵀ F_hand."""
    m11, m12, m22 = mass_of(a, t)
    _, c12, c21, _ = coriolis_of(a, t, tsd, ted)
    j11, j12, j21, j22 = jacobian_of(a, t)
    return (m11 * tsdd + m12 * tedd + c12 * ted + j11 * fx + j21 * fy,
            m12 * tsdd + m22 * tedd + c21 * tsd + j12 * fx + j22 * fy)


@kernel
def forward_dynamics_of(a, t, tsd, ted, tau_s, tau_e, fx, fy):
    """Joint accelerations θ̈_A for net joint torques and the hand's force (eq. 3.27)."""
    m11, m12, m22 = mass_of(a, t)
    _, c12, c21, _ = coriolis_of(a, t, tsd, ted)
    j11, j12, j21, j22 = jacobian_of(a, t)
    r1 = tau_s - c12 * ted - (j11 * fx + j21 * fy)
    r2 = tau_e - c21 * tsd - (j12 * fx + j22 * fy)
    det = m11 * m22 - m12 * m12
    return ((m22 * r1 - m12 * r2) / det, (m11 * r2 - m12 * r1) / det)


@kernel
def kinetic_energy_of(a, t, tsd, ted):
    """½ θ̇_Aᵀ M_A θ̇_A."""
    m11, m12, m22 = mass_of(a, t)
    return 0.5 * (m11 * tsd * tsd + 2.0 * m12 * tsd * ted + m22 * ted * ted)


# The same terms of joint angles, for one term at a time (ArmModel's methods).
@kernel
def position(a, ts, te):
    return position_of(a, trig(ts, te))


@kernel
def elbow_position(a, ts, te):
    return elbow_position_of(a, trig(ts, te))


@kernel
def jacobian_terms(a, ts, te):
    return jacobian_of(a, trig(ts, te))


@kernel
def jacobian_dot_terms(a, ts, te, tsd, ted):
    return jacobian_dot_of(a, trig(ts, te), tsd, ted)


@kernel
def mass_terms(a, ts, te):
    return mass_of(a, trig(ts, te))


@kernel
def coriolis_terms(a, ts, te, tsd, ted):
    return coriolis_of(a, trig(ts, te), tsd, ted)


@kernel
def inverse_dynamics_terms(a, ts, te, tsd, ted, tsdd, tedd, fx, fy):
    return inverse_dynamics_of(a, trig(ts, te), tsd, ted, tsdd, tedd, fx, fy)


@kernel
def forward_dynamics_terms(a, ts, te, tsd, ted, tau_s, tau_e, fx, fy):
    return forward_dynamics_of(a, trig(ts, te), tsd, ted, tau_s, tau_e, fx, fy)


@kernel
def kinetic_energy_terms(a, ts, te, tsd, ted):
    return kinetic_energy_of(a, trig(ts, te), tsd, ted)


@kernel
def ik_of(a, x, y):
    """Joint angles (θ_s, θ_e) for a hand position on the anatomical branch (the elbow
    flexed the way an elbow bends), with their trig (as `trig` gives it): (θ_s, θ_e,
    trig). Unreachable points give NaN.

    From the shoulder to the hand, v = S − P = l_u e(θ_s) + l_f e(θ_e) (eq. 3.16). The
    law of cosines gives the elbow, cos(θ_e − θ_s) = (|v|² − l_u² − l_f²)/(2 l_u l_f),
    its sine takes the elbow's sign, and e(θ_s) and e(θ_e) follow from v by solving the
    2×2 system in closed form: two inverse trigonometric functions and no sine or cosine
    of an angle, which the coupled dynamics take twice a step."""
    lu = a[ARM_LU]
    lf = a[ARM_LF]
    sign = a[ARM_SIGN]
    vx = a[ARM_SX] - x
    vy = a[ARM_SY] - y
    d2 = vx * vx + vy * vy
    cd = (d2 - lu * lu - lf * lf) / (2.0 * lu * lf)
    cd = where(abs(cd) <= 1.0, cd, xp.nan)
    sd = sign * xp.sqrt(1.0 - cd * cd)
    pp = lu + lf * cd
    qq = lf * sd
    cs = (pp * vx + qq * vy) / d2
    ss = (pp * vy - qq * vx) / d2
    ce = (vx - lu * cs) / lf
    se = (vy - lu * ss) / lf
    ts = xp.atan2(ss, cs)
    return (ts, ts + sign * xp.acos(cd), (ss, cs, se, ce, sd, cd))


@kernel
def ik_terms(a, x, y):
    """Joint angles (θ_s, θ_e) for a hand position on the anatomical branch (the elbow
    flexed the way an elbow bends). Unreachable points give NaN."""
    ts, te, _ = ik_of(a, x, y)
    return (ts, te)


@kernel
def isb_of(a, ts, te):
    """Display angles in the ISB convention (eq. 3.37–3.38), radians. Right arm: shoulder
    = 90° − θ_s, elbow = θ_e − θ_s; a left arm is the mirror image (θ → 180° − θ), which
    gives shoulder = θ_s − 90°, elbow = θ_s − θ_e: the elbow's sign times the right arm's,
    so both arms read the same for the same posture."""
    sign = a[ARM_SIGN]
    return (sign * (0.5 * xp.pi - ts), sign * (te - ts))
