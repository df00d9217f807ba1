"""The safety supervisor's per-tick work, compiled.

`check` is device.safety.supervisor.SafetySupervisor.step for a tick with a sensor reading:
it keeps the same sample history, saturation timer, late-tick count and restart
ramp, and clamps the torque the same way. It does not build fault events: when
any check would trip it returns TRIPPED, and the caller hands the tick to the
Python supervisor (restoring the state from before it), which latches the fault
and writes it with its cause and values. The checks are the same, in the same order, as
SafetySupervisor.step (docs/safety.md).
"""

from __future__ import annotations

import math

import numpy as np

from device.compiled.jit import kernel
from device.safety.supervisor import SENSOR_SATURATION_FRACTION

(G_PERIOD, G_HALF_PERIOD, G_FULL1, G_FULL2, G_SATURATION_S, G_RAMP_S, G_JOINT_SPEED,
 G_EE_SPEED, G_FORCE, G_PLANAR_SAT, G_NORMAL_SAT, G_JUMP, G_STALE, G_LATE_TICK, G_REACH_MIN,
 G_REACH_MAX, G_REGION, G_X_MIN, G_X_MAX, G_Y_MIN, G_Y_MAX, G_SPREAD_MIN, G_SPREAD_MAX,
 G_Q1_MIN, G_Q1_MAX, G_Q2_MIN, G_Q2_MAX, G_BRANCH, G_L2, G_L4, G_LATE_RUN, G_HEARTBEAT,
 G_SIZE) = range(33)

# the supervisor's history (SafetySupervisor.kernel_state)
(W_PREV_VALID, W_PREV_T, W_PREV_Q1, W_PREV_Q2, W_PREV_X, W_PREV_Y, W_STALE_RUN,
 W_SAT_SINCE, W_RAMP_SINCE, W_LATE_RUN, W_SIZE) = range(11)

CLEAR, TRIPPED = 0, 1


def supervisor_constants(supervisor) -> np.ndarray:
    """The flat constants of a device.safety.supervisor.SafetySupervisor."""
    lim = supervisor.limits
    robot = supervisor.robot
    g = np.zeros(G_SIZE)
    full1, full2 = supervisor.torque_limits_Nm
    reach_min, reach_max = supervisor.reach_band_m
    g[[G_PERIOD, G_HALF_PERIOD, G_FULL1, G_FULL2]] = (
        lim.period_s, 0.5 * lim.period_s, full1, full2)
    g[[G_SATURATION_S, G_RAMP_S, G_JOINT_SPEED, G_EE_SPEED, G_FORCE]] = (
        lim.saturation_time_s, lim.restart_ramp_s, lim.joint_speed_limit_rad_s,
        lim.ee_speed_limit_m_s, lim.force_limit_N)
    g[G_PLANAR_SAT] = SENSOR_SATURATION_FRACTION * lim.sensor_planar_range_N
    g[G_NORMAL_SAT] = SENSOR_SATURATION_FRACTION * lim.sensor_normal_range_N
    g[[G_JUMP, G_STALE, G_LATE_TICK]] = lim.encoder_jump_rad, lim.stale_samples, lim.late_tick_s
    g[[G_REACH_MIN, G_REACH_MAX]] = reach_min, reach_max
    if lim.region_m is not None:
        g[G_REGION] = 1.0
        g[G_X_MIN:G_Y_MAX + 1] = lim.region_m
    jl = robot.limits
    g[[G_SPREAD_MIN, G_SPREAD_MAX, G_Q1_MIN, G_Q1_MAX, G_Q2_MIN, G_Q2_MAX]] = (
        jl.spread_min_rad, jl.spread_max_rad, jl.q1_min_rad, jl.q1_max_rad, jl.q2_min_rad,
        jl.q2_max_rad)
    g[[G_BRANCH, G_L2, G_L4]] = robot.branch, robot.l2_m, robot.l4_m
    g[[G_LATE_RUN, G_HEARTBEAT]] = lim.late_run_ticks, lim.heartbeat_timeout_s
    return g


def initial_state() -> np.ndarray:
    """A new supervisor's history: no previous sample, no saturation, ramp not started."""
    w = np.zeros(W_SIZE)
    w[W_SAT_SINCE] = math.nan
    w[W_RAMP_SINCE] = math.nan
    return w


@kernel
def check(g, w, now_s, t, q1, q2, fx, fy, fz, rate1, rate2, torque1, torque2, lateness_s,
          heartbeat_age_s, estop, recording_lost):
    """One tick of SafetySupervisor.step with a sensor reading: (torque1, torque2, CLEAR)
    to write, or (0, 0, TRIPPED) when a check trips (the history is then updated as far
    as SafetySupervisor.step would have, but the caller replays the tick in Python)."""
    if lateness_s > g[G_PERIOD]:
        w[W_LATE_RUN] += 1.0
    else:
        w[W_LATE_RUN] = 0.0
    if estop:
        return 0.0, 0.0, TRIPPED
    if not (math.isfinite(now_s) and math.isfinite(t) and math.isfinite(q1)
            and math.isfinite(q2) and math.isfinite(fx) and math.isfinite(fy)
            and math.isfinite(fz) and math.isfinite(rate1) and math.isfinite(rate2)
            and math.isfinite(torque1) and math.isfinite(torque2)):
        return 0.0, 0.0, TRIPPED
    l2 = g[G_L2]
    l4 = g[G_L4]
    x = l2 * math.cos(q2) + l4 * math.cos(q1)
    y = l2 * math.sin(q2) + l4 * math.sin(q1)
    jumped = False
    diff_rate1 = 0.0
    diff_rate2 = 0.0
    diff_speed = 0.0
    if w[W_PREV_VALID] == 0.0:
        _set_prev(w, t, q1, q2, x, y)
        w[W_STALE_RUN] = 0.0
    else:
        sample_dt = t - w[W_PREV_T]
        if sample_dt <= 0.0:
            w[W_STALE_RUN] += 1.0
        else:
            w[W_STALE_RUN] = 0.0
            dq1 = q1 - w[W_PREV_Q1]
            dq2 = q2 - w[W_PREV_Q2]
            jump_limit = g[G_JUMP] * max(1.0, sample_dt / g[G_LATE_TICK])
            jumped = abs(dq1) > jump_limit or abs(dq2) > jump_limit
            if sample_dt >= g[G_HALF_PERIOD] or jumped:
                diff_rate1 = dq1 / sample_dt
                diff_rate2 = dq2 / sample_dt
                diff_speed = math.hypot(x - w[W_PREV_X], y - w[W_PREV_Y]) / sample_dt
                _set_prev(w, t, q1, q2, x, y)
    full1 = g[G_FULL1]
    full2 = g[G_FULL2]
    if abs(torque1) > full1 or abs(torque2) > full2:
        if math.isnan(w[W_SAT_SINCE]):
            w[W_SAT_SINCE] = now_s
    else:
        w[W_SAT_SINCE] = math.nan

    if not lateness_s <= g[G_LATE_TICK] or w[W_LATE_RUN] >= g[G_LATE_RUN]:
        return 0.0, 0.0, TRIPPED
    if w[W_STALE_RUN] >= g[G_STALE] or jumped:
        return 0.0, 0.0, TRIPPED
    if abs(fx) > g[G_PLANAR_SAT] or abs(fy) > g[G_PLANAR_SAT] or abs(fz) > g[G_NORMAL_SAT]:
        return 0.0, 0.0, TRIPPED
    if math.hypot(fx, fy) > g[G_FORCE]:
        return 0.0, 0.0, TRIPPED
    spread = (q1 - q2) * g[G_BRANCH]
    if (spread < g[G_SPREAD_MIN] or spread > g[G_SPREAD_MAX]
            or not g[G_Q1_MIN] <= q1 <= g[G_Q1_MAX] or not g[G_Q2_MIN] <= q2 <= g[G_Q2_MAX]):
        return 0.0, 0.0, TRIPPED
    radius = math.hypot(x, y)
    if not g[G_REACH_MIN] <= radius <= g[G_REACH_MAX]:
        return 0.0, 0.0, TRIPPED
    if g[G_REGION] != 0.0 and not (g[G_X_MIN] <= x <= g[G_X_MAX]
                                   and g[G_Y_MIN] <= y <= g[G_Y_MAX]):
        return 0.0, 0.0, TRIPPED
    speed_limit = g[G_JOINT_SPEED]
    if (abs(rate1) > speed_limit or abs(rate2) > speed_limit
            or abs(diff_rate1) > speed_limit or abs(diff_rate2) > speed_limit):
        return 0.0, 0.0, TRIPPED
    j11 = -l4 * math.sin(q1)
    j12 = -l2 * math.sin(q2)
    j21 = l4 * math.cos(q1)
    j22 = l2 * math.cos(q2)
    ee_speed = math.hypot(j11 * rate1 + j12 * rate2, j21 * rate1 + j22 * rate2)
    if ee_speed > g[G_EE_SPEED] or diff_speed > g[G_EE_SPEED]:
        return 0.0, 0.0, TRIPPED
    if not heartbeat_age_s <= g[G_HEARTBEAT] or recording_lost:
        return 0.0, 0.0, TRIPPED
    if now_s - w[W_SAT_SINCE] >= g[G_SATURATION_S]:
        return 0.0, 0.0, TRIPPED

    limit1 = full1
    limit2 = full2
    if g[G_RAMP_S] > 0.0:
        if math.isnan(w[W_RAMP_SINCE]):
            w[W_RAMP_SINCE] = now_s
        share = (now_s - w[W_RAMP_SINCE]) / g[G_RAMP_S]
        if share < 1.0:
            share = max(share, 0.0)
            limit1 *= share
            limit2 *= share
    scale = 1.0
    size1 = abs(torque1)
    size2 = abs(torque2)
    if size1 > limit1:
        scale = limit1 / size1
    if size2 * scale > limit2:
        scale = limit2 / size2
    return _clip(torque1 * scale, limit1), _clip(torque2 * scale, limit2), CLEAR


@kernel
def _clip(value, limit):
    """max(-limit, min(limit, value)) with Python's choice among equals."""
    low = value if value < limit else limit
    return low if low > -limit else -limit


@kernel
def _set_prev(w, t, q1, q2, x, y):
    w[W_PREV_VALID] = 1.0
    w[W_PREV_T] = t
    w[W_PREV_Q1] = q1
    w[W_PREV_Q2] = q2
    w[W_PREV_X] = x
    w[W_PREV_Y] = y
