"""Physical human–robot interaction: the robot and the subject's arm joined at the handle
(section 3.4, eq. 3.26–3.38).

Forces here are the force the hand applies to the handle, `hand_force` (the
sensor's reading, rotated to the global frame): see the sign note in
`core.robot`. Every function works on plain floats for the 2 ms tick and on
numpy arrays for whole trials.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from core.arm import ArmModel
from core.arm_terms import (
    coriolis_of as arm_coriolis_of,
    ik_of as arm_ik_of,
    inverse_dynamics_of as arm_inverse_dynamics_of,
    isb_of as arm_isb_of,
    jacobian_dot_of as arm_jacobian_dot_of,
    jacobian_of as arm_jacobian_of,
    mass_of as arm_mass_of,
    trig as arm_trig,
)
from core.errors import SingularityError
from core.kernels import kernel, suited, where
from core.robot import RobotModel
from core.robot_terms import (
    bias_of as robot_bias_of,
    jacobian_dot_of as robot_jacobian_dot_of,
    jacobian_of as robot_jacobian_of,
    mass_of as robot_mass_of,
    position_of as robot_position_of,
    trig as robot_trig,
)

xp = math

# Below this smallest singular value of J_A (metres per radian) the arm is
# treated as near-straight and the rates use a damped pseudo-inverse. 0.02 m/rad
# is reached at about 4° of elbow flexion for a 0.30 m + 0.30 m arm.
ARM_SINGULAR_THRESHOLD_M = 0.02


def sensor_to_global(fx_sensor, fy_sensor, q1, offset_rad=0.0):
    """Rotate the sensor's planar force into the global frame, eq. 3.35–3.36 (the kernel
    `rotated_to_global`, on floats or arrays)."""
    return suited(rotated_to_global, q1)(fx_sensor, fy_sensor, q1, offset_rad)


@kernel
def rotated_to_global(fx_sensor, fy_sensor, q1, offset_rad):
    """The sensor's planar force in the global frame, eq. 3.35–3.36. The sensor turns
    with link 4, whose absolute angle is θ_R1; `offset_rad` is the sensor's mounting
    angle on that link (0 in the thesis)."""
    angle = q1 + offset_rad
    c = xp.cos(angle)
    s = xp.sin(angle)
    return (c * fx_sensor - s * fy_sensor, s * fx_sensor + c * fy_sensor)


def global_to_sensor(fx, fy, q1, offset_rad=0.0):
    """Inverse of `sensor_to_global`: what the sensor reads for a global force."""
    return sensor_to_global(fx, fy, -q1, -offset_rad)


def subject_angles(robot: RobotModel, arm: ArmModel, q1, q2):
    """The subject's arm angles (θ_s, θ_e) with the hand on the handle, eq. 3.28."""
    x, y = robot.position(q1, q2)
    return arm.ik_terms(x, y)


def subject_rates(robot: RobotModel, arm: ArmModel, q1, q2, qd1, qd2, ts, te):
    """θ̇_A = J_A⁻¹ J_R θ̇_R (eq. 3.32), with a damped pseudo-inverse near the
    straight-arm singularity. Returns (θ̇_s, θ̇_e, damped)."""
    return suited(arm_rates, q1)(robot.jacobian_terms(q1, q2), arm.jacobian_terms(ts, te),
                                 qd1, qd2)


def subject_accelerations(
    robot: RobotModel, arm: ArmModel, q1, q2, qd1, qd2, qdd1, qdd2, ts, te, tsd, ted
):
    """θ̈_A = J_A⁻¹ (J̇_R θ̇_R + J_R θ̈_R − J̇_A θ̇_A) (eq. 3.33), damped like the rates.
    Returns (θ̈_s, θ̈_e, damped)."""
    return suited(arm_accelerations, q1)(
        robot.jacobian_terms(q1, q2), arm.jacobian_terms(ts, te),
        robot.jacobian_dot_terms(q1, q2, qd1, qd2), arm.jacobian_dot_terms(ts, te, tsd, ted),
        qd1, qd2, qdd1, qdd2, tsd, ted)


def subject_torques(arm: ArmModel, ts, te, tsd, ted, tsdd, tedd, fx, fy):
    """The subject's net shoulder and elbow torques τ_A from eq. 3.27."""
    return arm.inverse_dynamics_terms(ts, te, tsd, ted, tsdd, tedd, fx, fy)


def subject_hand_force(arm: ArmModel, ts, te, tsd, ted, tsdd, tedd, tau_s, tau_e):
    """The hand's force that the subject's net torques τ_A imply (eq. 3.27 solved for F,
    the kernel `hand_force_from_torques`), on floats or arrays: (F_x, F_y, damped)."""
    at = suited(arm_trig, ts)(ts, te)
    return suited(hand_force_from_torques, ts)(arm.constants, at, tsd, ted, tsdd, tedd,
                                               tau_s, tau_e)


def subject_robot_torque(robot: RobotModel, q1, q2, fx, fy):
    """τ_subject = J_Rᵀ F (eq. 3.34): the subject's contribution at the robot's joints."""
    return robot.joint_torque_terms(q1, q2, fx, fy)


class SubjectState(NamedTuple):
    """Everything the interaction model derives about the subject from one robot sample."""

    force_x_N: float
    force_y_N: float
    shoulder_rad: float
    elbow_rad: float
    shoulder_rate_rad_s: float
    elbow_rate_rad_s: float
    shoulder_acc_rad_s2: float
    elbow_acc_rad_s2: float
    shoulder_torque_Nm: float
    elbow_torque_Nm: float
    isb_shoulder_rad: float
    isb_elbow_rad: float
    damped: bool


def subject_state(
    robot: RobotModel,
    arm: ArmModel,
    q1, q2, qd1, qd2, qdd1, qdd2,
    fx_sensor, fy_sensor,
    sensor_offset_rad=0.0,
) -> SubjectState:
    """Run the whole interaction model (eq. 3.28, 3.32–3.33, 3.35–3.38, 3.27) on one
    sample or on arrays of samples: the kernel `subject_motion`."""
    return SubjectState(*suited(subject_motion, q1)(
        robot.constants, arm.constants, q1, q2, qd1, qd2, qdd1, qdd2, fx_sensor, fy_sensor,
        sensor_offset_rad))


@kernel
def subject_motion(r, a, q1, q2, qd1, qd2, qdd1, qdd2, fx_sensor, fy_sensor, offset_rad):
    """The subject's state from one robot sample, SubjectState's values in its order: the
    hand's force in the global frame (eq. 3.35–3.36), the arm's angles (eq. 3.28), rates
    and accelerations (eq. 3.32–3.33, damped near the straight arm), net torques
    (eq. 3.27) and ISB display angles (eq. 3.37–3.38). Each state's sines are taken once."""
    fx, fy = rotated_to_global(fx_sensor, fy_sensor, q1, offset_rad)
    rt = robot_trig(q1, q2)
    x, y = robot_position_of(r, rt)
    ts, te, at = arm_ik_of(a, x, y)
    robot_jacobian = robot_jacobian_of(r, rt)
    arm_jacobian = arm_jacobian_of(a, at)
    tsd, ted, damped_rate = arm_rates(robot_jacobian, arm_jacobian, qd1, qd2)
    tsdd, tedd, damped_acc = arm_accelerations(
        robot_jacobian, arm_jacobian, robot_jacobian_dot_of(r, rt, qd1, qd2),
        arm_jacobian_dot_of(a, at, tsd, ted), qd1, qd2, qdd1, qdd2, tsd, ted)
    tau_s, tau_e = arm_inverse_dynamics_of(a, at, tsd, ted, tsdd, tedd, fx, fy)
    isb_s, isb_e = arm_isb_of(a, ts, te)
    return (fx, fy, ts, te, tsd, ted, tsdd, tedd, tau_s, tau_e, isb_s, isb_e,
            damped_rate | damped_acc)


@kernel
def arm_rates(robot_jacobian, arm_jacobian, qd1, qd2):
    """θ̇_A = J_A⁻¹ J_R θ̇_R (eq. 3.32), damped near the straight arm: (θ̇_s, θ̇_e, damped)."""
    r11, r12, r21, r22 = robot_jacobian
    a11, a12, a21, a22 = arm_jacobian
    vx = r11 * qd1 + r12 * qd2
    vy = r21 * qd1 + r22 * qd2
    return damped_solve(a11, a12, a21, a22, vx, vy, ARM_SINGULAR_THRESHOLD_M)


@kernel
def arm_accelerations(robot_jacobian, arm_jacobian, robot_jacobian_dot, arm_jacobian_dot,
                      qd1, qd2, qdd1, qdd2, tsd, ted):
    """θ̈_A = J_A⁻¹ (J̇_R θ̇_R + J_R θ̈_R − J̇_A θ̇_A) (eq. 3.33), damped like the rates."""
    r11, r12, r21, r22 = robot_jacobian
    a11, a12, a21, a22 = arm_jacobian
    d11, d12, d21, d22 = robot_jacobian_dot
    e11, e12, e21, e22 = arm_jacobian_dot
    ax = r11 * qdd1 + r12 * qdd2 + d11 * qd1 + d12 * qd2 - (e11 * tsd + e12 * ted)
    ay = r21 * qdd1 + r22 * qdd2 + d21 * qd1 + d22 * qd2 - (e21 * tsd + e22 * ted)
    return damped_solve(a11, a12, a21, a22, ax, ay, ARM_SINGULAR_THRESHOLD_M)


@kernel
def smallest_singular_value(a, b, c, d):
    """σ_min of [[a, b], [c, d]] in closed form."""
    total = a * a + b * b + c * c + d * d
    det = a * d - b * c
    disc = total * total - 4.0 * det * det
    disc = where(disc > 0.0, disc, 0.0)
    half = 0.5 * (total - xp.sqrt(disc))
    return xp.sqrt(where(half > 0.0, half, 0.0))


@kernel
def damped_solve(a, b, c, d, r1, r2, threshold):
    """Solve [[a, b], [c, d]] x = r, damped near a singularity: (x1, x2, damped).

    The normal equations (AᵀA + λ²I) x = Aᵀ r with λ² = threshold² − σ_min² where that
    is positive and 0 elsewhere: the exact solution where σ_min ≥ threshold, the damped
    least-squares one below it, growing smoothly from zero, so the result has no jump
    where damping starts."""
    sigma = smallest_singular_value(a, b, c, d)
    lam2 = threshold * threshold - sigma * sigma
    damped = lam2 > 0.0
    lam2 = where(damped, lam2, 0.0)
    p11 = a * a + c * c + lam2
    p12 = a * b + c * d
    p22 = b * b + d * d + lam2
    s1 = a * r1 + c * r2
    s2 = b * r1 + d * r2
    det = p11 * p22 - p12 * p12
    return ((p22 * s1 - p12 * s2) / det, (p11 * s2 - p12 * s1) / det, damped)


@kernel
def hand_force_from_torques(a, at, tsd, ted, tsdd, tedd, tau_s, tau_e):
    """The hand's force on the handle that net arm torques τ_A imply, eq. 3.27 solved for
    F: J_Aᵀ F = τ_A − (M_A θ̈_A + C_A θ̇_A), damped near the straight arm like the rates
    (there the torques say nothing of a push along the arm): (F_x, F_y, damped). `a` is
    the arm's constants and `at` its trig (core.arm_terms.trig); used to turn an
    estimate of the patient's torques (from EMG, thesis chapter 5) into the force the
    assistance judges."""
    motion_s, motion_e = arm_inverse_dynamics_of(a, at, tsd, ted, tsdd, tedd, 0.0, 0.0)
    j11, j12, j21, j22 = arm_jacobian_of(a, at)
    return damped_solve(j11, j21, j12, j22, tau_s - motion_s, tau_e - motion_e,
                        ARM_SINGULAR_THRESHOLD_M)


# ----------------------------------------------------------- coupled dynamics
ARM_DET_MIN_M2 = 1e-9
"""|det J_A| (m²) below which the arm counts as straight: the coupled model has no
solution there."""


def coupled_forward_dynamics(
    robot: RobotModel, arm: ArmModel, q1, q2, qd1, qd2, tau1, tau2, tau_s, tau_e
):
    """Robot and arm joined rigidly at the handle (eq. 3.26–3.27 under 3.28–3.31), for
    given net arm torques τ_A: the kernels `arm_state` and `coupled_motion` on the
    models' constants.

    Plain floats only. Returns (θ̈_R1, θ̈_R2, F_x, F_y, θ_s, θ_e, θ̇_s, θ̇_e).
    Raises SingularityError when the arm is straight (J_A not invertible).
    """
    r, a = robot.constants, arm.constants
    ok, ts, te, tsd, ted, rt, at = arm_state(r, a, q1, q2, qd1, qd2)
    if not ok:
        x, y = robot.position(q1, q2)
        raise SingularityError(
            f"the subject's arm is straight or out of reach at ({x:.3f}, {y:.3f}) m; "
            "the coupled model has no solution there. Keep the handle within the arm's reach."
        )
    qdd1, qdd2, fx, fy, *_ = coupled_motion(r, a, rt, at, q1, q2, qd1, qd2, tau1, tau2, tau_s,
                                            tau_e, tsd, ted)
    return (qdd1, qdd2, fx, fy, ts, te, tsd, ted)


@kernel
def arm_state(r, a, q1, q2, qd1, qd2):
    """The arm's angles and rates with the hand on the handle (eq. 3.28, 3.32, exact:
    θ̇_A = J_A⁻¹ J_R θ̇_R): (ok, θ_s, θ_e, θ̇_s, θ̇_e, the robot's trig, the arm's trig),
    ok False where the arm is straight or out of reach. `r` and `a` are the robot's
    and the arm's constants; the trig (core.robot_terms.trig, core.arm_terms.trig) is
    for `coupled_motion`, so that the state's sines are taken once."""
    rt = robot_trig(q1, q2)
    x, y = robot_position_of(r, rt)
    ts, te, at = arm_ik_of(a, x, y)
    a11, a12, a21, a22 = arm_jacobian_of(a, at)
    det_a = a11 * a22 - a12 * a21
    if not abs(det_a) > ARM_DET_MIN_M2 or math.isnan(ts):
        return (False, ts, te, 0.0, 0.0, rt, at)
    r11, r12, r21, r22 = robot_jacobian_of(r, rt)
    vx = r11 * qd1 + r12 * qd2
    vy = r21 * qd1 + r22 * qd2
    return (True, ts, te, (a22 * vx - a12 * vy) / det_a, (a11 * vy - a21 * vx) / det_a, rt,
            at)


@kernel
def coupled_motion(r, a, rt, at, q1, q2, qd1, qd2, tau1, tau2, tau_s, tau_e, tsd, ted):
    """The coupled robot and arm's accelerations for motor torques τ_R and net arm
    torques τ_A, at the arm state `arm_state` gave (with its trig rt, at). With
    G = J_A⁻¹ J_R, θ̇_A = G θ̇_R and θ̈_A = G θ̈_R + g, g = J_A⁻¹(J̇_R θ̇_R − J̇_A θ̇_A):

        (M_R + Gᵀ M_A G) θ̈_R = τ_R − h_R + Gᵀ (τ_A − C_A θ̇_A − M_A g)

    and the hand's force on the handle follows from the arm's equation,
    F_hand = J_A⁻ᵀ (τ_A − M_A θ̈_A − C_A θ̇_A). Returns (θ̈_R1, θ̈_R2, F_x, F_y,
    θ̈_s, θ̈_e, n11, n12, n22), the last three the inverse coupled mass, which maps a
    change of motor torque to θ̈_R (the accelerations are affine in τ_R)."""
    a11, a12, a21, a22 = arm_jacobian_of(a, at)
    det_a = a11 * a22 - a12 * a21
    # J_A⁻¹ entries
    i11 = a22 / det_a
    i12 = -a12 / det_a
    i21 = -a21 / det_a
    i22 = a11 / det_a
    r11, r12, r21, r22 = robot_jacobian_of(r, rt)
    g11 = i11 * r11 + i12 * r21
    g12 = i11 * r12 + i12 * r22
    g21 = i21 * r11 + i22 * r21
    g22 = i21 * r12 + i22 * r22
    d11, d12, d21, d22 = robot_jacobian_dot_of(r, rt, qd1, qd2)
    e11, e12, e21, e22 = arm_jacobian_dot_of(a, at, tsd, ted)
    wx = d11 * qd1 + d12 * qd2 - (e11 * tsd + e12 * ted)
    wy = d21 * qd1 + d22 * qd2 - (e21 * tsd + e22 * ted)
    gs = i11 * wx + i12 * wy
    ge = i21 * wx + i22 * wy

    ma11, ma12, ma22 = arm_mass_of(a, at)
    _, ca12, ca21, _ = arm_coriolis_of(a, at, tsd, ted)
    # arm-side generalised force left after its own bias and the g-part of its inertia
    ps = tau_s - ca12 * ted - (ma11 * gs + ma12 * ge)
    pe = tau_e - ca21 * tsd - (ma12 * gs + ma22 * ge)

    mr11, mr12, mr22 = robot_mass_of(r, rt)
    h1, h2 = robot_bias_of(r, rt, q1, q2, qd1, qd2)
    # Gᵀ M_A G
    t11 = ma11 * g11 + ma12 * g21
    t12 = ma11 * g12 + ma12 * g22
    t21 = ma12 * g11 + ma22 * g21
    t22 = ma12 * g12 + ma22 * g22
    m11 = mr11 + g11 * t11 + g21 * t21
    m12 = mr12 + g11 * t12 + g21 * t22
    m22 = mr22 + g12 * t12 + g22 * t22
    b1 = tau1 - h1 + g11 * ps + g21 * pe
    b2 = tau2 - h2 + g12 * ps + g22 * pe
    det = m11 * m22 - m12 * m12
    qdd1 = (m22 * b1 - m12 * b2) / det
    qdd2 = (m11 * b2 - m12 * b1) / det

    tsdd = g11 * qdd1 + g12 * qdd2 + gs
    tedd = g21 * qdd1 + g22 * qdd2 + ge
    # J_Aᵀ F = τ_A − M_A θ̈_A − C_A θ̇_A  →  F = J_A⁻ᵀ (…)
    us = tau_s - (ma11 * tsdd + ma12 * tedd) - ca12 * ted
    ue = tau_e - (ma12 * tsdd + ma22 * tedd) - ca21 * tsd
    fx = i11 * us + i21 * ue
    fy = i12 * us + i22 * ue
    return (qdd1, qdd2, fx, fy, tsdd, tedd, m22 / det, -m12 / det, m11 / det)


def coupled_energy(robot: RobotModel, arm: ArmModel, q1, q2, qd1, qd2) -> float:
    """Kinetic energy of robot and arm plus the robot's stored joint-stiffness energy."""
    ts, te = subject_angles(robot, arm, q1, q2)
    tsd, ted, _ = subject_rates(robot, arm, q1, q2, qd1, qd2, ts, te)
    return (
        robot.kinetic_energy_terms(q1, q2, qd1, qd2)
        + robot.potential_energy_terms(q1, q2)
        + arm.kinetic_energy_terms(ts, te, tsd, ted)
    )
