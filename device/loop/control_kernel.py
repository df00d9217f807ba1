"""The kernel of one tick up to the commanded torque (`control`), in the order of the
thesis's scheme (Fig. 3.6): rate estimate → reference → controller → performance-based
assistance, on flat vectors (`Vectors`) and precomputed reference rows.

A kernel (core.kernels): interpreted on Python tuples and lists, or compiled on float arrays
(device.compiled), the same code either way. device.loop.pipeline.TickPipeline holds a
trial's vectors and calls it; device.loop.engine runs it over blocks of ticks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.control.assistance import (
    A_LEVEL,
    assisted_torques,
    cone_test,
    judged_force,
)
from core.control.ctpid import (
    I_SIZE,
    ComputedTorquePID,
    ctpid_acceleration,
    ctpid_limit,
    ctpid_torques,
)
from core.control.guidance import (
    GC_DELAY_ROWS,
    GC_ON,
    guidance_command,
    guidance_rows,
)
from core.control.hold import HC_ON, held_at, taken_over
from core.control.smc import SlidingModeController, smc_torques
from core.control.transparent import TC_ON, transparent_torques
from core.interaction import (
    rotated_to_global,
)
from core.kernels import kernel
from core.learning.kernel import learned_torques
from core.robot_terms import R_SIZE
from core.signal import track
from device.loop.plan import PHASE_APPROACH, PHASE_EXERCISE, PHASE_HOLD


@dataclass(slots=True)
class Vectors:
    """What the `control` kernel works on: the robot's constants, the arm's (for the
    subject's state in the record), the controller's model's (core.robot_terms), the rate
    tracker's, the controller's gains, the assistance's constants, the guidance's
    (core.control.guidance GC_*, all zero in the thesis mode); the trackers' state (angle,
    rate, acceleration of each joint, Z_*), the controller's integral (core.control.ctpid
    I_*), the guidance's state (GS_*), the last tick's values (C_*), and the reference
    rows loaded (TickPipeline.load_rows: all of them in the live loop, a block's worth in a
    headless run)."""

    robot: object
    arm: object
    model: object
    tracker: object
    gains: object
    assist: object
    guide: object
    rates: object
    integral: object
    guided: object
    last: object
    rows: object


# The trackers' state in `rates`.
Z_ANGLE1, Z_RATE1, Z_ACC1, Z_ANGLE2, Z_RATE2, Z_ACC2, Z_SIZE = range(7)
# What `control` leaves in `last`, the record's view of the tick (TickPipeline.last_tick);
# C_LEVEL is the assistance level the tick ran with (the record's `assistance_level`).
(C_PHASE, C_QD1, C_QD2, C_QDD1, C_QDD2, C_R1, C_R2, C_RD1, C_RD2, C_RDD1, C_RDD2, C_TAU1,
 C_TAU2, C_OUT1, C_OUT2, C_XD, C_YD, C_VXD, C_VYD, C_DX, C_DY, C_FX, C_FY, C_ANGLE, C_ACTIVE,
 C_LEVEL, C_SIZE) = range(27)
# Which law `controller_torques` runs.
SMC, CTPID, GENERIC, LEARNED = 0, 1, 2, 3


def _controller_kind(controller, compiled: bool) -> int:
    on_a_robot_model = len(getattr(controller.model, "constants", ())) == R_SIZE
    if type(controller) is SlidingModeController and on_a_robot_model:
        return SMC
    if type(controller) is ComputedTorquePID and on_a_robot_model:
        return CTPID
    if (compiled and type(controller) is ComputedTorquePID
            and has_compiled_form(controller.model)):
        # interpreted, the numpy tick (its own step) is the faster of the two
        return LEARNED
    return GENERIC


def has_compiled_form(model) -> bool:
    """Whether `model` (a controller's) is a learned model the kernels compute
    (core.learning.kernel: an FNN or a DeLaN of the robot)."""
    return getattr(model, "kernel_weights", None) is not None


def _python(values):
    return list(values)


def _arrays(values):
    return np.asarray(values, dtype=float).copy()


def _replacements(controller, kind: int) -> dict:
    """What the interpreted `control` replaces for a controller the kernels do not know:
    its own `step` in place of `controller_torques`."""
    if kind != GENERIC:
        return {}
    step = controller.step

    def own_law(kind, model, gains, integral, dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2,
                rdd1, rdd2):
        return step(dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2)

    return {"controller_torques": own_law}


@kernel
def controller_torques(kind, model, gains, integral, dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2,
                       rdd1, rdd2):
    """The trial's controller: the sliding-mode law or the computed-torque PID
    (core.control), on its model's constants."""
    if kind == SMC:
        return smc_torques(model, gains, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2)
    if kind == LEARNED:
        # eq. 4.8 with the learned model's inverse dynamics (core.learning.kernel)
        a1, a2 = ctpid_acceleration(gains, integral, dt_s, q1, q2, qd1, qd2, r1, r2, rd1,
                                    rd2, rdd1, rdd2)
        tau1, tau2 = learned_torques(model, q1, q2, qd1, qd2, a1, a2)
        return ctpid_limit(gains, integral, tau1, tau2)
    return ctpid_torques(model, gains, integral, dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2,
                         rdd1, rdd2)


@kernel
def rows_needed(guide, guided, approach_ticks, tick, n_rows):
    """The lowest and highest reference row `control` reads at `tick`, from the state
    before it: the tick's own row (the last one in the hold) and, while the as-needed
    mode guides, the rows the guidance may search or lead to
    (core.control.guidance.guidance_rows)."""
    own = tick if tick < n_rows else n_rows - 1
    lo = own
    hi = own
    if guide[GC_ON] != 0.0 and approach_ticks <= tick < n_rows + guide[GC_DELAY_ROWS]:
        low, high = guidance_rows(guide, guided, approach_ticks, n_rows - 1, tick)
        lo = low if low < lo else lo
        hi = high if high > hi else hi
    return lo, hi


@kernel
def control(kind, robot, model, tracker, gains, assist, guide, rates, integral, guided, tick,
            rows, rows_from, n_rows, approach_ticks, period_s, sensor_offset_rad, q1, q2,
            force_x, force_y, last):
    """One tick up to the commanded torque, in the order of Fig. 3.6: rate estimate →
    reference → controller → performance-based assistance. Writes `last` (C_*); the
    command is last[C_OUT1], last[C_OUT2]. `rows` holds rows rows_from… of the trial's
    n_rows reference rows (approach then exercise), at least those `rows_needed` names."""
    for joint in range(2):
        # the tracker's offset a loop variable, not a literal: numba would compile `track`
        # once for each literal offset
        track(tracker, rates, (Z_ANGLE2 - Z_ANGLE1) * joint, q1 if joint == 0 else q2)
    qd1 = rates[Z_RATE1]
    qdd1 = rates[Z_ACC1]
    qd2 = rates[Z_RATE2]
    qdd2 = rates[Z_ACC2]
    n = n_rows
    if tick < n:
        row = rows[tick - rows_from]
        phase = PHASE_APPROACH if tick < approach_ticks else PHASE_EXERCISE
        xd, yd, vxd, vyd, dx, dy = row[0], row[1], row[2], row[3], row[4], row[5]
        r1, r2, rd1, rd2, rdd1, rdd2 = row[6], row[7], row[8], row[9], row[10], row[11]
    else:
        # the hold: at rest at the last reference point
        row = rows[n - 1 - rows_from]
        phase = PHASE_HOLD
        xd, yd, vxd, vyd, dx, dy = row[0], row[1], 0.0, 0.0, row[4], row[5]
        r1, r2, rd1, rd2, rdd1, rdd2 = row[6], row[7], 0.0, 0.0, 0.0, 0.0
    fx, fy = rotated_to_global(force_x, force_y, q1, sensor_offset_rad)
    # the force the assistance judges: the sensor's, or an estimate from EMG (chapter 5)
    px, py = judged_force(assist, tick, fx, fy)
    held = False
    first = False
    if guide[HC_ON] != 0.0 and phase == PHASE_EXERCISE:
        held, first = held_at(guide, tick - approach_ticks)
        if first:
            # what the hold's integral held in its last stretch is no push of this one
            for i in range(I_SIZE):
                integral[i] = 0.0
    if held:
        # from where the patient left the hand (core.control.hold.taken_over; the
        # record's desired joint angles are the ones the controller tracked)
        r1, r2, rd1, rd2, rdd1, rdd2 = taken_over(integral, first, tick - approach_ticks,
                                                  period_s, q1, q2, r1, r2, rd1, rd2, rdd1,
                                                  rdd2)
        # A task the robot leads (core.control.hold): the trial's controller holds the
        # hand on the task's reference with nothing taken off its torque; the cone test
        # says whether the push points the way asked.
        tau1, tau2 = controller_torques(kind, model, gains, integral, period_s, q1, q2, qd1,
                                        qd2, r1, r2, rd1, rd2, rdd1, rdd2)
        out1, out2 = tau1, tau2
        active, angle = cone_test(assist, px, py, dx, dy)
    elif guide[TC_ON] != 0.0 and phase != PHASE_APPROACH:
        # Transparent (core.control.transparent), the exercise and the hold after it: the
        # robot's own inertia, friction and stiffness as far as its model allows, no
        # guidance, and no pull to the path's end once the clock has run out; the cone test
        # only says whether the push pointed along the path (the directional performance),
        # and only in the exercise.
        tau1, tau2 = transparent_torques(robot, guide, q1, q2, qd1, qd2, qdd1, qdd2)
        out1, out2 = tau1, tau2
        active, angle = cone_test(assist, px, py, dx, dy)
        active = active and phase == PHASE_EXERCISE
    elif guide[GC_ON] != 0.0 and approach_ticks <= tick < n + guide[GC_DELAY_ROWS]:
        # As needed (core.control.guidance): the reference is where the patient is, or
        # the clock's row less the delay, whichever is further on.
        phase = PHASE_EXERCISE
        sigma, here, tau1, tau2, out1, out2, active, angle = guidance_command(
            robot, guide, assist, guided, rows, rows_from, n, approach_ticks, tick, q1, q2, qd1,
            qd2, px, py)
        row = rows[sigma - rows_from]
        xd, yd, vxd, vyd = row[0], row[1], row[2], row[3]
        r1, r2, rd1, rd2, rdd1, rdd2 = row[6], row[7], row[8], row[9], row[10], row[11]
        # the desired direction where the hand is, the one its cone test used
        dx, dy = rows[here - rows_from][4], rows[here - rows_from][5]
    else:
        tau1, tau2 = controller_torques(kind, model, gains, integral, period_s, q1, q2, qd1,
                                        qd2, r1, r2, rd1, rd2, rdd1, rdd2)
        out1, out2, active, angle = assisted_torques(robot, assist, q1, q2, tau1, tau2, px,
                                                     py, dx, dy)
        if phase != PHASE_EXERCISE:
            # The subject's effort counts only on the exercise, not on the way to it.
            out1, out2, active = tau1, tau2, False
    last[C_PHASE] = phase
    last[C_QD1] = qd1
    last[C_QD2] = qd2
    last[C_QDD1] = qdd1
    last[C_QDD2] = qdd2
    last[C_R1] = r1
    last[C_R2] = r2
    last[C_RD1] = rd1
    last[C_RD2] = rd2
    last[C_RDD1] = rdd1
    last[C_RDD2] = rdd2
    last[C_TAU1] = tau1
    last[C_TAU2] = tau2
    last[C_OUT1] = out1
    last[C_OUT2] = out2
    last[C_XD] = xd
    last[C_YD] = yd
    last[C_VXD] = vxd
    last[C_VYD] = vyd
    last[C_DX] = dx
    last[C_DY] = dy
    last[C_FX] = fx
    last[C_FY] = fy
    last[C_ANGLE] = angle
    last[C_ACTIVE] = 1.0 if active else 0.0
    last[C_LEVEL] = assist[A_LEVEL]
