"""Computed-torque PID control, eq. 4.1–4.8 (thesis section 4.2).

Control law
-----------
With e = θ_d − θ (4.1), ė = θ̇_d − θ̇ (4.2) and the PID term of eq. 4.7,

    u = M(θ) (θ̈_d + K_p e + K_i ∫e dt + K_d ė) + C(θ, θ̇) θ̇ + f          (4.8)

where f collects stiffness and friction (eq. 4.4). On an exact model the
robot then obeys, per joint and decoupled, ë + K_d ė + K_p e + K_i ∫e = 0.

Implementation through inverse dynamics
---------------------------------------
The controller never builds M and C itself. It forms the commanded
acceleration a = θ̈_d + K_p e + K_i ∫e + K_d ė and asks the model for

    u = model.inverse_dynamics_terms(θ1, θ2, θ̇1, θ̇2, a1, a2)

For `core.robot.RobotModel` that is M(θ) a + C(θ, θ̇) θ̇ + K_R(θ − θ_R0) +
J_Rᵀ f_RE + f_RJ — eq. 4.8 term for term (the tests check it against M and C
by hand). Any other inverse-dynamics model with the same method — the
learned models of chapter 4 (DeLaN, FNN, RNN) — plugs in unchanged, which is
exactly the use chapter 4 makes of this controller.

Integral and anti-windup
------------------------
∫e is integrated with the tick's `dt_s` (backward rectangle: this tick's error
counts this tick). Two guards keep it from winding up when the drive cannot
follow (a blocked handle, a subject holding back, torque limit reached):

* clamping: |K_i ∫e| ≤ `integral_limit_rad_s2` per joint, so the integral alone
  can never ask for more than that acceleration;
* conditional integration: while a joint's output was saturated at
  `torque_limit_Nm` on the previous tick, its integral is not advanced in the
  direction that would push it further into saturation (e of the same sign as
  the saturated torque); it may still unwind. The sign test pairs joint i's
  error with joint i's torque: M's diagonal dominates (|m12| ≤ 0.055 against
  m11 = 0.114, m22 = 0.168 kg·m² on the thesis robot), so K_i ∫e_i moves τ_i
  the same way.

Gains (`CTPIDGains`, per joint) and why these values
----------------------------------------------------
With an exact model the error obeys s³ + K_d s² + K_p s + K_i = 0. The defaults
place all three poles at s = −ω with ω = 20 rad/s (3.2 Hz): K_d = 3ω,
K_p = 3ω², K_i = ω³, critically damped (no oscillation from the PID itself).

kp_1_s2 = 1200 1/s²,  kd_1_s = 60 1/s,  ki_1_s3 = 8000 1/s³
    Chosen by simulating the D (tests/core/control/test_tracking.py). ω = 14
    rad/s left 2.7 mm RMS on the constant-speed D with the thesis subject's
    passive arm on the handle (not in the model, so the loop sees ≈ 2–4 times
    the inertia it assumes and its poles slow down accordingly); ω = 20 gives
    1.9 mm, ω = 30 1.6 mm at 50 % more rate noise in the torque (K_d·M
    multiplies the rate error; one encoder count per 2 ms tick is 0.041 rad/s,
    and with the raw 2 ms difference as the rate these defaults pass ≈ 0.1–0.17
    N·m RMS of noise into the torque). ω·0.002 s = 0.04 leaves the discrete
    loop far from its limit. Routh–Hurwitz needs K_d K_p > K_i (checked); the
    triple pole has a margin of 9.
integral_limit_rad_s2 = 5 rad/s²
    Through M (0.11 and 0.17 kg·m²) that is 0.57 and 0.85 N·m: room for the
    stiffness and friction chapter 4 found to dominate the real robot's torque
    (Fig. 4.5–4.6), yet well under the drive's 2.21 N·m, so the integral alone
    cannot hold the drive saturated. The integral is no help against the
    transient loads of the D's corners; 10 rad/s² made those up to 0.35 mm worse.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from core.control.base import check_pair, check_torque_limit
from core.errors import ParameterError
from core.kernels import kernel
from core.robot_terms import R_SIZE, inverse_dynamics_terms

_OMEGA_RAD_S = 20.0
_GAIN_MAX = 1.0e7  # catches a gain in the wrong unit, not a tuning bound


@dataclass(frozen=True, slots=True)
class CTPIDGains:
    """Per-joint outer-loop gains of eq. 4.7–4.8; they act on acceleration, so
    K_p is 1/s², K_i 1/s³, K_d 1/s. See the module docstring for the values."""

    kp_1_s2: tuple[float, float] = (3.0 * _OMEGA_RAD_S**2, 3.0 * _OMEGA_RAD_S**2)
    ki_1_s3: tuple[float, float] = (_OMEGA_RAD_S**3, _OMEGA_RAD_S**3)
    kd_1_s: tuple[float, float] = (3.0 * _OMEGA_RAD_S, 3.0 * _OMEGA_RAD_S)
    integral_limit_rad_s2: tuple[float, float] = (5.0, 5.0)

    def __post_init__(self) -> None:
        kp = check_pair("kp_1_s2", self.kp_1_s2, "1/s²", 0.0, _GAIN_MAX,
                        "proportional gain on acceleration; > 0", low_open=True)
        kd = check_pair("kd_1_s", self.kd_1_s, "1/s", 0.0, _GAIN_MAX,
                        "derivative gain on acceleration; > 0", low_open=True)
        ki = check_pair("ki_1_s3", self.ki_1_s3, "1/s³", 0.0, _GAIN_MAX,
                        "integral gain on acceleration; ≥ 0 (0 = PD)", low_open=False)
        limit = check_pair("integral_limit_rad_s2", self.integral_limit_rad_s2, "rad/s²",
                           0.0, _GAIN_MAX, "largest |K_i ∫e|; > 0", low_open=True)
        for i in range(2):
            if not ki[i] < kp[i] * kd[i]:
                raise ParameterError(
                    f"ki_1_s3[{i}]", ki[i], f"< kp·kd = {kp[i] * kd[i]:g} 1/s³",
                    "Routh–Hurwitz: s³ + kd s² + kp s + ki has a root in the right half-plane "
                    "otherwise, so the loop would be unstable even on an exact model",
                )
        for name, value in (("kp_1_s2", kp), ("kd_1_s", kd), ("ki_1_s3", ki),
                            ("integral_limit_rad_s2", limit)):
            object.__setattr__(self, name, value)


# The gains vector of the kernels (ComputedTorquePID.constants), per joint; ∫e's clamp
# is kept on ∫e itself (rad·s): integral_limit_rad_s2 / K_i, 0 when K_i = 0.
(C_KP1, C_KP2, C_KI1, C_KI2, C_KD1, C_KD2, C_ZMAX1, C_ZMAX2, C_LIM1, C_LIM2,
 C_SIZE) = range(11)
# The state between ticks: ∫e per joint and the sign of each joint's saturation.
I_INT1, I_INT2, I_SAT1, I_SAT2, I_SIZE = range(5)


class ComputedTorquePID:
    """Computed-torque PID (eq. 4.8) on any model with `inverse_dynamics_terms`.

    The law is the kernels below (compiled in the loop, core.kernels): on a
    RobotModel the whole step is `ctpid_torques`; on any other model (a learned one)
    the same `ctpid_acceleration` and `ctpid_limit` run around the model's own
    inverse dynamics. This class validates and holds the gains and the state.
    """

    __slots__ = ("_model", "_robot", "_state", "constants", "gains", "torque_limit_Nm")

    name = "ctpid"

    def __init__(self, model, gains: CTPIDGains | None = None, *, torque_limit_Nm) -> None:
        if not callable(getattr(model, "inverse_dynamics_terms", None)):
            raise ParameterError(
                "model", type(model).__name__, "a model with inverse_dynamics_terms",
                "eq. 4.8 is evaluated through the model's inverse dynamics",
            )
        gains = CTPIDGains() if gains is None else gains
        if not isinstance(gains, CTPIDGains):
            raise ParameterError("gains", type(gains).__name__, "a CTPIDGains")
        self._model = model
        robot = getattr(model, "constants", None)
        self._robot = robot if robot is not None and len(robot) == R_SIZE else None
        self.gains = gains
        self.torque_limit_Nm = check_torque_limit(torque_limit_Nm)
        z_max = tuple(
            lim / ki if ki > 0.0 else 0.0
            for lim, ki in zip(gains.integral_limit_rad_s2, gains.ki_1_s3, strict=True)
        )
        self.constants = (*gains.kp_1_s2, *gains.ki_1_s3, *gains.kd_1_s, *z_max,
                          *self.torque_limit_Nm)
        self._state = [0.0, 0.0, 0.0, 0.0]

    @property
    def model(self):
        """The inverse-dynamics model eq. 4.8 is evaluated through."""
        return self._model

    @property
    def integral_limit_rad_s(self) -> tuple[float, float]:
        """The clamp on ∫e dt per joint (rad·s): integral_limit_rad_s2 / K_i (0 when K_i = 0)."""
        return (self.constants[C_ZMAX1], self.constants[C_ZMAX2])

    @property
    def integral_rad_s(self) -> tuple[float, float]:
        """∫e dt per joint (rad·s), for logging and tests."""
        return (self._state[I_INT1], self._state[I_INT2])

    @property
    def state(self) -> tuple[float, float, int, int]:
        """(∫e₁, ∫e₂, saturation sign of joint 1, of joint 2): what `step` carries over."""
        z = self._state
        return (z[I_INT1], z[I_INT2], int(z[I_SAT1]), int(z[I_SAT2]))

    def reset(self) -> None:
        """Zero the integral and forget the saturation state (and a model's own state: a
        recurrent model starts each trial from its zero state)."""
        self._state[:] = (0.0, 0.0, 0.0, 0.0)
        reset_model = getattr(self._model, "reset", None)
        if callable(reset_model):
            reset_model()

    def step(self, dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2):
        """Joint torques (N·m) of eq. 4.8 for one tick, limited to `torque_limit_Nm`."""
        if self._robot is not None:
            return ctpid_torques(self._robot, self.constants, self._state, dt_s, q1, q2, qd1,
                                 qd2, r1, r2, rd1, rd2, rdd1, rdd2)
        a1, a2 = ctpid_acceleration(self.constants, self._state, dt_s, q1, q2, qd1, qd2,
                                    r1, r2, rd1, rd2, rdd1, rdd2)
        tau1, tau2 = self._model.inverse_dynamics_terms(q1, q2, qd1, qd2, a1, a2)
        return ctpid_limit(self.constants, self._state, tau1, tau2)


@kernel
def ctpid_acceleration(gains, z, dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2):
    """The commanded acceleration a = θ̈_d + K_p e + K_i ∫e + K_d ė of eq. 4.8, with ∫e
    advanced in the state z (clamped, and held while its joint is saturated and the
    error would push it further in; the module notes)."""
    e1 = r1 - q1
    e2 = r2 - q2
    z1 = z[I_INT1]
    z2 = z[I_INT2]
    # A NaN or a non-positive dt must not poison the integral for the rest of the trial.
    if dt_s > 0.0 and math.isfinite(e1) and math.isfinite(e2):
        sat1 = z[I_SAT1]
        sat2 = z[I_SAT2]
        if not (sat1 > 0 and e1 > 0.0) and not (sat1 < 0 and e1 < 0.0):
            z1 += e1 * dt_s
            zm = gains[C_ZMAX1]
            z1 = zm if z1 > zm else (-zm if z1 < -zm else z1)
        if not (sat2 > 0 and e2 > 0.0) and not (sat2 < 0 and e2 < 0.0):
            z2 += e2 * dt_s
            zm = gains[C_ZMAX2]
            z2 = zm if z2 > zm else (-zm if z2 < -zm else z2)
        z[I_INT1] = z1
        z[I_INT2] = z2
    a1 = rdd1 + gains[C_KP1] * e1 + gains[C_KI1] * z1 + gains[C_KD1] * (rd1 - qd1)
    a2 = rdd2 + gains[C_KP2] * e2 + gains[C_KI2] * z2 + gains[C_KD2] * (rd2 - qd2)
    return (a1, a2)


@kernel
def ctpid_limit(gains, z, tau1, tau2):
    """The inverse dynamics' torques clipped to the drive limit, each joint's
    saturation sign kept in z for the next tick's conditional integration."""
    tau1, z[I_SAT1] = saturated(tau1, gains[C_LIM1])
    tau2, z[I_SAT2] = saturated(tau2, gains[C_LIM2])
    return (tau1, tau2)


@kernel
def saturated(tau, limit):
    """One joint's torque clipped to ±limit, with its saturation sign: +1 clipped from
    above, −1 from below, 0 within (a NaN torque passes through, unsaturated)."""
    if tau > limit:
        return (limit, 1.0)
    if tau < -limit:
        return (-limit, -1.0)
    return (tau, 0.0)


@kernel
def ctpid_torques(robot, gains, z, dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2):
    """One tick of eq. 4.8 on a RobotModel's constants `robot` (core.robot_terms)."""
    a1, a2 = ctpid_acceleration(gains, z, dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1,
                                rdd2)
    tau1, tau2 = inverse_dynamics_terms(robot, q1, q2, qd1, qd2, a1, a2, 0.0, 0.0)
    return ctpid_limit(gains, z, tau1, tau2)


class DiagonalInertia:
    """No model: eq. 4.8 with M held at its diagonal at one posture and C = f = 0, so the
    law is a plain PID per joint whose torque gains are the acceleration gains times that
    joint's inertia (kp·m_ii N·m/rad, …): the "PID alone" chapter 4's models are compared
    with, tuned by the same gains as the computed-torque PID."""

    __slots__ = ("inertia_kgm2", "max_joint_torque_Nm")

    def __init__(self, robot, q_rad) -> None:
        M = robot.mass_matrix(q_rad)
        self.inertia_kgm2 = (float(M[0, 0]), float(M[1, 1]))
        self.max_joint_torque_Nm = robot.max_joint_torque_Nm

    def inverse_dynamics_terms(self, q1, q2, qd1, qd2, qdd1, qdd2, fx=0.0, fy=0.0):
        return (self.inertia_kgm2[0] * qdd1, self.inertia_kgm2[1] * qdd2)
