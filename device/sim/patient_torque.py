"""A virtual patient's net joint torques τ_A as kernels (core.kernels): the model of
device.sim.patients' module notes, on the constants vector `VirtualPatient.constants`
(P_* below), its desired-motion table and its wrong-way episodes.

`VirtualPatient.torque` runs `patient_torque` interpreted; the simulator's physics
(device.sim.physics) call it, compiled, at every evaluation of the dynamics.
"""

from __future__ import annotations

import math

from core.kernels import kernel

_TWO_PI = 2.0 * math.pi
TABLE_STEP_S = 0.001
"""The desired-motion table's time step (device.sim.patients tabulates it)."""
RELAXED_BEFORE_S = -1.5e9
"""A patient's clock earlier than this: the patient rests after a trial (the simulator's
`rest_patient` puts its clock 2·10⁹ s before the exercise; one waiting for its first cue
is at −10⁹ s and holds the start posture). Resting, the active impedance keeps its damping
and drops its stiffness and pushes: the hand settles where the trial left it, and the
relaxed arm's tissue drifts it slowly back (under 0.2 m/s). Its clock used to run on: the
strength task's pushes went on against the idle robot and took the handle out of the
exercise area (a workspace fault with no trial running). Then it held the start posture
as before its cue: the set-point jumped there from wherever the trial stopped, and the
stiffness threw the handle back at up to 1.3 m/s with the robot at zero torque, over the
supervisor's speed limit (a plan's Pause or Stop latched EE_SPEED). The passive tissue
alone let a stopped hand coast on, 0.4 m/s and 25 cm in 10 s."""


# The constants vector of `patient_torque` (VirtualPatient.constants).
(P_ACTIVE, P_EFFORT, P_TS0, P_PHI0, P_LU, P_LF, P_PKS, P_PKC, P_PKE, P_PBS, P_PBC, P_PBE,
 P_KS, P_KC, P_KE, P_BS, P_BC, P_BE, P_DURATION, P_TOTAL, P_DT_RATE, P_ROWS, P_TREMOR,
 P_OMEGA, P_PHASE, P_AMP_S, P_AMP_E, P_SPASTIC, P_TH_S, P_TH_E, P_G_S, P_G_E, P_VB_S, P_VB_E,
 P_WRONG, P_WRONG_N, P_EP_LEN, P_EP_WINDOW, P_EPISODES, P_REST_DX, P_REST_DY, P_SELECTIVE,
 P_SEL_SS, P_SEL_SE, P_SEL_EE, P_IMP_SS, P_IMP_SE, P_IMP_EE, P_SIZE) = range(49)


def constants_vector(parameters, arm, trajectory, ts0: float, phi0: float, rows: int,
                     ep_len: float, ep_window: float, episodes: int,
                     rest_direction) -> tuple[float, ...]:
    """The constants vector of a patient (its PatientParameters, arm and trajectory, the
    start posture, the table's and the episodes' sizes)."""
    c = [0.0] * P_SIZE
    c[P_ACTIVE] = float(parameters.kind != "passive")
    c[P_EFFORT] = parameters.effort
    c[P_TS0], c[P_PHI0], c[P_LU], c[P_LF] = ts0, phi0, arm.upper_arm_m, arm.forearm_m
    c[P_PKS:P_PBE + 1] = parameters.passive.stiffness_Nm_rad + parameters.passive.damping_Nms_rad
    c[P_KS:P_KE + 1] = parameters.active.stiffness_Nm_rad
    c[P_BS:P_BE + 1] = parameters.active.damping_Nms_rad
    c[P_DURATION] = trajectory.duration_s
    c[P_TOTAL] = trajectory.total_duration_s
    c[P_DT_RATE] = 1.0 / TABLE_STEP_S
    c[P_ROWS] = rows
    if parameters.tremor is not None:
        tr = parameters.tremor
        c[P_TREMOR] = 1.0
        c[P_OMEGA:P_AMP_E + 1] = (_TWO_PI * tr.frequency_hz, tr.phase_rad, *tr.amplitude_Nm)
    if parameters.spasticity is not None:
        sp = parameters.spasticity
        c[P_SPASTIC] = 1.0
        c[P_TH_S:P_VB_E + 1] = (*sp.threshold_rad_s, *sp.reflex_gain_Nms_rad,
                                *sp.viscous_Nms_rad)
    if parameters.wrong_way is not None:
        c[P_WRONG] = 1.0
        c[P_WRONG_N] = parameters.wrong_way.force_N
    c[P_EP_LEN], c[P_EP_WINDOW], c[P_EPISODES] = ep_len, ep_window, episodes
    c[P_REST_DX], c[P_REST_DY] = rest_direction
    c[P_SELECTIVE] = float(parameters.selectivity_loss != 0.0)
    loss, direction = parameters.selectivity_loss, parameters.synergy_direction_rad
    c[P_SEL_SS:P_SEL_EE + 1] = selectivity_filter(loss, direction)
    # the impedance's answer across the synergy loses the same share: Q K Q with Q's own
    # loss 1 − √(1 − loss), so the stiffness and the damping across scale by 1 − loss
    c[P_IMP_SS:P_IMP_EE + 1] = selectivity_filter(1.0 - math.sqrt(1.0 - loss), direction)
    return tuple(float(v) for v in c)


def selectivity_filter(loss: float, direction_rad: float) -> tuple[float, float, float]:
    """The matrix P = I − loss · n nᵀ as (P_ss, P_se, P_ee), n = (−sin α, cos α) the unit
    vector across the synergy's direction s = (cos α, sin α) in joint-coordinate torques
    (τ_sh, τ_el), α = `direction_rad`: P keeps a command's part along s and scales the
    part across it by 1 − loss (device.sim.patients' module notes, selectivity)."""
    n_s, n_e = -math.sin(direction_rad), math.cos(direction_rad)
    return (1.0 - loss * n_s * n_s, -loss * n_s * n_e, 1.0 - loss * n_e * n_e)


@kernel
def table_position(p, t_s):
    """Where `t_s` falls in the desired-motion table: (row, fraction of a step past it);
    row −1 outside the exercise's time (the patient rests at the start posture)."""
    n = int(p[P_ROWS])
    if 0.0 <= t_s < p[P_TOTAL] and n:
        u = (t_s % p[P_DURATION]) * p[P_DT_RATE]
        i = int(u)
        if i < n:
            return i, u - i
        return n - 1, 1.0
    return -1, 0.0


@kernel
def desired_motion(p, table, t_s):
    """(θ_s, φ, θ̇_s, φ̇, τ_ff,s, τ_ff,e, direction x, y, drive x, y) at `t_s`, linearly
    interpolated in the table (at rest at the start posture outside the exercise)."""
    i, f = table_position(p, t_s)
    if i < 0:
        return (p[P_TS0], p[P_PHI0], 0.0, 0.0, 0.0, 0.0, p[P_REST_DX], p[P_REST_DY], 0.0,
                0.0)
    row = table[i]
    return (row[0] + f * row[8], row[1] + f * row[9], row[2] + f * row[10],
            row[3] + f * row[11], row[4] + f * row[12], row[5] + f * row[13], row[16],
            row[17], row[6] + f * row[14], row[7] + f * row[15])


@kernel
def pushing_wrong_way(p, episodes, t_s):
    """True during a wrong-way episode."""
    if p[P_WRONG] == 0.0 or not 0.0 <= t_s < p[P_TOTAL]:
        return False
    k = int(t_s / p[P_EP_WINDOW])
    if k >= int(p[P_EPISODES]):
        return False
    into = t_s - k * p[P_EP_WINDOW] - episodes[k]
    return 0.0 <= into < p[P_EP_LEN]


@kernel
def passive_tissue(ks, kc, ke, bs, bc, be, e_s, e_e, tsd, phid):
    """The passive tissue's torques (τ_sh, τ_el) in joint coordinates for the joints'
    distance (e_s, e_e) to the rest posture and their rates. Floats or arrays."""
    sh = ks * e_s + kc * e_e - bs * tsd - bc * phid
    el = kc * e_s + ke * e_e - bc * tsd - be * phid
    return (sh, el)


@kernel
def spastic_resistance(rate, threshold, gain, viscous):
    """b ω + g (|ω| − ω_th)₊ sign ω: opposes the stretch, grows with its speed."""
    out = viscous * rate
    if rate > threshold:
        out += gain * (rate - threshold)
    elif rate < -threshold:
        out += gain * (rate + threshold)
    return out


@kernel
def out_of_synergy_scaled(p, k, a_s, a_e):
    """A joint-coordinate pair (shoulder, elbow) through the selectivity filter whose
    (P_ss, P_se, P_ee) start at p[k] (P_SEL_SS or P_IMP_SS): its part along the synergy
    kept, its part across scaled down."""
    return (p[k] * a_s + p[k + 1] * a_e, p[k + 1] * a_s + p[k + 2] * a_e)


@kernel
def _resting_damping(p, sh, el, tsd, phid):
    """(sh, el) with a resting patient's active damping added: the impedance's damping
    toward no motion and no stiffness, so the hand stops where the trial left it and
    the next trial's approach moves it freely (RELAXED_BEFORE_S)."""
    v_s = -tsd
    v_e = -phid
    if p[P_SELECTIVE] != 0.0:
        v_s, v_e = out_of_synergy_scaled(p, P_IMP_SS, v_s, v_e)
    w = p[P_EFFORT]
    u_sh = w * (p[P_BS] * v_s + p[P_BC] * v_e)
    u_el = w * (p[P_BC] * v_s + p[P_BE] * v_e)
    if p[P_SELECTIVE] != 0.0:
        u_sh, u_el = out_of_synergy_scaled(p, P_IMP_SS, u_sh, u_el)
    return (sh + u_sh, el + u_el)


@kernel
def patient_torque(p, table, episodes, t_s, ts, te, tsd, ted):
    """Net joint torques τ_A (eq. 3.20) of a virtual patient, absolute-angle convention
    (VirtualPatient.torque; the model is in the module notes)."""
    phi = te - ts
    phid = ted - tsd
    e_s = p[P_TS0] - ts
    # the shoulder's distance to its rest posture the short way round
    if e_s > math.pi:
        e_s -= _TWO_PI
    elif e_s < -math.pi:
        e_s += _TWO_PI
    sh, el = passive_tissue(p[P_PKS], p[P_PKC], p[P_PKE], p[P_PBS], p[P_PBC], p[P_PBE],
                            e_s, p[P_PHI0] - phi, tsd, phid)
    gen_s = 0.0
    gen_e = 0.0
    if p[P_ACTIVE] != 0.0 and t_s < RELAXED_BEFORE_S:
        sh, el = _resting_damping(p, sh, el, tsd, phid)
    elif p[P_ACTIVE] != 0.0:
        ts_d, phi_d, tsd_d, phid_d, ff_s, ff_e, dir_x, dir_y, drive_x, drive_y = (
            desired_motion(p, table, t_s))
        d_s = ts_d - ts
        if d_s > math.pi:
            d_s -= _TWO_PI
        elif d_s < -math.pi:
            d_s += _TWO_PI
        d_e = phi_d - phi
        v_s = tsd_d - tsd
        v_e = phid_d - phid
        w = p[P_EFFORT]
        if p[P_SELECTIVE] != 0.0:
            # the impedance Q K Q, Q B Q: the error's part across the synergy is answered
            # less, on both sides, so the stiffness stays symmetric (it creates no energy)
            d_s, d_e = out_of_synergy_scaled(p, P_IMP_SS, d_s, d_e)
            v_s, v_e = out_of_synergy_scaled(p, P_IMP_SS, v_s, v_e)
        u_sh = w * (p[P_KS] * d_s + p[P_KC] * d_e + p[P_BS] * v_s + p[P_BC] * v_e)
        u_el = w * (p[P_KC] * d_s + p[P_KE] * d_e + p[P_BC] * v_s + p[P_BE] * v_e)
        sin_s = math.sin(ts)
        cos_s = math.cos(ts)
        sin_e = math.sin(te)
        cos_e = math.cos(te)
        gen_s = w * (ff_s + p[P_LU] * (sin_s * drive_x - cos_s * drive_y))
        gen_e = w * (ff_e + p[P_LF] * (sin_e * drive_x - cos_e * drive_y))
        if pushing_wrong_way(p, episodes, t_s):
            fx = -p[P_WRONG_N] * dir_x - w * drive_x
            fy = -p[P_WRONG_N] * dir_y - w * drive_y
            gen_s += p[P_LU] * (sin_s * fx - cos_s * fy)
            gen_e += p[P_LF] * (sin_e * fx - cos_e * fy)
        if p[P_SELECTIVE] != 0.0:
            # the impedance's answer through Q (the other side of Q K Q); the feed-forward
            # and the pushes in joint coordinates (τ_sh = τ_A,s + τ_A,e, τ_el = τ_A,e)
            # through P (device.sim.patients' module notes, selectivity)
            u_sh, u_el = out_of_synergy_scaled(p, P_IMP_SS, u_sh, u_el)
            f_sh, f_el = out_of_synergy_scaled(p, P_SEL_SS, gen_s + gen_e, gen_e)
            u_sh += f_sh
            u_el += f_el
            gen_s = 0.0
            gen_e = 0.0
        sh += u_sh
        el += u_el
    if p[P_TREMOR] != 0.0:
        wave = math.sin(p[P_OMEGA] * t_s + p[P_PHASE])
        sh += p[P_AMP_S] * wave
        el += p[P_AMP_E] * wave
    if p[P_SPASTIC] != 0.0:
        sh -= spastic_resistance(tsd, p[P_TH_S], p[P_G_S], p[P_VB_S])
        el -= spastic_resistance(phid, p[P_TH_E], p[P_G_E], p[P_VB_E])
    return (sh - el + gen_s, el + gen_e)
