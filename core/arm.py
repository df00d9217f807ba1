"""The subject's arm: a planar 2-link model with the shoulder held still (section 3.3).

Convention
----------
θ_s and θ_e are *absolute* angles in the global frame, as in eq. 3.16, and the
segments point from the shoulder S towards the hand along −e(θ):

    P_A = S − l_u e(θ_s) − l_f e(θ_e)                                   (3.16)

The relative elbow angle is θ_e − θ_s (the ISB elbow angle of eq. 3.38).

Dynamics in this convention (derived from the kinetic energy, see
docs/validation.md): with m_u, c_u, I_u the upper arm's mass, centre-of-mass
distance from the shoulder and inertia about its centre of mass, and m_f, c_f,
I_f the same for the forearm (hand lumped in, see `from_subject`),

    M_A = [[I_u + m_u c_u² + m_f l_u²,  k cos(θ_e − θ_s)],
           [k cos(θ_e − θ_s),           I_f + m_f c_f²  ]],   k = m_f l_u c_f
    C_A = [[0,                        −k sin(θ_e − θ_s) θ̇_e],
           [ k sin(θ_e − θ_s) θ̇_s,    0                   ]]

M_A is symmetric and Ṁ_A − 2C_A is skew-symmetric. Eq. 3.21–3.22 as printed mix
the relative-angle form (β2 with cos θ_e) with an asymmetric off-diagonal and
drop the velocity factor of C_A(2,1); they are not used.

Sign of the interaction force: `hand_force` is the force the hand applies to the
handle (what the sensor measures); the handle pushes back with −hand_force, so

    M_A θ̈_A + C_A θ̇_A = τ_A − J_Aᵀ F_hand                               (3.27)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from core import arm_terms as terms
from core.arrays import as_pairs, matrix2
from core.errors import ParameterError, UnreachableError, check_finite, check_positive, check_range
from core.kernels import suited

# Winter (2009), Table 4.1: segment mass / body mass, centre of mass / segment
# length from the proximal end, radius of gyration about the centre of mass /
# segment length.
WINTER_UPPER_ARM = (0.028, 0.436, 0.322)
WINTER_FOREARM = (0.016, 0.430, 0.303)
WINTER_HAND = (0.006, 0.506, 0.297)

BODY_MASS_RANGE_KG = (20.0, 250.0)
UPPER_ARM_RANGE_M = (0.15, 0.50)
FOREARM_RANGE_M = (0.15, 0.50)
SHOULDER_RANGE_M = (-2.0, 2.0)


@dataclass(frozen=True, slots=True)
class ArmModel:
    """A subject's arm as a planar 2-link chain from a fixed shoulder.

    `forearm_m` is the distal link from the elbow axis to the handle. The
    forearm's mass properties include whatever `from_subject` lumped into it.
    `side` is the arm in use; a left arm is the mirror image of a right arm,
    and its anatomical branch and ISB angles follow the mirror.
    """

    upper_arm_m: float
    forearm_m: float
    shoulder_x_m: float
    shoulder_y_m: float
    upper_arm_mass_kg: float
    upper_arm_com_m: float
    upper_arm_inertia_kgm2: float
    forearm_mass_kg: float
    forearm_com_m: float
    forearm_inertia_kgm2: float
    side: str = "right"
    a11: float = field(init=False)
    a22: float = field(init=False)
    coupling: float = field(init=False)
    constants: tuple[float, ...] = field(init=False, repr=False, compare=False)
    """The vector the formulas of core.arm_terms take (its ARM_* names)."""

    def __post_init__(self) -> None:
        check_range("upper_arm_m", self.upper_arm_m, *UPPER_ARM_RANGE_M, "m")
        check_range("forearm_m", self.forearm_m, *FOREARM_RANGE_M, "m")
        check_range("shoulder_x_m", self.shoulder_x_m, *SHOULDER_RANGE_M, "m")
        check_range("shoulder_y_m", self.shoulder_y_m, *SHOULDER_RANGE_M, "m")
        check_positive("upper_arm_mass_kg", self.upper_arm_mass_kg, "kg")
        check_positive("upper_arm_inertia_kgm2", self.upper_arm_inertia_kgm2, "kg·m²")
        check_positive("forearm_mass_kg", self.forearm_mass_kg, "kg")
        check_positive("forearm_inertia_kgm2", self.forearm_inertia_kgm2, "kg·m²")
        check_range("upper_arm_com_m", self.upper_arm_com_m, 0.0, self.upper_arm_m, "m")
        check_range("forearm_com_m", self.forearm_com_m, 0.0, self.forearm_m, "m")
        if self.side not in ("right", "left"):
            raise ParameterError("side", self.side, "'right' or 'left'")
        mu, cu, iu = self.upper_arm_mass_kg, self.upper_arm_com_m, self.upper_arm_inertia_kgm2
        mf, cf, i_f = self.forearm_mass_kg, self.forearm_com_m, self.forearm_inertia_kgm2
        object.__setattr__(self, "a11", iu + mu * cu * cu + mf * self.upper_arm_m**2)
        object.__setattr__(self, "a22", i_f + mf * cf * cf)
        object.__setattr__(self, "coupling", mf * self.upper_arm_m * cf)
        values = {
            terms.ARM_LU: self.upper_arm_m, terms.ARM_LF: self.forearm_m,
            terms.ARM_SX: self.shoulder_x_m, terms.ARM_SY: self.shoulder_y_m,
            terms.ARM_A11: self.a11, terms.ARM_A22: self.a22, terms.ARM_K: self.coupling,
            terms.ARM_SIGN: self.elbow_sign,
        }
        object.__setattr__(self, "constants",
                           tuple(float(values[i]) for i in range(terms.ARM_SIZE)))

    @classmethod
    def from_subject(
        cls,
        body_mass_kg: float,
        upper_arm_m: float,
        forearm_m: float,
        shoulder_xy_m: tuple[float, float],
        *,
        side: str = "right",
        hand: str = "lumped",
        inertia: str = "winter",
    ) -> ArmModel:
        """Size an arm from body mass and segment lengths with Winter's table.

        hand:
          "lumped" (default): the hand (0.006 M) grips the handle, so it is a point
            mass at the distal end of the forearm link and moves with it. Its
            rotation is free (wrist and the handle's passive joint), so its own
            rotational inertia is not carried by the forearm.
          "none": as in the thesis, the hand's mass is left out.
        inertia:
          "winter" (default): segment inertia from Winter's radius of gyration
            (0.322 l_u, 0.303 l_f about the centre of mass).
          "slender_rod": m l²/12 about the centre of mass, which is what the
            thesis's coefficients 12817/46875 = 0.436² + 1/12 and 8047/30000 =
            0.430² + 1/12 (eq. 3.21, 3.23) encode.
        """
        body = check_range("body_mass_kg", body_mass_kg, *BODY_MASS_RANGE_KG, "kg",
                           "Winter's proportions are for adults and adolescents")
        lu = check_range("upper_arm_m", upper_arm_m, *UPPER_ARM_RANGE_M, "m")
        lf = check_range("forearm_m", forearm_m, *FOREARM_RANGE_M, "m")
        try:
            sx, sy = shoulder_xy_m
        except (TypeError, ValueError):
            raise ParameterError("shoulder_xy_m", shoulder_xy_m, "a pair (x, y) in m") from None
        sx = check_finite("shoulder_x_m", sx, "m")
        sy = check_finite("shoulder_y_m", sy, "m")
        if hand not in ("lumped", "none"):
            raise ParameterError("hand", hand, "'lumped' or 'none'")
        if inertia not in ("winter", "slender_rod"):
            raise ParameterError("inertia", inertia, "'winter' or 'slender_rod'")

        def segment(table, length):
            mass_fraction, com_fraction, gyration_fraction = table
            mass = mass_fraction * body
            gyration_sq = (
                (gyration_fraction * length) ** 2 if inertia == "winter" else length**2 / 12.0
            )
            return mass, com_fraction * length, mass * gyration_sq

        mu, cu, iu = segment(WINTER_UPPER_ARM, lu)
        mf, cf, i_f = segment(WINTER_FOREARM, lf)
        if hand == "lumped":
            mh = WINTER_HAND[0] * body
            total = mf + mh
            com = (mf * cf + mh * lf) / total
            i_f = i_f + mf * (cf - com) ** 2 + mh * (lf - com) ** 2
            mf, cf = total, com
        return cls(lu, lf, sx, sy, mu, cu, iu, mf, cf, i_f, side)

    # ------------------------------------------------------------------ reach
    @property
    def reach_max_m(self) -> float:
        """Distance from the shoulder with the arm straight."""
        return self.upper_arm_m + self.forearm_m

    @property
    def reach_min_m(self) -> float:
        """Distance from the shoulder with the elbow folded completely."""
        return abs(self.upper_arm_m - self.forearm_m)

    def reach_at_elbow_flexion(self, flexion_rad: float) -> float:
        """Shoulder-to-hand distance when the elbow is flexed by `flexion_rad` (0 = straight)."""
        lu, lf = self.upper_arm_m, self.forearm_m
        return math.sqrt(lu * lu + lf * lf + 2.0 * lu * lf * math.cos(flexion_rad))

    @property
    def elbow_sign(self) -> int:
        """+1 when elbow flexion makes θ_e − θ_s positive (right arm), −1 for a left arm."""
        return 1 if self.side == "right" else -1

    # ------------------------------------------------------- component level
    # Each takes plain floats or numpy arrays of one shape and runs the kernel of the
    # same name in core.arm_terms, the one copy of each formula.
    def position(self, ts, te):
        """Hand position (x, y), eq. 3.16."""
        return suited(terms.position, ts)(self.constants, ts, te)

    def elbow_position(self, ts, te):
        """Elbow position (x, y)."""
        return suited(terms.elbow_position, ts)(self.constants, ts, te)

    def jacobian_terms(self, ts, te):
        """J_A = ∂P_A/∂θ_A as (j11, j12, j21, j22), eq. 3.17."""
        return suited(terms.jacobian_terms, ts)(self.constants, ts, te)

    def jacobian_dot_terms(self, ts, te, tsd, ted):
        """dJ_A/dt as (j11, j12, j21, j22), used in eq. 3.19."""
        return suited(terms.jacobian_dot_terms, ts)(self.constants, ts, te, tsd, ted)

    def mass_terms(self, ts, te):
        """M_A as (m11, m12, m22), derived for the absolute angles of eq. 3.16."""
        return suited(terms.mass_terms, ts)(self.constants, ts, te)

    def coriolis_terms(self, ts, te, tsd, ted):
        """C_A as (c11, c12, c21, c22), Christoffel form (Ṁ_A − 2C_A skew)."""
        return suited(terms.coriolis_terms, ts)(self.constants, ts, te, tsd, ted)

    def inverse_dynamics_terms(self, ts, te, tsd, ted, tsdd, tedd, fx=0.0, fy=0.0):
        """Net joint torques τ_A (shoulder, elbow) for a motion and the hand's force
        on the handle, eq. 3.27: τ_A = M_A θ̈_A + C_A θ̇_A + J_Aᵀ F_hand."""
        return suited(terms.inverse_dynamics_terms, ts)(
            self.constants, ts, te, tsd, ted, tsdd, tedd, fx, fy)

    def forward_dynamics_terms(self, ts, te, tsd, ted, tau_s, tau_e, fx=0.0, fy=0.0):
        """Joint accelerations θ̈_A for net joint torques and the hand's force (eq. 3.27)."""
        return suited(terms.forward_dynamics_terms, ts)(
            self.constants, ts, te, tsd, ted, tau_s, tau_e, fx, fy)

    def kinetic_energy_terms(self, ts, te, tsd, ted):
        """½ θ̇_Aᵀ M_A θ̇_A."""
        return suited(terms.kinetic_energy_terms, ts)(self.constants, ts, te, tsd, ted)

    def ik_terms(self, x, y):
        """Joint angles (θ_s, θ_e) for a hand position on the anatomical branch
        (elbow flexed the way an elbow bends). Unreachable points give NaN."""
        return suited(terms.ik_terms, x)(self.constants, x, y)

    def isb_terms(self, ts, te):
        """Display angles in the ISB convention (eq. 3.37–3.38), radians (core.arm_terms.isb_of:
        the same reading for a right and a left arm in the same posture)."""
        return terms.isb_of(self.constants, ts, te)

    # ----------------------------------------------------------- array level
    def fk(self, theta) -> np.ndarray:
        """Hand positions for arm angles θ_A[..., 2] (eq. 3.16)."""
        theta = as_pairs("theta", theta)
        return np.stack(self.position(theta[..., 0], theta[..., 1]), axis=-1)

    def sines(self, theta) -> tuple:
        """The sines and cosines of θ_A[..., 2] (core.arm_terms.trig), for `jacobian` and
        `jacobian_dot` at the same angles to share (core.arrays.joint_motion)."""
        theta = as_pairs("theta", theta)
        return suited(terms.trig, theta)(theta[..., 0], theta[..., 1])

    def jacobian(self, theta, sines=None) -> np.ndarray:
        """J_A[..., 2, 2] (eq. 3.17); `sines` of θ_A when the caller has them (`sines`)."""
        theta = as_pairs("theta", theta)
        if sines is None:
            return matrix2(self.jacobian_terms(theta[..., 0], theta[..., 1]))
        return matrix2(suited(terms.jacobian_of, theta)(self.constants, sines))

    def jacobian_dot(self, theta, theta_dot, sines=None) -> np.ndarray:
        """dJ_A/dt[..., 2, 2]; `sines` of θ_A when the caller has them (`sines`)."""
        theta, theta_dot = as_pairs("theta", theta), as_pairs("theta_dot", theta_dot)
        if sines is None:
            return matrix2(self.jacobian_dot_terms(theta[..., 0], theta[..., 1],
                                                   theta_dot[..., 0], theta_dot[..., 1]))
        return matrix2(suited(terms.jacobian_dot_of, theta)(self.constants, sines,
                                                            theta_dot[..., 0],
                                                            theta_dot[..., 1]))

    def mass_matrix(self, theta) -> np.ndarray:
        theta = as_pairs("theta", theta)
        m11, m12, m22 = self.mass_terms(theta[..., 0], theta[..., 1])
        return matrix2((m11, m12, m12, m22))

    def coriolis_matrix(self, theta, theta_dot) -> np.ndarray:
        theta, theta_dot = as_pairs("theta", theta), as_pairs("theta_dot", theta_dot)
        return matrix2(
            self.coriolis_terms(theta[..., 0], theta[..., 1], theta_dot[..., 0], theta_dot[..., 1])
        )

    def inverse_dynamics(self, theta, theta_dot, theta_ddot, hand_force=None) -> np.ndarray:
        """Net joint torques τ_A[..., 2] (eq. 3.27)."""
        theta, theta_dot = as_pairs("theta", theta), as_pairs("theta_dot", theta_dot)
        theta_ddot = as_pairs("theta_ddot", theta_ddot)
        f = np.zeros(2) if hand_force is None else as_pairs("hand_force", hand_force)
        return np.stack(
            self.inverse_dynamics_terms(
                theta[..., 0], theta[..., 1], theta_dot[..., 0], theta_dot[..., 1],
                theta_ddot[..., 0], theta_ddot[..., 1], f[..., 0], f[..., 1],
            ),
            axis=-1,
        )

    def forward_dynamics(self, theta, theta_dot, tau, hand_force=None) -> np.ndarray:
        """Joint accelerations θ̈_A[..., 2] (eq. 3.27)."""
        theta, theta_dot = as_pairs("theta", theta), as_pairs("theta_dot", theta_dot)
        tau = as_pairs("tau", tau)
        f = np.zeros(2) if hand_force is None else as_pairs("hand_force", hand_force)
        return np.stack(
            self.forward_dynamics_terms(
                theta[..., 0], theta[..., 1], theta_dot[..., 0], theta_dot[..., 1],
                tau[..., 0], tau[..., 1], f[..., 0], f[..., 1],
            ),
            axis=-1,
        )

    def ik(self, p) -> np.ndarray:
        """Arm angles θ_A[..., 2] for hand positions p[..., 2], anatomical branch.

        Raises UnreachableError naming the first point out of the arm's reach.
        """
        p = as_pairs("p", p)
        theta = np.stack(self.ik_terms(p[..., 0], p[..., 1]), axis=-1)
        flat_p, flat_t = p.reshape(-1, 2), theta.reshape(-1, 2)
        bad = np.flatnonzero(np.isnan(flat_t).any(axis=1))
        if bad.size:
            raise UnreachableError(self.reach_message(*flat_p[bad[0]]))
        return theta

    def reach_message(self, x: float, y: float) -> str:
        distance = math.hypot(x - self.shoulder_x_m, y - self.shoulder_y_m)
        if distance > self.reach_max_m:
            return (
                f"point ({x:.2f}, {y:.2f}) m is {distance:.2f} m from the shoulder; this arm "
                f"reaches {self.reach_max_m:.2f} m. Move the path or the shoulder closer."
            )
        return (
            f"point ({x:.2f}, {y:.2f}) m is {distance:.2f} m from the shoulder; the hand cannot "
            f"come closer than {self.reach_min_m:.2f} m. Move the path away from the shoulder."
        )

    def isb_angles(self, theta) -> np.ndarray:
        """ISB display angles[..., 2] in radians (eq. 3.37–3.38); degrees only at the display."""
        theta = as_pairs("theta", theta)
        return np.stack(self.isb_terms(theta[..., 0], theta[..., 1]), axis=-1)
