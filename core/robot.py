"""The planar parallelogram rehabilitation robot (section 3.2, eq. 3.1–3.14).

Frames and joints
-----------------
The global frame has its origin on the motor axes (Fig. 3.2), x and y in the
horizontal plane. θ_R1 is the absolute angle of the short link l1, and therefore
also of the parallel distal link l4; θ_R2 is the absolute angle of l2 and of the
parallel link l3. The end effector sits at the end of l4:

    P_R = l2 e(θ_R2) + l4 e(θ_R1),   e(θ) = (cos θ, sin θ)          (3.2)

Two levels of API
-----------------
* Component functions (`position`, `jacobian_terms`, `mass_terms`, …) take the
  joint values as separate numbers and return tuples of numbers. They accept
  plain floats (the 2 ms control tick, a few µs per call) or numpy arrays of
  any shape (whole trials, vectorised) with the same formula.
* Array functions (`fk`, `jacobian`, `mass_matrix`, `inverse_dynamics`, …) take
  and return numpy arrays shaped (..., 2) and (..., 2, 2) for scripting.

Sign of the interaction force
-----------------------------
`hand_force` is the force the subject's hand applies to the handle, which is
what the handle's sensor measures (the F_I of eq. 3.34). Eq. 3.26 writes the
same coupling as `τ_R − J_Rᵀ F_I` with F_I taken as the force on the hand; the
two agree with F_I = −hand_force. Here:

    M_R θ̈ + C_R θ̇ + K_R (θ − θ_R0) + J_Rᵀ f_RE + f_RJ = τ_R + J_Rᵀ F_hand   (3.6, 3.26)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from core import robot_terms as terms
from core.arrays import as_pairs, matrix2
from core.errors import (
    ParameterError,
    UnreachableError,
    check_finite,
    check_non_negative,
    check_positive,
)
from core.kernels import suited
from core.motor import MotorParameters

_DEG = math.pi / 180.0

WORKSPACE_MARGIN_M = 0.02
"""The safety supervisor's radial margin inside the robot's reach ring: the handle must stay
this far inside it, so it stops before the parallelogram folds flat at the spread limits
(device.safety.limits.SafetyLimits.workspace_margin_m's default; a trial's reach check
takes the same band, `RobotModel.reach_band_m`)."""


@dataclass(frozen=True, slots=True)
class Link:
    """One link of Table 3.3: mass, moment of inertia about its centre of gravity,
    and the centre of gravity in the link's own frame (x along the link)."""

    mass_kg: float
    inertia_kgm2: float
    cg_x_m: float
    cg_y_m: float

    def __post_init__(self) -> None:
        check_positive("mass_kg", self.mass_kg, "kg")
        check_positive("inertia_kgm2", self.inertia_kgm2, "kg·m²")
        check_finite("cg_x_m", self.cg_x_m, "m")
        check_finite("cg_y_m", self.cg_y_m, "m")


THESIS_LINKS = (
    Link(2.578, 0.022, -0.005, 0.0),
    Link(3.399, 0.061, 0.001, 0.0),
    Link(0.062, 0.001, 0.158, 0.0),
    Link(1.083, 0.010, 0.274, 0.008),
)


@dataclass(frozen=True, slots=True)
class JointLimits:
    """Software joint limits of the working branch (radians).

    The thesis gives none. The defaults keep the parallelogram at least 15°
    from folding flat (where it loses a degree of freedom: det J_R = 0) and
    cover the table in front of the robot with margin.
    """

    q1_min_rad: float = 0.0
    q1_max_rad: float = 315.0 * _DEG
    q2_min_rad: float = -45.0 * _DEG
    q2_max_rad: float = 180.0 * _DEG
    spread_min_rad: float = 15.0 * _DEG
    spread_max_rad: float = 165.0 * _DEG

    def __post_init__(self) -> None:
        for low, high in (
            ("q1_min_rad", "q1_max_rad"),
            ("q2_min_rad", "q2_max_rad"),
            ("spread_min_rad", "spread_max_rad"),
        ):
            lo = check_finite(low, getattr(self, low), "rad")
            hi = check_finite(high, getattr(self, high), "rad")
            if lo >= hi:
                raise ParameterError(high, hi, f"> {low} = {lo:g} rad")
        if not (self.spread_min_rad > 0.0 and self.spread_max_rad < math.pi):
            raise ParameterError(
                "spread_min_rad", self.spread_min_rad, "(0, π) rad",
                "θ_R1 − θ_R2 must stay on one side of the flat parallelogram",
            )


@dataclass(frozen=True, slots=True)
class Friction:
    """Continuous-velocity friction (the thesis's model family, ref. [5]).

    Joint friction per joint i:  f_RJ,i = Fc_i · tanh(θ̇_i / v_s) + b_i · θ̇_i
    End-effector friction:       f_RE = Fc_e · tanh(|v| / v_e) · v/|v| + b_e · v

    The thesis gives no numbers. The defaults are a belt-and-disc drive's order
    of magnitude (0.05 N·m breakaway, 0.02 N·m·s/rad viscous at the joint) and
    no end-effector friction (an air-bearing or low-friction handle); set them
    from identification data on a real robot.
    """

    joint_coulomb_Nm: tuple[float, float] = (0.05, 0.05)
    joint_viscous_Nms: tuple[float, float] = (0.02, 0.02)
    joint_smoothing_rad_s: float = 0.01
    ee_coulomb_N: float = 0.0
    ee_viscous_Ns_m: float = 0.0
    ee_smoothing_m_s: float = 0.005

    def __post_init__(self) -> None:
        for i in range(2):
            check_non_negative(f"joint_coulomb_Nm[{i}]", self.joint_coulomb_Nm[i], "N·m")
            check_non_negative(f"joint_viscous_Nms[{i}]", self.joint_viscous_Nms[i], "N·m·s/rad")
        check_positive("joint_smoothing_rad_s", self.joint_smoothing_rad_s, "rad/s")
        check_non_negative("ee_coulomb_N", self.ee_coulomb_N, "N")
        check_non_negative("ee_viscous_Ns_m", self.ee_viscous_Ns_m, "N·s/m")
        check_positive("ee_smoothing_m_s", self.ee_smoothing_m_s, "m/s")


FRICTIONLESS = Friction((0.0, 0.0), (0.0, 0.0))


@dataclass(frozen=True, slots=True)
class Stiffness:
    """Symmetric joint stiffness K_R and equilibrium θ_R0 of eq. 3.6 (3 + 2 parameters).

    The thesis gives no numbers; the default is no stiffness.
    """

    k11_Nm_rad: float = 0.0
    k12_Nm_rad: float = 0.0
    k22_Nm_rad: float = 0.0
    q1_rest_rad: float = 0.0
    q2_rest_rad: float = 0.0

    def __post_init__(self) -> None:
        check_non_negative("k11_Nm_rad", self.k11_Nm_rad, "N·m/rad")
        check_non_negative("k22_Nm_rad", self.k22_Nm_rad, "N·m/rad")
        check_finite("k12_Nm_rad", self.k12_Nm_rad, "N·m/rad")
        if self.k12_Nm_rad**2 > self.k11_Nm_rad * self.k22_Nm_rad:
            raise ParameterError(
                "k12_Nm_rad", self.k12_Nm_rad,
                f"|k12| <= sqrt(k11·k22) = {math.sqrt(self.k11_Nm_rad * self.k22_Nm_rad):g}",
                "K_R must be positive semi-definite to store, not create, energy",
            )
        check_finite("q1_rest_rad", self.q1_rest_rad, "rad")
        check_finite("q2_rest_rad", self.q2_rest_rad, "rad")


@dataclass(frozen=True, slots=True)
class RobotModel:
    """A 2-DOF planar parallelogram robot; the defaults are the thesis robot.

    Link lengths are Table 3.2, masses, inertias and centres of gravity Table 3.3,
    the drives Table 3.1. `branch` chooses the assembly of the inverse
    kinematics: +1 keeps θ_R1 − θ_R2 in (0, π) (the default working branch, with
    every link on the patient's side of the motor axes), −1 the mirror.
    """

    l1_m: float = 0.100
    l2_m: float = 0.310
    l3_m: float = 0.310
    l4_m: float = 0.375
    links: tuple[Link, Link, Link, Link] = THESIS_LINKS
    friction: Friction = field(default_factory=Friction)
    stiffness: Stiffness = field(default_factory=Stiffness)
    limits: JointLimits = field(default_factory=JointLimits)
    motors: tuple[MotorParameters, MotorParameters] = (MotorParameters(), MotorParameters())
    branch: int = 1
    alpha: tuple[float, float, float, float] = field(init=False)
    constants: tuple[float, ...] = field(init=False, repr=False, compare=False)
    """The vector the formulas of core.robot_terms take (its R_* names)."""

    def __post_init__(self) -> None:
        for name in ("l1_m", "l2_m", "l3_m", "l4_m"):
            check_positive(name, getattr(self, name), "m")
        if abs(self.l2_m - self.l3_m) > 1e-9:
            raise ParameterError(
                "l3_m", self.l3_m, f"equal to l2_m = {self.l2_m:g} m",
                "a parallelogram needs equal opposite links",
            )
        if self.l4_m <= self.l1_m:
            raise ParameterError(
                "l4_m", self.l4_m, f"> l1_m = {self.l1_m:g} m",
                "the end effector lies beyond the l3–l4 joint",
            )
        if len(self.links) != 4:
            raise ParameterError("links", len(self.links), "exactly 4 links")
        if self.branch not in (1, -1):
            raise ParameterError("branch", self.branch, "+1 or -1")
        object.__setattr__(self, "alpha", self._alphas())
        object.__setattr__(self, "constants", self._constants())

    def _constants(self) -> tuple[float, ...]:
        fr, st, lim = self.friction, self.stiffness, self.limits
        values = {
            terms.R_L2: self.l2_m, terms.R_L4: self.l4_m,
            terms.R_A1: self.alpha[0], terms.R_A2: self.alpha[1], terms.R_A3: self.alpha[2],
            terms.R_A4: self.alpha[3],
            terms.R_FC1: fr.joint_coulomb_Nm[0], terms.R_FC2: fr.joint_coulomb_Nm[1],
            terms.R_FV1: fr.joint_viscous_Nms[0], terms.R_FV2: fr.joint_viscous_Nms[1],
            terms.R_VS: fr.joint_smoothing_rad_s, terms.R_EE_C: fr.ee_coulomb_N,
            terms.R_EE_V: fr.ee_viscous_Ns_m, terms.R_EE_VS: fr.ee_smoothing_m_s,
            terms.R_K11: st.k11_Nm_rad, terms.R_K12: st.k12_Nm_rad, terms.R_K22: st.k22_Nm_rad,
            terms.R_Q10: st.q1_rest_rad, terms.R_Q20: st.q2_rest_rad,
            terms.R_BRANCH: self.branch,
            terms.R_Q1_MIN: lim.q1_min_rad, terms.R_Q1_MAX: lim.q1_max_rad,
            terms.R_Q2_MIN: lim.q2_min_rad, terms.R_Q2_MAX: lim.q2_max_rad,
            terms.R_SPREAD_MIN: lim.spread_min_rad, terms.R_SPREAD_MAX: lim.spread_max_rad,
        }
        return tuple(float(values[i]) for i in range(terms.R_SIZE))

    def _alphas(self) -> tuple[float, float, float, float]:
        """α1..α4 of eq. 3.11–3.14."""
        k1, k2, k3, k4 = self.links
        l1, l2 = self.l1_m, self.l2_m
        a1 = (
            (k1.cg_x_m**2 + k1.cg_y_m**2) * k1.mass_kg
            + k3.mass_kg * l1**2
            + (k4.cg_x_m**2 + k4.cg_y_m**2) * k4.mass_kg
            + k1.inertia_kgm2
            + k4.inertia_kgm2
        )
        a2 = k3.mass_kg * l1 * k3.cg_x_m + k4.mass_kg * l2 * k4.cg_x_m
        a3 = k3.mass_kg * l1 * k3.cg_y_m - k4.mass_kg * l2 * k4.cg_y_m
        a4 = (
            (k2.cg_x_m**2 + k2.cg_y_m**2) * k2.mass_kg
            + k4.mass_kg * l2**2
            + (k3.cg_x_m**2 + k3.cg_y_m**2) * k3.mass_kg
            + k2.inertia_kgm2
            + k3.inertia_kgm2
        )
        return (a1, a2, a3, a4)

    # ------------------------------------------------------------------ reach
    @property
    def reach_min_m(self) -> float:
        """Closest reachable distance from the motor axes within the spread limits."""
        return self._reach(self.limits.spread_max_rad)

    @property
    def reach_max_m(self) -> float:
        """Farthest reachable distance from the motor axes within the spread limits."""
        return self._reach(self.limits.spread_min_rad)

    def reach_band_m(self, margin_m: float = WORKSPACE_MARGIN_M) -> tuple[float, float]:
        """The distances from the motor axes the handle may take with `margin_m` kept
        inside the reach ring on both sides: the safety supervisor's band (its workspace
        margin) and, with the path's tracking allowance added, a trial check's."""
        return (self.reach_min_m + margin_m, self.reach_max_m - margin_m)

    def _reach(self, spread: float) -> float:
        l2, l4 = self.l2_m, self.l4_m
        return math.sqrt(l2 * l2 + l4 * l4 + 2.0 * l2 * l4 * math.cos(spread))

    @property
    def max_joint_torque_Nm(self) -> tuple[float, float]:
        return (self.motors[0].max_joint_torque_Nm, self.motors[1].max_joint_torque_Nm)

    # ------------------------------------------------------- component level
    # Each takes plain floats (the 2 ms tick) or numpy arrays of one shape (whole
    # trials) and runs the kernel of the same name in core.robot_terms, the one copy
    # of each formula.
    def position(self, q1, q2):
        """End-effector position (x, y), eq. 3.2."""
        return suited(terms.position, q1)(self.constants, q1, q2)

    def jacobian_terms(self, q1, q2):
        """J_R = ∂P_R/∂θ_R as (j11, j12, j21, j22), eq. 3.3.

        Columns follow θ_R = (θ_R1, θ_R2). Eq. 3.3 as printed lists the θ_R2
        column first; multiplying it by θ̇_R = (θ̇_R1, θ̇_R2) as eq. 3.4 does
        would swap the joints, so the columns are put in joint order here.
        """
        return suited(terms.jacobian_terms, q1)(self.constants, q1, q2)

    def jacobian_dot_terms(self, q1, q2, qd1, qd2):
        """dJ_R/dt as (j11, j12, j21, j22), used in eq. 3.5."""
        return suited(terms.jacobian_dot_terms, q1)(self.constants, q1, q2, qd1, qd2)

    def mass_terms(self, q1, q2):
        """M_R as (m11, m12, m22), eq. 3.7 with c12, s12 of eq. 3.9–3.10."""
        return suited(terms.mass_terms, q1)(self.constants, q1, q2)

    def coriolis_terms(self, q1, q2, qd1, qd2):
        """C_R as (c11, c12, c21, c22), eq. 3.8 (Christoffel form: Ṁ − 2C is skew)."""
        return suited(terms.coriolis_terms, q1)(self.constants, q1, q2, qd1, qd2)

    def friction_terms(self, q1, q2, qd1, qd2):
        """Joint torques of joint friction f_RJ plus end-effector friction J_Rᵀ f_RE."""
        return suited(terms.friction_terms, q1)(self.constants, q1, q2, qd1, qd2)

    def stiffness_terms(self, q1, q2):
        """K_R (θ_R − θ_R0) of eq. 3.6."""
        return suited(terms.stiffness_terms, q1)(self.constants, q1, q2)

    def bias_terms(self, q1, q2, qd1, qd2):
        """Everything in eq. 3.6 but M_R θ̈: C_R θ̇ + K_R(θ − θ_R0) + J_Rᵀ f_RE + f_RJ."""
        return suited(terms.bias_terms, q1)(self.constants, q1, q2, qd1, qd2)

    def inverse_dynamics_terms(self, q1, q2, qd1, qd2, qdd1, qdd2, fx=0.0, fy=0.0):
        """Joint torques τ_R for a motion and a hand force on the handle (eq. 3.26)."""
        return suited(terms.inverse_dynamics_terms, q1)(
            self.constants, q1, q2, qd1, qd2, qdd1, qdd2, fx, fy)

    def forward_dynamics_terms(self, q1, q2, qd1, qd2, tau1, tau2, fx=0.0, fy=0.0):
        """Joint accelerations θ̈_R for torques and a hand force on the handle (eq. 3.26)."""
        return suited(terms.forward_dynamics_terms, q1)(
            self.constants, q1, q2, qd1, qd2, tau1, tau2, fx, fy)

    def joint_torque_terms(self, q1, q2, fx, fy):
        """J_Rᵀ F: the joint torques a force F at the end effector produces (eq. 3.34)."""
        return suited(terms.joint_torque_terms, q1)(self.constants, q1, q2, fx, fy)

    def kinetic_energy_terms(self, q1, q2, qd1, qd2):
        """½ θ̇ᵀ M_R θ̇."""
        return suited(terms.kinetic_energy_terms, q1)(self.constants, q1, q2, qd1, qd2)

    def potential_energy_terms(self, q1, q2):
        """½ (θ − θ_R0)ᵀ K_R (θ − θ_R0): the energy the joint stiffness stores."""
        return suited(terms.potential_energy_terms, q1)(self.constants, q1, q2)

    def ik_terms(self, x, y):
        """Joint angles (θ_R1, θ_R2) for an end-effector position, closed form (eq. 3.1).

        Law of cosines on |P|² = l2² + l4² + 2 l2 l4 cos(θ_R1 − θ_R2), on the
        working branch. Unreachable points give NaN; `ik` raises instead.
        """
        return suited(terms.ik_terms, x)(self.constants, x, y)

    # ----------------------------------------------------------- array level
    def fk(self, q) -> np.ndarray:
        """End-effector positions for joint angles q[..., 2] (eq. 3.2)."""
        q = as_pairs("q", q)
        return np.stack(self.position(q[..., 0], q[..., 1]), axis=-1)

    def sines(self, q) -> tuple:
        """The sines and cosines of q[..., 2] (core.robot_terms.trig), for `jacobian` and
        `jacobian_dot` at the same angles to share (core.arrays.joint_motion)."""
        q = as_pairs("q", q)
        return suited(terms.trig, q)(q[..., 0], q[..., 1])

    def jacobian(self, q, sines=None) -> np.ndarray:
        """J_R[..., 2, 2] (eq. 3.3, columns in joint order); `sines` of q when the caller
        has them (`sines`)."""
        q = as_pairs("q", q)
        if sines is None:
            return matrix2(self.jacobian_terms(q[..., 0], q[..., 1]))
        return matrix2(suited(terms.jacobian_of, q)(self.constants, sines))

    def jacobian_dot(self, q, qd, sines=None) -> np.ndarray:
        """dJ_R/dt[..., 2, 2]; `sines` of q when the caller has them (`sines`)."""
        q, qd = as_pairs("q", q), as_pairs("qd", qd)
        if sines is None:
            return matrix2(self.jacobian_dot_terms(q[..., 0], q[..., 1], qd[..., 0],
                                                   qd[..., 1]))
        return matrix2(suited(terms.jacobian_dot_of, q)(self.constants, sines, qd[..., 0],
                                                        qd[..., 1]))

    def mass_matrix(self, q) -> np.ndarray:
        """M_R[..., 2, 2] (eq. 3.7)."""
        q = as_pairs("q", q)
        m11, m12, m22 = self.mass_terms(q[..., 0], q[..., 1])
        return matrix2((m11, m12, m12, m22))

    def coriolis_matrix(self, q, qd) -> np.ndarray:
        """C_R[..., 2, 2] (eq. 3.8)."""
        q, qd = as_pairs("q", q), as_pairs("qd", qd)
        return matrix2(self.coriolis_terms(q[..., 0], q[..., 1], qd[..., 0], qd[..., 1]))

    def friction_torque(self, q, qd) -> np.ndarray:
        """f_RJ + J_Rᵀ f_RE[..., 2]."""
        q, qd = as_pairs("q", q), as_pairs("qd", qd)
        return np.stack(
            self.friction_terms(q[..., 0], q[..., 1], qd[..., 0], qd[..., 1]), axis=-1
        )

    def inverse_dynamics(self, q, qd, qdd, hand_force=None) -> np.ndarray:
        """Joint torques τ_R[..., 2] for a motion and the hand's force on the handle."""
        q, qd, qdd = as_pairs("q", q), as_pairs("qd", qd), as_pairs("qdd", qdd)
        f = np.zeros(2) if hand_force is None else as_pairs("hand_force", hand_force)
        return np.stack(
            self.inverse_dynamics_terms(
                q[..., 0], q[..., 1], qd[..., 0], qd[..., 1], qdd[..., 0], qdd[..., 1],
                f[..., 0], f[..., 1],
            ),
            axis=-1,
        )

    def forward_dynamics(self, q, qd, tau, hand_force=None) -> np.ndarray:
        """Joint accelerations θ̈_R[..., 2] for torques and the hand's force on the handle."""
        q, qd, tau = as_pairs("q", q), as_pairs("qd", qd), as_pairs("tau", tau)
        f = np.zeros(2) if hand_force is None else as_pairs("hand_force", hand_force)
        return np.stack(
            self.forward_dynamics_terms(
                q[..., 0], q[..., 1], qd[..., 0], qd[..., 1], tau[..., 0], tau[..., 1],
                f[..., 0], f[..., 1],
            ),
            axis=-1,
        )

    def joint_torque_from_force(self, q, force) -> np.ndarray:
        """J_Rᵀ F[..., 2] (eq. 3.34)."""
        q, force = as_pairs("q", q), as_pairs("force", force)
        return np.stack(
            self.joint_torque_terms(q[..., 0], q[..., 1], force[..., 0], force[..., 1]), axis=-1
        )

    def kinetic_energy(self, q, qd) -> np.ndarray:
        q, qd = as_pairs("q", q), as_pairs("qd", qd)
        return self.kinetic_energy_terms(q[..., 0], q[..., 1], qd[..., 0], qd[..., 1])

    def ik(self, p, *, check_limits: bool = True) -> np.ndarray:
        """Joint angles θ_R[..., 2] for end-effector positions p[..., 2] (eq. 3.1).

        Raises UnreachableError naming the first point out of reach or beyond a
        joint limit.
        """
        p = as_pairs("p", p)
        q = np.stack(self.ik_terms(p[..., 0], p[..., 1]), axis=-1)
        flat_p, flat_q = p.reshape(-1, 2), q.reshape(-1, 2)
        bad = np.flatnonzero(np.isnan(flat_q).any(axis=1))
        if bad.size:
            x, y = flat_p[bad[0]]
            raise UnreachableError(
                f"point ({x:.3f}, {y:.3f}) m is {math.hypot(x, y):.3f} m from the robot's "
                f"motor axes; the robot reaches from {abs(self.l4_m - self.l2_m):.3f} to "
                f"{self.l2_m + self.l4_m:.3f} m. Move the point inside that ring."
            )
        if check_limits and flat_q.shape[0]:
            # every point at once; the first one outside is put in words
            codes = suited(terms.limit_violation, flat_q[:, 0])(
                self.constants, flat_q[:, 0], flat_q[:, 1])
            outside = np.flatnonzero(np.asarray(codes) != terms.WITHIN_LIMITS)
            if outside.size:
                i = int(outside[0])
                x, y = flat_p[i]
                problem = self.limit_problem(flat_q[i, 0], flat_q[i, 1])
                raise UnreachableError(f"point ({x:.3f}, {y:.3f}) m: {problem}")
        return q

    def limit_problem(self, q1: float, q2: float, *, now: bool = False) -> str:
        """Why (θ_R1, θ_R2) is outside the joint limits, or '' if it is inside
        (core.robot_terms.limit_violation, in words). For a point asked for (a path, a
        form's position: "would be", with what to change); `now`: for the robot's own
        angles as read (the safety banner: "are", and the banner's action says what to do)."""
        lim = self.limits
        violation = terms.limit_violation(self.constants, q1, q2)
        verb = "is" if now else "would be"
        if violation == terms.SPREAD_OUTSIDE:
            spread = (q1 - q2) * self.branch
            low, high = math.degrees(lim.spread_min_rad), math.degrees(lim.spread_max_rad)
            return (
                f"the robot's links {'are' if now else 'would be'} {math.degrees(spread):.1f}° "
                f"apart; they must stay within {low:.0f}–{high:.0f}°"
                " (near 0° or 180° the parallelogram folds flat)"
                + ("" if now else ". Move the point toward the middle of the robot's reach.")
            )
        if violation == terms.Q1_OUTSIDE:
            return (
                f"joint 1 {verb} at {math.degrees(q1):.1f}°, outside its limits "
                f"{math.degrees(lim.q1_min_rad):.0f}–{math.degrees(lim.q1_max_rad):.0f}°"
            )
        if violation == terms.Q2_OUTSIDE:
            return (
                f"joint 2 {verb} at {math.degrees(q2):.1f}°, outside its limits "
                f"{math.degrees(lim.q2_min_rad):.0f}–{math.degrees(lim.q2_max_rad):.0f}°"
            )
        return ""
