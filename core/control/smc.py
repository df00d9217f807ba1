"""Sliding-mode tracking control of the robot (the thesis's controller, section 3.6).

The thesis drives the robot with the SMC of its reference [19], which is not
available; this is the standard robust sliding-mode law of Slotine and Li
(Applied Nonlinear Control, 1991, §9.4) on the robot model of eq. 3.6–3.14.

Control law
-----------
With the tracking error in the thesis's sign (eq. 4.1–4.2), per joint i,

    e = θ_d − θ,   ė = θ̇_d − θ̇
    s = ė + Λ e                       sliding variable (rad/s); s = 0 is the surface
    θ̇_r = θ̇_d + Λ e                   reference rate, so s = θ̇_r − θ̇
    θ̈_r = θ̈_d + Λ ė

    τ = M̂(θ) θ̈_r + Ĉ(θ, θ̇) θ̇_r + K̂_R (θ − θ_R0) + f̂(θ̇_r) + K_D s + K sat(s / Φ)

where hats are the controller's model (eq. 3.7, 3.8 and the stiffness and
friction of eq. 3.6), K_D, K, Φ, Λ are diagonal, and sat clips each component
to [−1, 1] (the boundary layer against chattering). The output is then clipped
to the drive limit.

Friction is compensated at the reference rate θ̇_r, not at the measured rate:
on the surface the two are equal, so the compensation is exact where it
matters, and the encoder-differenced θ̇ (noisy at 2 ms) never passes through
the steep Coulomb tanh.

Why it converges (Lyapunov, in a few lines)
-------------------------------------------
Let the plant be M θ̈ + C θ̇ + K_R(θ − θ_R0) + f(θ̇) = τ + d, with d everything the
model misses (inertia errors, the arm on the handle, the hand's force). With
the law above,

    M ṡ = −C s − K_D s − K sat(s/Φ) − (f(θ̇_r) − f(θ̇)) − d̃,
    d̃ = d − [(M − M̂) θ̈_r + (C − Ĉ) θ̇_r + …]   (the lumped mismatch).

Take V = ½ sᵀ M s ≥ 0. Because Ṁ − 2C is skew-symmetric (eq. 3.8 is the
Christoffel form),

    V̇ = −sᵀ K_D s − sᵀ K sat(s/Φ) − sᵀ (f(θ̇_r) − f(θ̇)) − sᵀ d̃.

The friction term sᵀ(f(θ̇_r) − f(θ̇)) is ≥ 0 because θ̇_r = θ̇ + s and joint
friction increases with each joint's rate (end-effector friction Jᵀφ(Jθ̇) is
monotone too): compensating friction at θ̇_r only ever adds dissipation. Outside the
boundary layer (|s_i| > Φ_i) sat is sign, so V̇ ≤ −sᵀK_D s − Σ (K_i − |d̃_i|)|s_i|
< 0 whenever K_i > |d̃_i|: s reaches the layer |s_i| ≤ Φ_i in finite time and
stays in it. Inside, ė + Λ e = s is a stable first-order filter, so the joint
error ends bounded by |e_i| ≤ Φ_i / Λ_i (Slotine's "tracking precision"); with
no mismatch s → 0 and e → 0 exponentially at rate Λ.

Gains (`SMCGains`, per joint) and why these values
---------------------------------------------------
Numbers below: M ≈ 0.11 (joint 1) and 0.17 kg·m² (joint 2) for the robot; the
thesis subject's passive arm on the handle adds GᵀM_A G ≈ 0.25–0.55 and
0.12–0.24 kg·m² along the D (G = J_A⁻¹ J_R), which the controller does not
model. The values were chosen by simulating the D (tests/core/control/
test_tracking.py) with and without the arm, and with the encoder's
quantisation and a 2 ms finite-difference rate to see the noise they pass.

lambda_1_s = 20 1/s
    The error's decay rate on the surface (e ∝ exp(−Λt), 50 ms). With the
    other gains at their defaults, raising it from 12 to 20 1/s cut the RMS
    error on the constant-speed D with the arm from 2.5 to 2.0 mm (and on the
    minimum-jerk D from 1.6 to 1.0 mm); 30 1/s gained ≈ 0.2 mm more at ≈ 15 %
    more rate noise in the torque. Λ·0.002 s = 0.04 keeps the discrete loop far from its
    stability limit.
k_d_Nms_rad = 3 N·m·s/rad
    Linear damping on s: K_D/M ≈ 18–26 1/s on the robot alone (s settles about
    as fast as e), ≈ 5–10 1/s with the arm on the handle, whose inertia it is
    the main brake for.
k_robust_Nm = 0.35 N·m
    Switching amplitude: must exceed the mismatch |d̃| the model misses. On the
    thesis D, ±20 % inertia error costs ≈ 0.03 N·m and an unknown Coulomb
    friction ≈ 0.05 N·m per joint; the passive arm's unmodelled inertia
    needs ≈ 0.1–0.3 N·m except at the D's corners. 0.35 N·m is 16 % of the
    drive's 2.21 N·m.
boundary_rad_s = 0.1 rad/s
    Boundary-layer thickness Φ. Inside it the switching term is the linear gain
    K/Φ = 3.5 N·m·s/rad, so the s-loop runs at (K_D + K/Φ)/M ≈ 40–60 1/s on the
    robot alone, far below what the 500 Hz loop can act on. The tracking
    precision Φ/Λ = 5 mrad per joint (≈ 2–3 mm at the handle) is the bound the
    error stays under once K covers the mismatch (the tests check it). Φ is
    2.5 encoder counts per 2 ms tick (one count per tick is 0.041 rad/s): a
    thinner layer switches on the quantised rate, i.e. chatters. With the raw
    2 ms difference as the rate these gains pass ≈ 0.15 N·m RMS of rate noise
    into the torque; a filtered rate estimate in the device layer lowers it.
"""

from __future__ import annotations

from dataclasses import dataclass

from core.control.base import check_pair, check_torque_limit
from core.errors import ParameterError
from core.kernels import kernel
from core.robot_terms import R_SIZE, coriolis_of, friction_of, mass_of, stiffness_terms, trig

# Upper bounds that catch a typo (a gain in the wrong unit) rather than tune.
_LAMBDA_MAX_1_S = 100.0  # Λ·dt ≤ 0.2 at the 2 ms tick
_K_D_MAX_NMS_RAD = 50.0
_K_ROBUST_MAX_NM = 10.0
_BOUNDARY_MAX_RAD_S = 10.0


@dataclass(frozen=True, slots=True)
class SMCGains:
    """Per-joint gains of the sliding-mode law; see the module docstring for each value."""

    lambda_1_s: tuple[float, float] = (20.0, 20.0)
    k_d_Nms_rad: tuple[float, float] = (3.0, 3.0)
    k_robust_Nm: tuple[float, float] = (0.35, 0.35)
    boundary_rad_s: tuple[float, float] = (0.1, 0.1)

    def __post_init__(self) -> None:
        pairs = (
            ("lambda_1_s", "1/s", 0.0, _LAMBDA_MAX_1_S, True,
             "the error's decay rate on the surface; > 0 for convergence, "
             "≤ 100 1/s for the 2 ms loop"),
            ("k_d_Nms_rad", "N·m·s/rad", 0.0, _K_D_MAX_NMS_RAD, False,
             "damping of the sliding variable; ≥ 0"),
            ("k_robust_Nm", "N·m", 0.0, _K_ROBUST_MAX_NM, False,
             "switching amplitude; ≥ 0 and below any drive's limit"),
            ("boundary_rad_s", "rad/s", 0.0, _BOUNDARY_MAX_RAD_S, True,
             "boundary-layer thickness; > 0 or the switching term chatters"),
        )
        for field, unit, low, high, low_open, why in pairs:
            value = check_pair(field, getattr(self, field), unit, low, high, why,
                               low_open=low_open)
            object.__setattr__(self, field, value)


# The gains vector of `smc_torques` (SlidingModeController.constants), per joint.
(S_LAM1, S_LAM2, S_KD1, S_KD2, S_K1, S_K2, S_INV_PHI1, S_INV_PHI2, S_LIM1, S_LIM2,
 S_SIZE) = range(11)


class SlidingModeController:
    """Slotine–Li sliding-mode controller on a `RobotModel` (see the module docstring).

    The law is the kernel `smc_torques` (compiled in the loop, core.kernels); this
    class validates the gains and the limit and holds them as its `constants`.
    Stateless apart from its parameters: `reset` has nothing to forget.
    """

    __slots__ = ("_model", "constants", "gains", "torque_limit_Nm")

    name = "smc"

    def __init__(self, model, gains: SMCGains | None = None, *, torque_limit_Nm) -> None:
        if len(getattr(model, "constants", ())) != R_SIZE:
            raise ParameterError(
                "model", type(model).__name__,
                "a core.robot.RobotModel (mass, Coriolis, stiffness and friction terms)",
                "the sliding-mode law needs M, C, stiffness and friction separately, as "
                "core.robot_terms computes them from a RobotModel's constants",
            )
        gains = SMCGains() if gains is None else gains
        if not isinstance(gains, SMCGains):
            raise ParameterError("gains", type(gains).__name__, "an SMCGains")
        self._model = model
        self.gains = gains
        self.torque_limit_Nm = check_torque_limit(torque_limit_Nm)
        self.constants = (*gains.lambda_1_s, *gains.k_d_Nms_rad, *gains.k_robust_Nm,
                          1.0 / gains.boundary_rad_s[0], 1.0 / gains.boundary_rad_s[1],
                          *self.torque_limit_Nm)

    @property
    def model(self):
        """The robot model the law uses (M̂, Ĉ, stiffness and friction)."""
        return self._model

    def reset(self) -> None:
        """Nothing to forget: the law has no internal state."""

    def sliding_variable(self, q1, q2, qd1, qd2, r1, r2, rd1, rd2) -> tuple[float, float]:
        """s = ė + Λ e (rad/s), for logging and tests."""
        lam1, lam2 = self.gains.lambda_1_s
        return (rd1 - qd1 + lam1 * (r1 - q1), rd2 - qd2 + lam2 * (r2 - q2))

    def step(self, dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2):
        """Joint torques (N·m) of the sliding-mode law for one tick; `dt_s` is unused."""
        return smc_torques(self._model.constants, self.constants, q1, q2, qd1, qd2,
                           r1, r2, rd1, rd2, rdd1, rdd2)


@kernel
def smc_torques(robot, gains, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2):
    """τ = M̂ θ̈_r + Ĉ θ̇_r + K̂_R(θ − θ_R0) + f̂(θ̇_r) + K_D s + K sat(s/Φ), clipped to the
    drive limit (the module notes). `robot` is a RobotModel's constants, `gains` the
    controller's (S_* names)."""
    lam1 = gains[S_LAM1]
    lam2 = gains[S_LAM2]
    e1 = r1 - q1
    e2 = r2 - q2
    ed1 = rd1 - qd1
    ed2 = rd2 - qd2
    s1 = ed1 + lam1 * e1
    s2 = ed2 + lam2 * e2
    vr1 = rd1 + lam1 * e1
    vr2 = rd2 + lam2 * e2
    ar1 = rdd1 + lam1 * ed1
    ar2 = rdd2 + lam2 * ed2

    t = trig(q1, q2)
    m11, m12, m22 = mass_of(robot, t)
    c11, c12, c21, c22 = coriolis_of(robot, t, qd1, qd2)
    k1, k2 = stiffness_terms(robot, q1, q2)
    f1, f2 = friction_of(robot, t, vr1, vr2)

    x1 = s1 * gains[S_INV_PHI1]
    x1 = 1.0 if x1 > 1.0 else (-1.0 if x1 < -1.0 else x1)
    x2 = s2 * gains[S_INV_PHI2]
    x2 = 1.0 if x2 > 1.0 else (-1.0 if x2 < -1.0 else x2)

    tau1 = (m11 * ar1 + m12 * ar2 + c11 * vr1 + c12 * vr2 + k1 + f1
            + gains[S_KD1] * s1 + gains[S_K1] * x1)
    tau2 = (m12 * ar1 + m22 * ar2 + c21 * vr1 + c22 * vr2 + k2 + f2
            + gains[S_KD2] * s2 + gains[S_K2] * x2)
    lim1 = gains[S_LIM1]
    lim2 = gains[S_LIM2]
    tau1 = lim1 if tau1 > lim1 else (-lim1 if tau1 < -lim1 else tau1)
    tau2 = lim2 if tau2 > lim2 else (-lim2 if tau2 < -lim2 else tau2)
    return (tau1, tau2)
