"""The robot holding the hand still, or moving it on the clock, in the assessment tasks the
robot leads (isometric strength, position sense; core.holdtasks): the law, what the drives
can hold, and when the robot holds and when it lets go.

The law
-------
The hold is the computed-torque PID of eq. 4.8 (core.control.ctpid) on the task's
reference: a point held still (strength, the pauses of position sense) or a minimum-jerk
move between two points (position sense's passive moves). Its gains are the trial's own
`ctpid` gains with the integral's clamp raised (`HOLD_GAINS`, written in the trial's gains
line, so the trial file says which gains held the hand): with the default clamp of
5 rad/s² (0.57 and 0.85 N·m through M) the integral could take only a third of a steady
push at the drives' limit and the rest would be held by K_p e, a few millimetres of give;
at `HOLD_INTEGRAL_LIMIT_RAD_S2` it can take a push up to the drives' limit (2.3 and
3.4 N·m through M, above 2.21 N·m), so a steady push leaves no static error: the hold is
isometric. The poles stay those of the tuned defaults (three at 20 rad/s), which the
tracking tests hold stable with the arm on the handle; the conditional integration keeps
the integral from winding up when a drive saturates. Nothing reduces the hold's torque
(no assistance, no level): the robot holds, the patient pushes.

What the drives can hold
------------------------
A hand force F on the handle needs the joint torques τ = J_Rᵀ F to be held still
(eq. 3.33, the statics of eq. 3.6). With each drive limited to |τ_i| ≤ τ_max (2.21 N·m,
device.safety.limits), the largest push the robot can hold along a unit direction u at a
posture is

    F_max(u) = τ_max / max_i |(J_Rᵀ u)_i|                                   (hold capacity)

At the thesis's centre (−0.30, 0.30) m that is 5.9 to 8.3 N over the eight directions:
the thesis robot's drives are small, and a healthy adult pushes tens of newtons. So the
strength task shows the patient a line at `LINE_FRACTION` of the capacity in each
direction and asks them to push as hard as they can up to it; a push that reaches the
line is at the robot's limit, and its peak is a lower bound of the patient's strength
(the task counts such directions). The line leaves the hold 30 % of the drives for its
own dynamics, so a push at the line never saturates them (the supervisor's
TORQUE_SATURATED after 1 s would end the trial); a push beyond what the drives can hold
moves the handle, and the supervisor's limits (force, speed, workspace, saturation) act on
it as in every trial.

When it holds
-------------
A task's exercise alternates stretches the robot leads (held: the hold law tracks the
reference) with stretches the patient moves freely (the transparent mode's law,
core.control.transparent). The task trial's mode is `transparent`, and the pipeline's
exercise vector carries the held stretches as windows of exercise ticks (`HC_*`, after the
transparent mode's `TC_*`); `held_at` says whether an exercise tick is in one, and whether
it is the first tick of one, where the hold's integral starts again from zero (what it
held in the last stretch is no push of this one) and the robot takes the hand over from
wherever the patient left it: the reference starts at the hand and glides to the task's
by minimum jerk over TAKEOVER_S (`taken_over`). On the realistic plant a weak patient's
hand came home from a match a few millimetres off the centre and the hold jumped at it
with a drive at its 2.21 N·m limit for 24 ms; with the take-over the largest torque there
is under 0.9 N·m (tests/device/test_hold_loop.py).
"""

from __future__ import annotations

import math

from core.control.ctpid import I_SIZE
from core.control.transparent import TC_SIZE
from core.kernels import kernel

HOLD_INTEGRAL_LIMIT_RAD_S2 = 20.0
"""The hold's clamp on K_i ∫e (module notes): through M (0.114 and 0.168 kg·m²) 2.3 and
3.4 N·m, above the drives' 2.21 N·m, so the integral alone can hold any push the drives can."""
HOLD_GAINS = f"ctpid.integral_limit_rad_s2={HOLD_INTEGRAL_LIMIT_RAD_S2:g}"
"""The hold's changes to the computed-torque PID's defaults, as a trial's gains line."""
LINE_FRACTION = 0.7
"""The strength task's line: this share of what the drives can hold in the push's
direction (module notes)."""

# The hold's part of the pipeline's exercise vector, after the transparent mode's: on, the
# number of held windows, then each window's first and last-plus-one exercise tick.
HC_ON, HC_COUNT, HC_WINDOWS = TC_SIZE, TC_SIZE + 1, TC_SIZE + 2
OFF = (0.0, 0.0)
"""The hold's part of a trial the robot does not lead."""
TAKEOVER_S = 0.5
"""How long the robot takes to bring its reference from where the patient left the hand to
the task's point when it takes the hand over (`taken_over`)."""
# The take-over's state, after the controller's integral (core.control.ctpid I_*) in the
# pipeline's integral vector: the hand's offset from the reference at the take-over (rad,
# per joint) and the exercise tick it happened.
HS_DQ1, HS_DQ2, HS_FROM, HS_SIZE = range(I_SIZE, I_SIZE + 4)


def hold_constants(windows_ticks) -> list[float]:
    """The hold's part of the exercise vector for held windows [(first, stop), ...] in
    exercise ticks, in order and apart."""
    out = [1.0, float(len(windows_ticks))]
    for first, stop in windows_ticks:
        out += [float(first), float(stop)]
    return out


@kernel
def held_at(guide, exercise_tick):
    """(held, first): whether the robot leads at this exercise tick (a held window of the
    exercise vector `guide`), and whether the tick is a held window's first."""
    n = int(guide[HC_COUNT])
    for w in range(n):
        first = guide[HC_WINDOWS + 2 * w]
        stop = guide[HC_WINDOWS + 2 * w + 1]
        if first <= exercise_tick < stop:
            return True, exercise_tick == first
    return False, False


@kernel
def taken_over(z, first, tick, period_s, q1, q2, r1, r2, rd1, rd2, rdd1, rdd2):
    """The joint reference (r, ṙ, r̈) of a held tick, eased in at a take-over: at a held
    window's first tick the hand is wherever the patient left it (a match's way home ends
    a few millimetres off the centre), and the reference starts there, its offset from the
    task's fading to nothing by minimum jerk over TAKEOVER_S, so the robot does not jump at
    the hand with its drives' full torque. The offset and its tick are kept in `z`
    (HS_*)."""
    if first:
        z[HS_DQ1] = q1 - r1
        z[HS_DQ2] = q2 - r2
        z[HS_FROM] = tick
    u = (tick - z[HS_FROM]) * period_s / TAKEOVER_S
    if not 0.0 <= u < 1.0:
        return r1, r2, rd1, rd2, rdd1, rdd2
    share = 1.0 - u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)
    rate = -30.0 * u * u * (1.0 - u) * (1.0 - u) / TAKEOVER_S
    accel = -60.0 * u * (1.0 - 3.0 * u + 2.0 * u * u) / (TAKEOVER_S * TAKEOVER_S)
    d1 = z[HS_DQ1]
    d2 = z[HS_DQ2]
    return (r1 + d1 * share, r2 + d2 * share, rd1 + d1 * rate, rd2 + d2 * rate,
            rdd1 + d1 * accel, rdd2 + d2 * accel)


def hold_capacity_N(robot, q1: float, q2: float, angle_rad: float) -> float:
    """The largest hand force along the direction `angle_rad` (global frame) the drives of
    `robot` (core.robot.RobotModel) can hold at the joint angles (q1, q2), N: the module
    notes' hold capacity with each joint's own limit."""
    lim1, lim2 = robot.max_joint_torque_Nm
    j11, j12, j21, j22 = robot.jacobian_terms(q1, q2)
    ux, uy = math.cos(angle_rad), math.sin(angle_rad)
    # τ = J_Rᵀ u per newton along u
    t1 = abs(j11 * ux + j21 * uy)
    t2 = abs(j12 * ux + j22 * uy)
    return min(lim1 / t1 if t1 > 0.0 else math.inf, lim2 / t2 if t2 > 0.0 else math.inf)
