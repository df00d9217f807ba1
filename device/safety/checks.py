"""The supervisor's per-tick work as kernels: one function per check, `supervise` that
runs them in order, latches the first fault and clamps the torque.

These are the only copy of the checks: `SafetySupervisor.step` runs them interpreted,
the loop's tick engine compiled (core.kernels). Each check returns
(code, d0, d1, d2, d3): 0 when it passes, else the fault code and up to four numbers
the supervisor turns into the fault's detail (device.safety.supervisor.fault_detail).
Which check wins when several fail in one tick, and why each limit has its value, is
in docs/safety.md; the order below is that table's.

`g` is the constants vector (G_*; SafetySupervisor builds it from its SafetyLimits and
robot), `w` the state vector (W_*) carried from tick to tick, `r` the robot's
constants (core.robot_terms).
"""

from __future__ import annotations

import math

from core.kernels import kernel
from core.robot_terms import WITHIN_LIMITS, jacobian_of, limit_violation, position_of, trig
from device.safety.faults import Fault

(G_PERIOD, G_HALF_PERIOD, G_FULL1, G_FULL2, G_SATURATION_S, G_RAMP_S, G_JOINT_SPEED,
 G_EE_SPEED, G_FORCE, G_PLANAR_SAT, G_NORMAL_SAT, G_JUMP, G_STALE, G_LATE_TICK, G_LATE_RUN,
 G_HEARTBEAT, G_REACH_MIN, G_REACH_MAX, G_REGION, G_X_MIN, G_X_MAX, G_Y_MIN, G_Y_MAX,
 G_SIZE) = range(24)

# The state: the previous sample, the stale and late counts, when the saturation and the
# ramp began, the latched fault and when, the last tick's condition with its numbers, and
# whether the last good reading put the handle outside the exercise area.
(W_PREV_VALID, W_PREV_T, W_PREV_Q1, W_PREV_Q2, W_PREV_X, W_PREV_Y, W_STALE_RUN,
 W_SAT_SINCE, W_RAMP_SINCE, W_LATE_RUN, W_FAULT, W_FAULT_TIME, W_CONDITION, W_D0, W_D1,
 W_D2, W_D3, W_SAT_SIGN1, W_SAT_SIGN2, W_OUTSIDE, W_SIZE) = range(21)

# Detail numbers that name one of several things.
LATE_ONE, LATE_RUN = 0.0, 1.0
FROM_RATE_ESTIMATE, FROM_ENCODER_DIFFERENCE = 0.0, 1.0
FINITE_FIELDS = ("now_s", "time_s", "q1_rad", "q2_rad", "force_x_N", "force_y_N",
                 "force_z_N", "rate1_rad_s", "rate2_rad_s", "torque1_Nm", "torque2_Nm")
"""What the NOT_FINITE check's first number indexes."""

_NONE = int(Fault.NONE)
_ESTOP = int(Fault.ESTOP)
_NOT_FINITE = int(Fault.NOT_FINITE)
_LATE_TICK = int(Fault.LATE_TICK)
_SENSOR_STALE = int(Fault.SENSOR_STALE)
_ENCODER_JUMP = int(Fault.ENCODER_JUMP)
_SENSOR_RANGE = int(Fault.SENSOR_RANGE)
_FORCE_LIMIT = int(Fault.FORCE_LIMIT)
_WORKSPACE = int(Fault.WORKSPACE)
_JOINT_SPEED = int(Fault.JOINT_SPEED)
_EE_SPEED = int(Fault.EE_SPEED)
_HEARTBEAT_LOST = int(Fault.HEARTBEAT_LOST)
_RECORDING_LOST = int(Fault.RECORDING_LOST)
_TORQUE_SATURATED = int(Fault.TORQUE_SATURATED)


@kernel
def length(x, y):
    """√(x² + y²). Not math.hypot: CPython's is its own, more careful algorithm and numba
    calls the C library's, which can differ in the last bit, and the supervisor's numbers
    must be the same compiled and interpreted."""
    return math.sqrt(x * x + y * y)


# ---------------------------------------------------------------- the sample history
@kernel
def count_late(g, w, lateness_s):
    """Ticks in a row that started more than one period late."""
    if lateness_s > g[G_PERIOD]:
        w[W_LATE_RUN] += 1.0
    else:
        w[W_LATE_RUN] = 0.0


@kernel
def follow_sample(r, g, w, t, q1, q2, rt):
    """Update the previous sample and the stale count with this one (kept up to date
    whatever the outcome, so the checks are sound again on the tick after a clear).
    Returns (jump joint 0/1/2, its change, the jump limit, the sample gap, the two
    joints' and the handle's speeds by difference, the handle's x, y). `rt` is the
    sample's trig (core.robot_terms.trig)."""
    x, y = position_of(r, rt)
    jump_joint = 0
    jump_change = jump_limit = sample_dt = 0.0
    diff_rate1 = diff_rate2 = diff_speed = 0.0
    if w[W_PREV_VALID] == 0.0:
        _set_previous(w, t, q1, q2, x, y)
        w[W_STALE_RUN] = 0.0
        return (jump_joint, jump_change, jump_limit, sample_dt, diff_rate1, diff_rate2,
                diff_speed, x, y)
    sample_dt = t - w[W_PREV_T]
    if sample_dt <= 0.0:
        w[W_STALE_RUN] += 1.0
        return (jump_joint, jump_change, jump_limit, sample_dt, diff_rate1, diff_rate2,
                diff_speed, x, y)
    w[W_STALE_RUN] = 0.0
    dq1 = q1 - w[W_PREV_Q1]
    dq2 = q2 - w[W_PREV_Q2]
    # a longer gap allows a proportionally larger change: a stall is a late tick, not a jump
    jump_limit = g[G_JUMP] * max(1.0, sample_dt / g[G_LATE_TICK])
    if abs(dq1) > jump_limit:
        jump_joint, jump_change = 1, dq1
    elif abs(dq2) > jump_limit:
        jump_joint, jump_change = 2, dq2
    # Samples closer than half a period would turn one encoder count into a large rate:
    # difference over a longer span instead.
    if sample_dt >= g[G_HALF_PERIOD] or jump_joint != 0:
        diff_rate1 = dq1 / sample_dt
        diff_rate2 = dq2 / sample_dt
        diff_speed = length(x - w[W_PREV_X], y - w[W_PREV_Y]) / sample_dt
        _set_previous(w, t, q1, q2, x, y)
    return (jump_joint, jump_change, jump_limit, sample_dt, diff_rate1, diff_rate2,
            diff_speed, x, y)


@kernel
def _set_previous(w, t, q1, q2, x, y):
    w[W_PREV_VALID] = 1.0
    w[W_PREV_T] = t
    w[W_PREV_Q1] = q1
    w[W_PREV_Q2] = q2
    w[W_PREV_X] = x
    w[W_PREV_Y] = y


@kernel
def time_saturation(g, w, now_s, torque1, torque2):
    """When the command began to push one way at the clamp (NaN while it does not).

    At the limit counts: the SMC and the CT-PID clip their own output to exactly the
    drive's limit, so a timer started only above it never ran for them. One way: a joint
    at the clamp whose torque changes sign starts the time again. The hazard (H2) is a
    sustained push against a resisting or blocked arm; a tracker chattering from one
    clamp to the other while it catches a fast reference up (the centre-out targets'
    reaches) pushes no arm anywhere for a second, and counting it faulted every weak
    patient's targets trial. Timed only while the torque is applied: a latched fault
    resets it, so a controller winding up against zero torque does not count."""
    at1 = abs(torque1) >= g[G_FULL1]
    at2 = abs(torque2) >= g[G_FULL2]
    if not (at1 or at2):
        w[W_SAT_SINCE] = math.nan
        w[W_SAT_SIGN1] = 0.0
        w[W_SAT_SIGN2] = 0.0
        return
    sign1 = math.copysign(1.0, torque1) if at1 else 0.0
    sign2 = math.copysign(1.0, torque2) if at2 else 0.0
    turned = sign1 * w[W_SAT_SIGN1] < 0.0 or sign2 * w[W_SAT_SIGN2] < 0.0
    if math.isnan(w[W_SAT_SINCE]) or turned:
        w[W_SAT_SINCE] = now_s
        w[W_SAT_SIGN1] = sign1
        w[W_SAT_SIGN2] = sign2
        return
    # a joint that reaches the clamp later joins the push with its own way
    if at1:
        w[W_SAT_SIGN1] = sign1
    if at2:
        w[W_SAT_SIGN2] = sign2


# ---------------------------------------------------------------------- the checks
@kernel
def check_finite(now_s, t, q1, q2, fx, fy, fz, rate1, rate2, torque1, torque2):
    """NOT_FINITE: the first of the tick's numbers (FINITE_FIELDS order) that is NaN or
    infinite, with its value."""
    values = (now_s, t, q1, q2, fx, fy, fz, rate1, rate2, torque1, torque2)
    for i in range(11):
        if not math.isfinite(values[i]):
            return (_NOT_FINITE, float(i), values[i], 0.0, 0.0)
    return (_NONE, 0.0, 0.0, 0.0, 0.0)


@kernel
def check_late(g, w, lateness_s):
    """LATE_TICK: one tick more than late_tick_s late, or late_run_ticks in a row each
    more than a period late (on the robot's clock: device.backend)."""
    if not lateness_s <= g[G_LATE_TICK]:
        return (_LATE_TICK, LATE_ONE, lateness_s, w[W_LATE_RUN], 0.0)
    if w[W_LATE_RUN] >= g[G_LATE_RUN]:
        return (_LATE_TICK, LATE_RUN, lateness_s, w[W_LATE_RUN], 0.0)
    return (_NONE, 0.0, 0.0, 0.0, 0.0)


@kernel
def check_stale(g, w, t):
    """SENSOR_STALE: stale_samples in a row whose time stamp did not advance."""
    if w[W_STALE_RUN] >= g[G_STALE]:
        return (_SENSOR_STALE, w[W_STALE_RUN], t, 0.0, 0.0)
    return (_NONE, 0.0, 0.0, 0.0, 0.0)


@kernel
def check_jump(jump_joint, jump_change, jump_limit, sample_dt):
    """ENCODER_JUMP: a joint-angle change between two samples no motion could make."""
    if jump_joint != 0:
        return (_ENCODER_JUMP, float(jump_joint), abs(jump_change), jump_limit, sample_dt)
    return (_NONE, 0.0, 0.0, 0.0, 0.0)


@kernel
def check_sensor_range(g, fx, fy, fz):
    """SENSOR_RANGE: an axis of the force sensor near the end of its span (x', y', z')."""
    if abs(fx) > g[G_PLANAR_SAT]:
        return (_SENSOR_RANGE, 0.0, fx, 0.0, 0.0)
    if abs(fy) > g[G_PLANAR_SAT]:
        return (_SENSOR_RANGE, 1.0, fy, 0.0, 0.0)
    if abs(fz) > g[G_NORMAL_SAT]:
        return (_SENSOR_RANGE, 2.0, fz, 0.0, 0.0)
    return (_NONE, 0.0, 0.0, 0.0, 0.0)


@kernel
def check_force(g, fx, fy):
    """FORCE_LIMIT: the planar force on the handle over the limit. Its magnitude is the
    same in the sensor's frame and the global one, so no rotation is needed."""
    force = length(fx, fy)
    if force > g[G_FORCE]:
        return (_FORCE_LIMIT, force, fx, fy, 0.0)
    return (_NONE, 0.0, 0.0, 0.0, 0.0)


@kernel
def outside_area(g, x, y):
    """The handle outside the exercise area: outside the reach band (the reach ring less
    the margin, so the handle stops before the links fold flat) or the exercise's
    region."""
    radius = length(x, y)
    return (not g[G_REACH_MIN] <= radius <= g[G_REACH_MAX]
            or (g[G_REGION] != 0.0
                and not (g[G_X_MIN] <= x <= g[G_X_MAX] and g[G_Y_MIN] <= y <= g[G_Y_MAX])))


@kernel
def check_workspace(r, w, driving, q1, q2, x, y):
    """WORKSPACE: a joint limit or the links' spread, always; outside the exercise area
    (w[W_OUTSIDE], this tick's) only while the robot drives the handle (a trial runs).

    The hazard is the handle DRIVEN out (docs/safety.md, H8). With no trial the loop
    writes zero torque to a backdrivable robot, which cannot drive the handle anywhere:
    a handle a person has put outside the area (the homing pose at Connect is outside
    most exercises' areas) is a state the window shows and Start refuses, not a fault.
    A joint beyond its limit or the links near folding flat are not where hands put the
    handle (the reach band's margin lies inside the spread limits): they mean the
    position itself is suspect (a Connect away from the homing pose) or the linkage may
    snap to its other branch, so they latch whether or not a trial runs."""
    if limit_violation(r, q1, q2) != WITHIN_LIMITS or (driving and w[W_OUTSIDE] != 0.0):
        return (_WORKSPACE, q1, q2, x, y)
    return (_NONE, 0.0, 0.0, 0.0, 0.0)


@kernel
def check_joint_speed(g, rate1, rate2, diff_rate1, diff_rate2):
    """JOINT_SPEED: a joint faster than the limit, by the rate estimate or by encoder
    difference (joint, speed, source)."""
    limit = g[G_JOINT_SPEED]
    if abs(rate1) > limit:
        return (_JOINT_SPEED, 1.0, abs(rate1), FROM_RATE_ESTIMATE, 0.0)
    if abs(rate2) > limit:
        return (_JOINT_SPEED, 2.0, abs(rate2), FROM_RATE_ESTIMATE, 0.0)
    if abs(diff_rate1) > limit:
        return (_JOINT_SPEED, 1.0, abs(diff_rate1), FROM_ENCODER_DIFFERENCE, 0.0)
    if abs(diff_rate2) > limit:
        return (_JOINT_SPEED, 2.0, abs(diff_rate2), FROM_ENCODER_DIFFERENCE, 0.0)
    return (_NONE, 0.0, 0.0, 0.0, 0.0)


@kernel
def check_ee_speed(r, g, rt, rate1, rate2, diff_speed):
    """EE_SPEED: the handle faster than the limit, J_R θ̇ by the rate estimate, or by
    difference of its positions (speed, source)."""
    j11, j12, j21, j22 = jacobian_of(r, rt)
    speed = length(j11 * rate1 + j12 * rate2, j21 * rate1 + j22 * rate2)
    if speed > g[G_EE_SPEED]:
        return (_EE_SPEED, speed, FROM_RATE_ESTIMATE, 0.0, 0.0)
    if diff_speed > g[G_EE_SPEED]:
        return (_EE_SPEED, diff_speed, FROM_ENCODER_DIFFERENCE, 0.0, 0.0)
    return (_NONE, 0.0, 0.0, 0.0, 0.0)


@kernel
def check_heartbeat(g, heartbeat_age_s):
    """HEARTBEAT_LOST: the console's window has not said it is alive for too long."""
    if not heartbeat_age_s <= g[G_HEARTBEAT]:
        return (_HEARTBEAT_LOST, heartbeat_age_s, 0.0, 0.0, 0.0)
    return (_NONE, 0.0, 0.0, 0.0, 0.0)


@kernel
def check_saturation(g, w, now_s, torque1, torque2):
    """TORQUE_SATURATED: the command over the clamp without a break for too long."""
    if now_s - w[W_SAT_SINCE] >= g[G_SATURATION_S]:
        return (_TORQUE_SATURATED, now_s - w[W_SAT_SINCE], torque1, torque2, 0.0)
    return (_NONE, 0.0, 0.0, 0.0, 0.0)


@kernel
def first_failure(r, g, w, now_s, t, q1, q2, fx, fy, fz, rate1, rate2, torque1, torque2,
                  lateness_s, heartbeat_age_s, estop, recording_lost, read_error, driving):
    """Update the history and run the checks in order, most informative cause first:
    (code, d0, d1, d2, d3) of the first that fails, code 0 when all pass. `read_error`
    is the fault code of a sensor read that raised, as a float (0.0 when it did not): numba
    compiles a separate copy of a kernel for each literal int it is passed, and the
    kernels that call this pass none. `driving`: a trial runs, so the torque written is
    the controller's (check_workspace). w[W_OUTSIDE] follows every good reading, whatever
    fails; a reading without a position leaves it as it was (its own fault holds Start)."""
    count_late(g, w, lateness_s)
    nothing = (_NONE, 0.0, 0.0, 0.0, 0.0)
    if read_error == 0.0:
        finite = check_finite(now_s, t, q1, q2, fx, fy, fz, rate1, rate2, torque1, torque2)
    else:
        finite = nothing
    jump_joint = 0
    jump_change = jump_limit = sample_dt = 0.0
    diff_rate1 = diff_rate2 = diff_speed = x = y = 0.0
    rt = (0.0, 1.0, 0.0, 1.0, 0.0, 1.0)  # trig(0, 0): a reading that failed has no angles
    if read_error == 0.0 and finite[0] == _NONE:
        rt = trig(q1, q2)
        (jump_joint, jump_change, jump_limit, sample_dt, diff_rate1, diff_rate2, diff_speed,
         x, y) = follow_sample(r, g, w, t, q1, q2, rt)
        w[W_OUTSIDE] = 1.0 if outside_area(g, x, y) else 0.0
    else:
        w[W_PREV_VALID] = 0.0
        w[W_STALE_RUN] = 0.0
    time_saturation(g, w, now_s, torque1, torque2)
    if estop:
        return (_ESTOP, 0.0, 0.0, 0.0, 0.0)
    if read_error != 0.0:
        return (int(read_error), 0.0, 0.0, 0.0, 0.0)
    if finite[0] != _NONE:
        return finite
    found = check_late(g, w, lateness_s)
    if found[0] == _NONE:
        found = check_stale(g, w, t)
    if found[0] == _NONE:
        found = check_jump(jump_joint, jump_change, jump_limit, sample_dt)
    if found[0] == _NONE:
        found = check_sensor_range(g, fx, fy, fz)
    if found[0] == _NONE:
        found = check_force(g, fx, fy)
    if found[0] == _NONE:
        found = check_workspace(r, w, driving, q1, q2, x, y)
    if found[0] == _NONE:
        found = check_joint_speed(g, rate1, rate2, diff_rate1, diff_rate2)
    if found[0] == _NONE:
        found = check_ee_speed(r, g, rt, rate1, rate2, diff_speed)
    if found[0] == _NONE:
        found = check_heartbeat(g, heartbeat_age_s)
    if found[0] == _NONE and recording_lost:
        found = (_RECORDING_LOST, 0.0, 0.0, 0.0, 0.0)
    if found[0] == _NONE:
        found = check_saturation(g, w, now_s, torque1, torque2)
    return found


# ------------------------------------------------------------------- the outcome
@kernel
def clamp(g, w, now_s, torque1, torque2):
    """The torques to write with no fault latched: the limit ramps up from zero after a
    start or a clear, and one factor scales both joints, which keeps the direction of
    the force on the hand."""
    limit1 = g[G_FULL1]
    limit2 = g[G_FULL2]
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
    return (_within(torque1 * scale, limit1), _within(torque2 * scale, limit2))


@kernel
def _within(value, limit):
    """max(-limit, min(limit, value)), with Python's choice among equal values."""
    low = value if value < limit else limit
    return low if low > -limit else -limit


@kernel
def supervise(r, g, w, now_s, t, q1, q2, fx, fy, fz, rate1, rate2, torque1, torque2,
              lateness_s, heartbeat_age_s, estop, recording_lost, read_error, driving):
    """One tick: (torque1, torque2, fault) to write. The first failing check's code and
    numbers become the tick's condition (w[W_CONDITION], w[W_D0:]); the first condition
    while none is latched becomes the latched fault (w[W_FAULT], with its time), and
    from then on the output is exactly zero until `clear`. `driving` is True while a
    trial runs (the controller's torque goes through), False while the loop writes zero
    torque between trials: leaving the exercise area is then a state (w[W_OUTSIDE]), not
    a fault (check_workspace)."""
    code, d0, d1, d2, d3 = first_failure(
        r, g, w, now_s, t, q1, q2, fx, fy, fz, rate1, rate2, torque1, torque2, lateness_s,
        heartbeat_age_s, estop, recording_lost, read_error, driving)
    w[W_CONDITION] = code
    if code != _NONE:
        w[W_D0] = d0
        w[W_D1] = d1
        w[W_D2] = d2
        w[W_D3] = d3
        if w[W_FAULT] == _NONE:
            w[W_FAULT] = code
            w[W_FAULT_TIME] = now_s
    if w[W_FAULT] != _NONE:
        w[W_SAT_SINCE] = math.nan
        return (0.0, 0.0, int(w[W_FAULT]))
    out1, out2 = clamp(g, w, now_s, torque1, torque2)
    return (out1, out2, _NONE)
