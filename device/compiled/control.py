"""The controller side of a tick, compiled: rate estimation, the sliding-mode and
computed-torque PID laws, and the performance-based assistance.

Statement for statement the arithmetic of core.signal.RateEstimator,
core.control.smc, core.control.ctpid (on a core.robot.RobotModel) and
core.control.assistance, which document the laws (eq. 3.34–3.36, 4.1–4.8). The
constants are a flat array filled by `controller_constants` from the pipeline's own
objects; the state (estimators, integral) lives in a small array between ticks.
"""

from __future__ import annotations

import math

import numpy as np

from core.control.ctpid import ComputedTorquePID
from core.control.smc import SlidingModeController
from core.robot import RobotModel
from device.compiled.jit import kernel

SMC, CTPID = 0, 1

# --- constants, `controller_constants`. The gains K_G1…K_G8 are, per joint pair,
# SMC: Λ, K_D, K, 1/Φ; CT-PID: K_p, K_i, K_d and the clamp on ∫e.
(K_KIND, K_A1, K_A2, K_A3, K_A4, K_L2, K_L4, K_FC1, K_FC2, K_FV1, K_FV2, K_VS, K_EE_C,
 K_EE_V, K_EE_VS, K_K11, K_K12, K_K22, K_Q10, K_Q20, K_LIM1, K_LIM2,
 K_G1, K_G2, K_G3, K_G4, K_G5, K_G6, K_G7, K_G8,
 K_TOLERANCE, K_LEVEL, K_MIN_FORCE_SQ, K_EST_DT, K_EST_HALF_DT2, K_EST_ALPHA, K_EST_BETA_DT,
 K_EST_GAMMA_DT2, K_PERIOD, K_SENSOR_OFFSET, K_SIZE) = range(41)

# --- state
(Z_ANGLE1, Z_RATE1, Z_ACC1, Z_ANGLE2, Z_RATE2, Z_ACC2, Z_INT1, Z_INT2, Z_SAT1, Z_SAT2,
 Z_SIZE) = range(11)

# --- what `control` leaves for the record, in the order of TickPipeline._last
(C_PHASE, C_QD1, C_QD2, C_QDD1, C_QDD2, C_R1, C_R2, C_RD1, C_RD2, C_RDD1, C_RDD2, C_TAU1,
 C_TAU2, C_OUT1, C_OUT2, C_XD, C_YD, C_VXD, C_VYD, C_DX, C_DY, C_FX, C_FY, C_ANGLE, C_ACTIVE,
 C_SIZE) = range(26)

PHASE_APPROACH, PHASE_EXERCISE, PHASE_HOLD = 1, 2, 3
_MIN_DIRECTION_SQ = 1.0e-12


def unsupported_controller(pipeline) -> str:
    """Why the pipeline's controller cannot run compiled, or ''."""
    controller = pipeline.controller
    if type(controller) not in (SlidingModeController, ComputedTorquePID):
        return f"controller {type(controller).__name__} has no compiled form"
    if type(controller.model) is not RobotModel:
        return f"the controller's model is a {type(controller.model).__name__}, not a RobotModel"
    if type(pipeline.assistance.robot) is not RobotModel:
        return "the assistance's robot is not a RobotModel"
    return ""


def controller_constants(pipeline) -> np.ndarray:
    """The flat constants of a device.loop.pipeline.TickPipeline's controller, assistance and
    rate estimators (see `unsupported_controller` for what is accepted)."""
    controller = pipeline.controller
    model = controller.model
    fr, st = model.friction, model.stiffness
    k = np.zeros(K_SIZE)
    k[K_A1:K_A4 + 1] = model.alpha
    k[[K_L2, K_L4]] = model.l2_m, model.l4_m
    k[[K_FC1, K_FC2]] = fr.joint_coulomb_Nm
    k[[K_FV1, K_FV2]] = fr.joint_viscous_Nms
    k[[K_VS, K_EE_C, K_EE_V, K_EE_VS]] = (
        fr.joint_smoothing_rad_s, fr.ee_coulomb_N, fr.ee_viscous_Ns_m, fr.ee_smoothing_m_s)
    k[[K_K11, K_K12, K_K22, K_Q10, K_Q20]] = (
        st.k11_Nm_rad, st.k12_Nm_rad, st.k22_Nm_rad, st.q1_rest_rad, st.q2_rest_rad)
    k[[K_LIM1, K_LIM2]] = controller.torque_limit_Nm
    g = controller.gains
    if isinstance(controller, SlidingModeController):
        k[K_KIND] = SMC
        k[K_G1:K_G8 + 1] = (*g.lambda_1_s, *g.k_d_Nms_rad, *g.k_robust_Nm,
                            1.0 / g.boundary_rad_s[0], 1.0 / g.boundary_rad_s[1])
    else:
        k[K_KIND] = CTPID
        k[K_G1:K_G8 + 1] = (*g.kp_1_s2, *g.ki_1_s3, *g.kd_1_s, *controller.integral_limit_rad_s)
    assistance = pipeline.assistance
    k[[K_TOLERANCE, K_LEVEL, K_MIN_FORCE_SQ]] = (
        assistance.tolerance_rad, assistance.level, assistance.min_force_N ** 2)
    est1, est2 = pipeline.rate_estimators
    if est1.coefficients != est2.coefficients:
        raise ValueError("the compiled tick takes one rate estimator's gains for both joints")
    k[K_EST_DT:K_EST_GAMMA_DT2 + 1] = est1.coefficients
    k[[K_PERIOD, K_SENSOR_OFFSET]] = pipeline.period_s, pipeline.sensor_offset_rad
    return k


def initial_state(pipeline, q1: float, q2: float) -> np.ndarray:
    """The state after TickPipeline.begin(q1, q2): estimators at rest at the angles."""
    z = np.zeros(Z_SIZE)
    z[Z_ANGLE1] = q1
    z[Z_ANGLE2] = q2
    return z


@kernel
def _estimate(k, z, i, angle):
    """RateEstimator.update on the primed tracker in z[i:i+3]."""
    dt = k[K_EST_DT]
    predicted = z[i] + z[i + 1] * dt + z[i + 2] * k[K_EST_HALF_DT2]
    rate = z[i + 1] + z[i + 2] * dt
    residual = angle - predicted
    z[i] = predicted + k[K_EST_ALPHA] * residual
    z[i + 1] = rate + k[K_EST_BETA_DT] * residual
    z[i + 2] += k[K_EST_GAMMA_DT2] * residual


@kernel
def _friction(k, q1, q2, qd1, qd2):
    """RobotModel.friction_terms."""
    vs = k[K_VS]
    f1 = k[K_FC1] * math.tanh(qd1 / vs) + (k[K_FV1] * qd1)
    f2 = k[K_FC2] * math.tanh(qd2 / vs) + (k[K_FV2] * qd2)
    if k[K_EE_C] == 0.0 and k[K_EE_V] == 0.0:
        return f1, f2
    j11 = -k[K_L4] * math.sin(q1)
    j12 = -k[K_L2] * math.sin(q2)
    j21 = k[K_L4] * math.cos(q1)
    j22 = k[K_L2] * math.cos(q2)
    vx = j11 * qd1 + j12 * qd2
    vy = j21 * qd1 + j22 * qd2
    speed = math.sqrt(vx * vx + vy * vy)
    scale = k[K_EE_VS]
    over = math.tanh(speed / scale) / speed if speed > 1e-12 else 1.0 / scale
    coulomb_gain = k[K_EE_C] * over
    fx = (coulomb_gain + k[K_EE_V]) * vx
    fy = (coulomb_gain + k[K_EE_V]) * vy
    return f1 + j11 * fx + j21 * fy, f2 + j12 * fx + j22 * fy


@kernel
def _smc(k, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2):
    """SlidingModeController.step."""
    lam1 = k[K_G1]
    lam2 = k[K_G2]
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
    d = q1 - q2
    m11 = k[K_A1] + 0.0 * d
    m12 = k[K_A2] * math.cos(d) + k[K_A3] * math.sin(d)
    m22 = k[K_A4] + 0.0 * d
    g = k[K_A2] * math.sin(d) - k[K_A3] * math.cos(d)
    zero = 0.0 * d
    c11, c12, c21, c22 = zero, g * qd2, -g * qd1, zero
    e1s = q1 - k[K_Q10]
    e2s = q2 - k[K_Q20]
    k1 = k[K_K11] * e1s + k[K_K12] * e2s
    k2 = k[K_K12] * e1s + k[K_K22] * e2s
    f1, f2 = _friction(k, q1, q2, vr1, vr2)
    x1 = s1 * k[K_G7]
    x1 = 1.0 if x1 > 1.0 else (-1.0 if x1 < -1.0 else x1)
    x2 = s2 * k[K_G8]
    x2 = 1.0 if x2 > 1.0 else (-1.0 if x2 < -1.0 else x2)
    tau1 = (m11 * ar1 + m12 * ar2 + c11 * vr1 + c12 * vr2 + k1 + f1
            + k[K_G3] * s1 + k[K_G5] * x1)
    tau2 = (m12 * ar1 + m22 * ar2 + c21 * vr1 + c22 * vr2 + k2 + f2
            + k[K_G4] * s2 + k[K_G6] * x2)
    lim1 = k[K_LIM1]
    lim2 = k[K_LIM2]
    tau1 = lim1 if tau1 > lim1 else (-lim1 if tau1 < -lim1 else tau1)
    tau2 = lim2 if tau2 > lim2 else (-lim2 if tau2 < -lim2 else tau2)
    return tau1, tau2


@kernel
def _ctpid(k, z, dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2):
    """ComputedTorquePID.step on RobotModel.inverse_dynamics_terms (no hand force)."""
    e1 = r1 - q1
    e2 = r2 - q2
    z1 = z[Z_INT1]
    z2 = z[Z_INT2]
    sat1 = z[Z_SAT1]
    sat2 = z[Z_SAT2]
    if dt_s > 0.0 and math.isfinite(e1) and math.isfinite(e2):
        if not (sat1 > 0 and e1 > 0.0) and not (sat1 < 0 and e1 < 0.0):
            z1 += e1 * dt_s
            zm = k[K_G7]
            z1 = zm if z1 > zm else (-zm if z1 < -zm else z1)
        if not (sat2 > 0 and e2 > 0.0) and not (sat2 < 0 and e2 < 0.0):
            z2 += e2 * dt_s
            zm = k[K_G8]
            z2 = zm if z2 > zm else (-zm if z2 < -zm else z2)
        z[Z_INT1] = z1
        z[Z_INT2] = z2
    a1 = rdd1 + k[K_G1] * e1 + k[K_G3] * z1 + k[K_G5] * (rd1 - qd1)
    a2 = rdd2 + k[K_G2] * e2 + k[K_G4] * z2 + k[K_G6] * (rd2 - qd2)
    d = q1 - q2
    m11 = k[K_A1] + 0.0 * d
    m12 = k[K_A2] * math.cos(d) + k[K_A3] * math.sin(d)
    m22 = k[K_A4] + 0.0 * d
    g = k[K_A2] * math.sin(d) - k[K_A3] * math.cos(d)
    c12 = g * qd2
    c21 = -g * qd1
    e1s = q1 - k[K_Q10]
    e2s = q2 - k[K_Q20]
    k1 = k[K_K11] * e1s + k[K_K12] * e2s
    k2 = k[K_K12] * e1s + k[K_K22] * e2s
    f1, f2 = _friction(k, q1, q2, qd1, qd2)
    h1 = c12 * qd2 + k1 + f1
    h2 = c21 * qd1 + k2 + f2
    j11 = -k[K_L4] * math.sin(q1)
    j12 = -k[K_L2] * math.sin(q2)
    j21 = k[K_L4] * math.cos(q1)
    j22 = k[K_L2] * math.cos(q2)
    tau1 = m11 * a1 + m12 * a2 + h1 - (j11 * 0.0 + j21 * 0.0)
    tau2 = m12 * a1 + m22 * a2 + h2 - (j12 * 0.0 + j22 * 0.0)
    lim1 = k[K_LIM1]
    lim2 = k[K_LIM2]
    if tau1 > lim1:
        tau1 = lim1
        z[Z_SAT1] = 1.0
    elif tau1 < -lim1:
        tau1 = -lim1
        z[Z_SAT1] = -1.0
    else:
        z[Z_SAT1] = 0.0
    if tau2 > lim2:
        tau2 = lim2
        z[Z_SAT2] = 1.0
    elif tau2 < -lim2:
        tau2 = -lim2
        z[Z_SAT2] = -1.0
    else:
        z[Z_SAT2] = 0.0
    return tau1, tau2


@kernel
def _assist(k, q1, q2, tau1, tau2, fx, fy, dir_x, dir_y):
    """PerformanceAssistance.apply: (τ1, τ2, active, angle)."""
    force_sq = fx * fx + fy * fy
    dir_sq = dir_x * dir_x + dir_y * dir_y
    if not (force_sq >= k[K_MIN_FORCE_SQ]) or not (dir_sq > _MIN_DIRECTION_SQ):
        return tau1, tau2, 0.0, math.nan
    angle = math.atan2(abs(fx * dir_y - fy * dir_x), fx * dir_x + fy * dir_y)
    if not (angle <= k[K_TOLERANCE]):
        return tau1, tau2, 0.0, angle
    level = k[K_LEVEL]
    j11 = -k[K_L4] * math.sin(q1)
    j12 = -k[K_L2] * math.sin(q2)
    j21 = k[K_L4] * math.cos(q1)
    j22 = k[K_L2] * math.cos(q2)
    g1 = j11 * fx + j21 * fy
    g2 = j12 * fx + j22 * fy
    r1 = level * g1
    r2 = level * g2
    if r1 * tau1 > 0.0:
        tau1 = tau1 - r1 if abs(r1) < abs(tau1) else 0.0
    if r2 * tau2 > 0.0:
        tau2 = tau2 - r2 if abs(r2) < abs(tau2) else 0.0
    return tau1, tau2, 1.0, angle


@kernel
def control(k, z, tick, rows, approach_ticks, q1, q2, force_x, force_y, c):
    """TickPipeline.control for tick `tick`: fills c[0:C_SIZE] (the pipeline's `_last`);
    the commanded torques are c[C_OUT1], c[C_OUT2]."""
    _estimate(k, z, Z_ANGLE1, q1)
    _estimate(k, z, Z_ANGLE2, q2)
    qd1 = z[Z_RATE1]
    qdd1 = z[Z_ACC1]
    qd2 = z[Z_RATE2]
    qdd2 = z[Z_ACC2]
    n = rows.shape[0]
    if tick < n:
        row = rows[tick]
        phase = PHASE_APPROACH if tick < approach_ticks else PHASE_EXERCISE
        xd, yd, vxd, vyd, dx, dy = row[0], row[1], row[2], row[3], row[4], row[5]
        r1, r2, rd1, rd2, rdd1, rdd2 = row[6], row[7], row[8], row[9], row[10], row[11]
    else:
        row = rows[n - 1]
        phase = PHASE_HOLD
        xd, yd, vxd, vyd, dx, dy = row[0], row[1], 0.0, 0.0, row[4], row[5]
        r1, r2, rd1, rd2, rdd1, rdd2 = row[6], row[7], 0.0, 0.0, 0.0, 0.0
    if k[K_KIND] == SMC:
        tau1, tau2 = _smc(k, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2)
    else:
        tau1, tau2 = _ctpid(k, z, k[K_PERIOD], q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2)
    angle = q1 + k[K_SENSOR_OFFSET]
    co = math.cos(angle)
    si = math.sin(angle)
    fx = co * force_x - si * force_y
    fy = si * force_x + co * force_y
    out1, out2, active, force_angle = _assist(k, q1, q2, tau1, tau2, fx, fy, dx, dy)
    if phase != PHASE_EXERCISE:
        # the subject's effort counts only on the exercise, not on the way to it
        out1, out2, active = tau1, tau2, 0.0
    c[C_OUT1] = out1
    c[C_OUT2] = out2
    c[C_PHASE] = phase
    c[C_QD1] = qd1
    c[C_QD2] = qd2
    c[C_QDD1] = qdd1
    c[C_QDD2] = qdd2
    c[C_R1] = r1
    c[C_R2] = r2
    c[C_RD1] = rd1
    c[C_RD2] = rd2
    c[C_RDD1] = rdd1
    c[C_RDD2] = rdd2
    c[C_TAU1] = tau1
    c[C_TAU2] = tau2
    c[C_XD] = xd
    c[C_YD] = yd
    c[C_VXD] = vxd
    c[C_VYD] = vyd
    c[C_DX] = dx
    c[C_DY] = dy
    c[C_FX] = fx
    c[C_FY] = fy
    c[C_ANGLE] = force_angle
    c[C_ACTIVE] = active


def pipeline_state(pipeline) -> np.ndarray:
    """The per-tick state of a pipeline whose trackers are primed: z for `control`."""
    z = np.zeros(Z_SIZE)
    for i, est in zip((Z_ANGLE1, Z_ANGLE2), pipeline.rate_estimators, strict=True):
        z[i:i + 3] = est.angle, est.rate, est.acceleration
    if isinstance(pipeline.controller, ComputedTorquePID):
        z[Z_INT1:Z_SAT2 + 1] = pipeline.controller.state
    return z


def restore_pipeline(pipeline, z: np.ndarray, c: np.ndarray | None) -> None:
    """Hand the state `control` carried on back to the pipeline's own objects, and the
    last tick's values (c, when a tick ran) to `record`."""
    values = z.tolist()
    for i, est in zip((Z_ANGLE1, Z_ANGLE2), pipeline.rate_estimators, strict=True):
        est.reset(values[i], values[i + 1], values[i + 2])
    if isinstance(pipeline.controller, ComputedTorquePID):
        pipeline.controller.restore_state(values[Z_INT1:Z_SAT2 + 1])
    if c is not None:
        pipeline.set_last_tick(last_tick(c))


def last_tick(c: np.ndarray) -> tuple:
    """TickPipeline.last_tick from `control`'s output c."""
    values = c.tolist()
    values[C_PHASE] = int(values[C_PHASE])
    values[C_ACTIVE] = bool(values[C_ACTIVE])
    return tuple(values)
