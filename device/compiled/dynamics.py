"""The simulator's physics, compiled: the robot coupled to a virtual patient's arm, the
patient's torques and the sensors.

The only implementation of the simulator's fused dynamics (eq. 3.6, 3.20, 3.27–3.33)
and of the virtual patients' torques: device.sim.simulator and device.sim.patients call these
kernels, and the tests hold them to core.interaction.coupled_forward_dynamics; the
module notes of those two modules explain the physics. Constants travel in flat
float arrays whose layout is the index names below, filled by `simulator_constants`
and `patient_arrays` from the Python objects.
"""

from __future__ import annotations

import math

import numpy as np

from device.compiled.jit import kernel

# --- simulator constants (robot, arm, sensor, drive), `simulator_constants`
(S_L2, S_L4, S_A1, S_A2, S_A3, S_A4, S_FC1, S_FC2, S_FV1, S_FV2, S_INV_VS, S_EE_C, S_EE_V,
 S_EE_VS, S_K11, S_K12, S_K22, S_Q10, S_Q20, S_JOINT_FRICTION, S_EE_FRICTION, S_STIFF,
 S_LU, S_LF, S_SX, S_SY, S_A11, S_A22, S_K, S_SIGN, S_LULF2, S_INV_2LULF, S_LULF, S_INV_LF,
 S_OFFSET, S_NOISE_XY, S_NOISE_Z, S_LOAD, S_RXY, S_RZ, S_LIMIT_XY, S_LIMIT_Z, S_CPR1, S_CPR2,
 S_STEP, S_RATE, S_MAX1, S_MAX2, S_SIZE) = range(49)

# --- patient constants, `patient_arrays`
(P_ACTIVE, P_EFFORT, P_TS0, P_PHI0, P_LU, P_LF, P_PKS, P_PKC, P_PKE, P_PBS, P_PBC, P_PBE,
 P_KS, P_KC, P_KE, P_BS, P_BC, P_BE, P_DURATION, P_TOTAL, P_DT_RATE, P_ROWS, P_TREMOR,
 P_OMEGA, P_PHASE, P_AMP_S, P_AMP_E, P_SPASTIC, P_TH_S, P_TH_E, P_G_S, P_G_E, P_VB_S, P_VB_E,
 P_WRONG, P_WRONG_N, P_EP_LEN, P_EP_WINDOW, P_EPISODES, P_REST_DX, P_REST_DY, P_SIZE) = range(42)

# --- simulator state (SimulatorBackend.kernel_state)
(X_STEPS, X_Q1, X_Q2, X_QD1, X_QD2, X_TAU1, X_TAU2, X_LAST_TAU1, X_LAST_TAU2, X_T0, X_ANCHOR,
 X_CACHED) = range(12)
X_LAST = 12  # the last full evaluation, 15 values (see `evaluate`)
X_READING = X_LAST + 15  # time, q1, q2, fx, fy, fz of the last sample
X_NOISE = X_READING + 6  # the next row of the noise block to use
X_SIZE = X_NOISE + 1

# Why a step or a sample failed: the Python simulator raises the matching exception.
OK, ARM_STRAIGHT, NOT_FINITE, SENSOR_RANGE, NO_NOISE = 0, 1, 2, 3, 4

_TWO_PI = 2.0 * math.pi
_ARM_DET_MIN = 1e-9


def simulator_constants(simulator) -> np.ndarray:
    """The flat constants of a device.sim.simulator.SimulatorBackend."""
    robot, arm, sensor = simulator.robot, simulator.arm, simulator.sensor
    fr, st = robot.friction, robot.stiffness
    lu, lf = arm.upper_arm_m, arm.forearm_m
    c = np.zeros(S_SIZE)
    c[[S_L2, S_L4]] = robot.l2_m, robot.l4_m
    c[S_A1:S_A4 + 1] = robot.alpha
    c[[S_FC1, S_FC2]] = fr.joint_coulomb_Nm
    c[[S_FV1, S_FV2]] = fr.joint_viscous_Nms
    c[S_INV_VS] = 1.0 / fr.joint_smoothing_rad_s
    c[[S_EE_C, S_EE_V, S_EE_VS]] = fr.ee_coulomb_N, fr.ee_viscous_Ns_m, fr.ee_smoothing_m_s
    c[[S_K11, S_K12, S_K22, S_Q10, S_Q20]] = (
        st.k11_Nm_rad, st.k12_Nm_rad, st.k22_Nm_rad, st.q1_rest_rad, st.q2_rest_rad)
    c[S_JOINT_FRICTION] = bool(any(fr.joint_coulomb_Nm) or any(fr.joint_viscous_Nms))
    c[S_EE_FRICTION] = bool(fr.ee_coulomb_N or fr.ee_viscous_Ns_m)
    c[S_STIFF] = bool(st.k11_Nm_rad or st.k12_Nm_rad or st.k22_Nm_rad)
    c[[S_LU, S_LF, S_SX, S_SY]] = lu, lf, arm.shoulder_x_m, arm.shoulder_y_m
    c[[S_A11, S_A22, S_K, S_SIGN]] = arm.a11, arm.a22, arm.coupling, float(arm.elbow_sign)
    c[[S_LULF2, S_INV_2LULF, S_LULF, S_INV_LF]] = (
        lu * lu + lf * lf, 1.0 / (2.0 * lu * lf), lu * lf, 1.0 / lf)
    c[[S_OFFSET, S_NOISE_XY, S_NOISE_Z, S_LOAD, S_RXY, S_RZ, S_LIMIT_XY, S_LIMIT_Z]] = (
        sensor.offset_rad, sensor.noise_xy_N, sensor.noise_z_N, sensor.normal_load_N,
        sensor.resolution_xy_N, sensor.resolution_z_N, sensor.limit_xy_N, sensor.limit_z_N)
    c[[S_CPR1, S_CPR2]] = (robot.motors[0].counts_per_joint_rev,
                           robot.motors[1].counts_per_joint_rev)
    c[[S_STEP, S_RATE]] = simulator.step_s, 1.0 / simulator.step_s
    c[[S_MAX1, S_MAX2]] = robot.max_joint_torque_Nm
    return c


def patient_arrays(patient) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(constants, desired-motion table, wrong-way episode offsets) of a
    device.sim.patients.VirtualPatient, from its `kernel_view()`."""
    view = patient.kernel_view()
    c = np.zeros(P_SIZE)
    c[P_ACTIVE] = view["active"]
    c[P_EFFORT] = view["effort"]
    c[[P_TS0, P_PHI0, P_LU, P_LF]] = view["ts0"], view["phi0"], view["lu"], view["lf"]
    c[P_PKS:P_PBE + 1] = view["passive"]
    c[P_KS:P_KE + 1] = view["stiffness"]
    c[P_BS:P_BE + 1] = view["damping"]
    c[[P_DURATION, P_TOTAL, P_DT_RATE]] = view["duration"], view["total"], view["dt_rate"]
    table = np.ascontiguousarray(view["table"], dtype=float).reshape(-1, 18)
    c[P_ROWS] = len(table)
    if view["tremor"] is not None:
        c[P_TREMOR] = 1.0
        c[P_OMEGA:P_AMP_E + 1] = view["tremor"]
    if view["spasticity"] is not None:
        c[P_SPASTIC] = 1.0
        c[P_TH_S:P_VB_E + 1] = view["spasticity"]
    episodes = np.array(view["episodes"], dtype=float)
    if view["wrong_force"] is not None:
        c[P_WRONG] = 1.0
        c[P_WRONG_N] = view["wrong_force"]
    c[[P_EP_LEN, P_EP_WINDOW, P_EPISODES]] = view["ep_len"], view["ep_window"], len(episodes)
    c[[P_REST_DX, P_REST_DY]] = view["rest_direction"]
    if len(table) == 0:
        table = np.zeros((1, 18))
    if len(episodes) == 0:
        episodes = np.zeros(1)
    return c, table, episodes


@kernel
def _resistance(rate, threshold, gain, viscous):
    out = viscous * rate
    if rate > threshold:
        out += gain * (rate - threshold)
    elif rate < -threshold:
        out += gain * (rate + threshold)
    return out


@kernel
def _pushing_wrong_way(p, episodes, t_s):
    if p[P_WRONG] == 0.0 or not 0.0 <= t_s < p[P_TOTAL]:
        return False
    k = int(t_s / p[P_EP_WINDOW])
    if k >= int(p[P_EPISODES]):
        return False
    into = t_s - k * p[P_EP_WINDOW] - episodes[k]
    return 0.0 <= into < p[P_EP_LEN]


@kernel
def patient_torque(p, table, episodes, t_s, ts, te, tsd, ted):
    """Net joint torques τ_A (eq. 3.20) of a virtual patient, absolute-angle convention
    (VirtualPatient.torque; the model is in device.sim.patients' module notes)."""
    phi = te - ts
    phid = ted - tsd
    e_s = p[P_TS0] - ts
    if e_s > math.pi:
        e_s -= _TWO_PI
    elif e_s < -math.pi:
        e_s += _TWO_PI
    e_e = p[P_PHI0] - phi
    sh = p[P_PKS] * e_s + p[P_PKC] * e_e - p[P_PBS] * tsd - p[P_PBC] * phid
    el = p[P_PKC] * e_s + p[P_PKE] * e_e - p[P_PBC] * tsd - p[P_PBE] * phid
    gen_s = 0.0
    gen_e = 0.0
    if p[P_ACTIVE] != 0.0:
        n = int(p[P_ROWS])
        i = -1
        f = 0.0
        if 0.0 <= t_s < p[P_TOTAL] and n:
            u = (t_s % p[P_DURATION]) * p[P_DT_RATE]
            i = int(u)
            if i < n:
                f = u - i
            else:
                i = n - 1
                f = 1.0
        if i >= 0:
            row = table[i]
            ts_d = row[0] + f * row[8]
            phi_d = row[1] + f * row[9]
            tsd_d = row[2] + f * row[10]
            phid_d = row[3] + f * row[11]
            ff_s = row[4] + f * row[12]
            ff_e = row[5] + f * row[13]
            drive_x = row[6] + f * row[14]
            drive_y = row[7] + f * row[15]
            dir_x = row[16]
            dir_y = row[17]
        else:  # at rest at the start posture, outside the exercise's time
            ts_d = p[P_TS0]
            phi_d = p[P_PHI0]
            tsd_d = phid_d = ff_s = ff_e = drive_x = drive_y = 0.0
            dir_x = p[P_REST_DX]
            dir_y = p[P_REST_DY]
        d_s = ts_d - ts
        if d_s > math.pi:
            d_s -= _TWO_PI
        elif d_s < -math.pi:
            d_s += _TWO_PI
        d_e = phi_d - phi
        v_s = tsd_d - tsd
        v_e = phid_d - phid
        w = p[P_EFFORT]
        sh += w * (p[P_KS] * d_s + p[P_KC] * d_e + p[P_BS] * v_s + p[P_BC] * v_e)
        el += w * (p[P_KC] * d_s + p[P_KE] * d_e + p[P_BC] * v_s + p[P_BE] * v_e)
        sin_s = math.sin(ts)
        cos_s = math.cos(ts)
        sin_e = math.sin(te)
        cos_e = math.cos(te)
        gen_s = w * (ff_s + p[P_LU] * (sin_s * drive_x - cos_s * drive_y))
        gen_e = w * (ff_e + p[P_LF] * (sin_e * drive_x - cos_e * drive_y))
        if p[P_WRONG] != 0.0 and _pushing_wrong_way(p, episodes, t_s):
            fx = -p[P_WRONG_N] * dir_x - w * drive_x
            fy = -p[P_WRONG_N] * dir_y - w * drive_y
            gen_s += p[P_LU] * (sin_s * fx - cos_s * fy)
            gen_e += p[P_LF] * (sin_e * fx - cos_e * fy)
    if p[P_TREMOR] != 0.0:
        wave = math.sin(p[P_OMEGA] * t_s + p[P_PHASE])
        sh += p[P_AMP_S] * wave
        el += p[P_AMP_E] * wave
    if p[P_SPASTIC] != 0.0:
        sh -= _resistance(tsd, p[P_TH_S], p[P_G_S], p[P_VB_S])
        el -= _resistance(phid, p[P_TH_E], p[P_G_E], p[P_VB_E])
    return (sh - el + gen_s, el + gen_e)


@kernel
def evaluate(c, p, table, episodes, t, q1, q2, qd1, qd2, tau1, tau2, out):
    """The fused coupled dynamics (device.sim.simulator's `dynamics="fused"`): writes
    θ̈_R1, θ̈_R2, F_x, F_y, θ_s, θ_e, θ̇_s, θ̇_e, θ̈_s, θ̈_e, τ_s, τ_e and the inverse
    coupled mass (n11, n12, n22) into out[0:15]; returns OK or ARM_STRAIGHT."""
    l2 = c[S_L2]
    l4 = c[S_L4]
    lu = c[S_LU]
    lf = c[S_LF]
    sign = c[S_SIGN]
    s1, c1, s2, c2 = math.sin(q1), math.cos(q1), math.sin(q2), math.cos(q2)
    vx = c[S_SX] - l2 * c2 - l4 * c1
    vy = c[S_SY] - l2 * s2 - l4 * s1
    d2 = vx * vx + vy * vy
    ce = (d2 - c[S_LULF2]) * c[S_INV_2LULF]
    if not -1.0 < ce < 1.0:
        return ARM_STRAIGHT
    se = sign * math.sqrt(1.0 - ce * ce)
    det_a = c[S_LULF] * se
    if not abs(det_a) > _ARM_DET_MIN:
        return ARM_STRAIGHT
    pp = lu + lf * ce
    qq = lf * se
    cts = (pp * vx + qq * vy) / d2
    sts = (pp * vy - qq * vx) / d2
    cte = (vx - lu * cts) * c[S_INV_LF]
    ste = (vy - lu * sts) * c[S_INV_LF]
    ts = math.atan2(sts, cts)
    te = ts + sign * math.acos(ce)
    j11, j12, j21, j22 = lu * sts, lf * ste, -lu * cts, -lf * cte
    i11, i12, i21, i22 = j22 / det_a, -j12 / det_a, -j21 / det_a, j11 / det_a
    r11, r12, r21, r22 = -l4 * s1, -l2 * s2, l4 * c1, l2 * c2
    g11 = i11 * r11 + i12 * r21
    g12 = i11 * r12 + i12 * r22
    g21 = i21 * r11 + i22 * r21
    g22 = i21 * r12 + i22 * r22
    tsd = g11 * qd1 + g12 * qd2
    ted = g21 * qd1 + g22 * qd2
    qq1, qq2, tt1, tt2 = qd1 * qd1, qd2 * qd2, tsd * tsd, ted * ted
    wx = -l4 * c1 * qq1 - l2 * c2 * qq2 - lu * cts * tt1 - lf * cte * tt2
    wy = -l4 * s1 * qq1 - l2 * s2 * qq2 - lu * sts * tt1 - lf * ste * tt2
    gs = i11 * wx + i12 * wy
    ge = i21 * wx + i22 * wy

    tau_s, tau_e = patient_torque(p, table, episodes, t, ts, te, tsd, ted)

    A11 = c[S_A11]
    A22 = c[S_A22]
    K = c[S_K]
    ma12 = K * ce
    gk = K * se
    ps = tau_s + gk * tt2 - A11 * gs - ma12 * ge
    pe = tau_e - gk * tt1 - ma12 * gs - A22 * ge

    cd = c1 * c2 + s1 * s2
    sd = s1 * c2 - c1 * s2
    mr12 = c[S_A2] * cd + c[S_A3] * sd
    gr = c[S_A2] * sd - c[S_A3] * cd
    h1 = gr * qq2
    h2 = -gr * qq1
    if c[S_STIFF] != 0.0:
        e1 = q1 - c[S_Q10]
        e2 = q2 - c[S_Q20]
        h1 += c[S_K11] * e1 + c[S_K12] * e2
        h2 += c[S_K12] * e1 + c[S_K22] * e2
    if c[S_JOINT_FRICTION] != 0.0:
        h1 += c[S_FC1] * math.tanh(qd1 * c[S_INV_VS]) + c[S_FV1] * qd1
        h2 += c[S_FC2] * math.tanh(qd2 * c[S_INV_VS]) + c[S_FV2] * qd2
    if c[S_EE_FRICTION] != 0.0:
        ex = r11 * qd1 + r12 * qd2
        ey = r21 * qd1 + r22 * qd2
        speed = math.sqrt(ex * ex + ey * ey)
        if speed > 1e-12:
            gain = c[S_EE_C] * (math.tanh(speed / c[S_EE_VS]) / speed) + c[S_EE_V]
        else:
            gain = c[S_EE_C] * (1.0 / c[S_EE_VS]) + c[S_EE_V]
        h1 += gain * (r11 * ex + r21 * ey)
        h2 += gain * (r12 * ex + r22 * ey)

    t11 = A11 * g11 + ma12 * g21
    t12 = A11 * g12 + ma12 * g22
    t21 = ma12 * g11 + A22 * g21
    t22 = ma12 * g12 + A22 * g22
    m11 = c[S_A1] + g11 * t11 + g21 * t21
    m12 = mr12 + g11 * t12 + g21 * t22
    m22 = c[S_A4] + g12 * t12 + g22 * t22
    b1 = tau1 - h1 + g11 * ps + g21 * pe
    b2 = tau2 - h2 + g12 * ps + g22 * pe
    det = m11 * m22 - m12 * m12
    qdd1 = (m22 * b1 - m12 * b2) / det
    qdd2 = (m11 * b2 - m12 * b1) / det
    tsdd = g11 * qdd1 + g12 * qdd2 + gs
    tedd = g21 * qdd1 + g22 * qdd2 + ge
    us = tau_s - A11 * tsdd - ma12 * tedd + gk * tt2
    ue = tau_e - ma12 * tsdd - A22 * tedd - gk * tt1
    out[0] = qdd1
    out[1] = qdd2
    out[2] = i11 * us + i21 * ue
    out[3] = i12 * us + i22 * ue
    out[4] = ts
    out[5] = te
    out[6] = tsd
    out[7] = ted
    out[8] = tsdd
    out[9] = tedd
    out[10] = tau_s
    out[11] = tau_e
    out[12] = m22 / det
    out[13] = -m12 / det
    out[14] = m11 / det
    return OK


@kernel
def sample(c, x, steps, q1, q2, noise):
    """The sensors' reading of the state into x[X_READING:]: time, quantised joint
    angles, noisy quantised force in the sensor frame. Returns OK or SENSOR_RANGE."""
    last = X_LAST
    fx = x[last + 2]
    fy = x[last + 3]
    rxy = c[S_RXY]
    rz = c[S_RZ]
    angle = q1 + c[S_OFFSET]
    co = math.cos(angle)
    si = math.sin(angle)
    fxs = math.floor((co * fx + si * fy + c[S_NOISE_XY] * noise[0]) / rxy + 0.5) * rxy
    fys = math.floor((co * fy - si * fx + c[S_NOISE_XY] * noise[1]) / rxy + 0.5) * rxy
    fzs = math.floor((c[S_LOAD] + c[S_NOISE_Z] * noise[2]) / rz + 0.5) * rz
    lxy = c[S_LIMIT_XY]
    lz = c[S_LIMIT_Z]
    if not (-lxy <= fxs <= lxy and -lxy <= fys <= lxy and -lz <= fzs <= lz):
        return SENSOR_RANGE
    cpr1 = c[S_CPR1]
    cpr2 = c[S_CPR2]
    r = X_READING
    x[r] = steps * c[S_STEP]
    x[r + 1] = round(q1 * cpr1 / _TWO_PI) * 2.0 * math.pi / cpr1
    x[r + 2] = round(q2 * cpr2 / _TWO_PI) * 2.0 * math.pi / cpr2
    x[r + 3] = fxs
    x[r + 4] = fys
    x[r + 5] = fzs
    return OK


@kernel
def reset(c, p, table, episodes, q1, q2, noise, x):
    """SimulatorBackend._reset for a patient who starts at once: at rest at (q1, q2) with
    zero torque, the first sample taken with noise[0] (`noise` holds the sensor's
    standard normal triples in order), clock anchored at 0."""
    x[:] = 0.0
    x[X_Q1] = q1
    x[X_Q2] = q2
    x[X_CACHED] = 1.0
    status = evaluate(c, p, table, episodes, -0.0, q1, q2, 0.0, 0.0, 0.0, 0.0,
                      x[X_LAST:X_LAST + 15])
    if status != OK:
        return status
    x[X_NOISE] = 1
    return sample(c, x, 0, q1, q2, noise[0])


@kernel
def write(c, x, tau1, tau2):
    """SimulatorBackend.write: the drives saturate at the motors' limit."""
    m1 = c[S_MAX1]
    m2 = c[S_MAX2]
    x[X_TAU1] = m1 if tau1 > m1 else -m1 if tau1 < -m1 else tau1
    x[X_TAU2] = m2 if tau2 > m2 else -m2 if tau2 < -m2 else tau2


@kernel
def advance(c, p, table, episodes, x, n, noise, scratch):
    """SimulatorBackend._advance with semi-implicit Euler: n steps with the torques held,
    then a full evaluation and a sample. `scratch` holds 15 floats. A failure leaves
    the state half-updated: the caller abandons the compiled run."""
    tau1 = x[X_TAU1]
    tau2 = x[X_TAU2]
    h = c[S_STEP]
    q1 = x[X_Q1]
    q2 = x[X_Q2]
    qd1 = x[X_QD1]
    qd2 = x[X_QD2]
    steps = int(x[X_STEPS])
    t0 = x[X_T0]
    t = steps * h - t0
    last = X_LAST
    for i in range(n):
        if i == 0 and x[X_CACHED] != 0.0:
            dt1 = tau1 - x[X_LAST_TAU1]
            dt2 = tau2 - x[X_LAST_TAU2]
            a1 = x[last] + x[last + 12] * dt1 + x[last + 13] * dt2
            a2 = x[last + 1] + x[last + 13] * dt1 + x[last + 14] * dt2
        else:
            status = evaluate(c, p, table, episodes, t, q1, q2, qd1, qd2, tau1, tau2, scratch)
            if status != OK:
                return status
            a1 = scratch[0]
            a2 = scratch[1]
        qd1 += h * a1
        qd2 += h * a2
        q1 += h * qd1
        q2 += h * qd2
        steps += 1
        t = steps * h - t0
        total = q1 + q2 + qd1 + qd2
        if total - total != 0.0:
            return NOT_FINITE
        if not (math.isfinite(a1) and math.isfinite(a2)):
            return NOT_FINITE
    status = evaluate(c, p, table, episodes, t, q1, q2, qd1, qd2, tau1, tau2, scratch)
    if status != OK:
        return status
    for j in range(15):
        if not math.isfinite(scratch[j]):
            return NOT_FINITE
    drawn = int(x[X_NOISE])
    if drawn >= noise.shape[0]:
        return NO_NOISE
    for j in range(15):
        x[last + j] = scratch[j]
    status = sample(c, x, steps, q1, q2, noise[drawn])
    x[X_NOISE] = drawn + 1
    if status != OK:
        return status
    x[X_Q1] = q1
    x[X_Q2] = q2
    x[X_QD1] = qd1
    x[X_QD2] = qd2
    x[X_STEPS] = steps
    x[X_LAST_TAU1] = tau1
    x[X_LAST_TAU2] = tau2
    x[X_CACHED] = 1.0
    return OK


@kernel
def read(c, p, table, episodes, x, now_s, noise, scratch):
    """SimulatorBackend.read on an anchored clock: advance in whole steps to `now_s`."""
    ahead = (now_s - x[X_ANCHOR]) * c[S_RATE] - x[X_STEPS] + 1e-7
    if ahead >= 1.0 and ahead != math.inf:
        return advance(c, p, table, episodes, x, int(ahead), noise, scratch)
    if not ahead < 1.0:
        return NOT_FINITE
    return OK
