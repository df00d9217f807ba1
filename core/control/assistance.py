"""Performance-based assistance: the robot gives way to a subject who pushes the right way
(section 3.5, Fig. 3.6, eq. 3.26 and 3.34).

The scheme, each tick
---------------------
1. F is the hand's force on the handle in the global frame (the sensor's
   reading rotated by eq. 3.35–3.36) and d the desired direction of motion
   (the path's unit tangent, `Trajectory.at(...)[6:8]`).
2. If |F| < `min_force_N` the force's direction is sensor noise: the scheme
   is *not active* and the angle is NaN.
3. The angle between F and d is atan2(|F × d|, F · d) in [0, π]. If it is
   within `tolerance_rad` (the thesis's 20°, chosen with the therapist), the
   subject is doing the right thing and the scheme is *active*.
4. When active, the robot's torque is reduced by the subject's contribution
   at the joints, τ_subject = J_Rᵀ F (eq. 3.34; it appears on the right of
   eq. 3.26 beside τ_R), scaled by `level`:

       τ_out,i = τ_i − level · (J_Rᵀ F)_i

   but only *reduced*: per joint, only when level·(J_Rᵀ F)_i has the same sign
   as τ_i, and never by more than |τ_i| (the torque goes to zero, never
   flips). A joint whose torque would grow is left as it is.

Why only reduce: the thesis found on the robot that adjusting the torque at
every instant, or increasing it, stacks on the controller's own aggressive
correction when the handle is off the path and gives excessive torques and
discomfort; only reduction was adopted. So |τ_out,i| ≤ |τ_i| always, with the
same sign or zero, and outside the cone τ_out = τ exactly.

`level` ∈ [0, 1] grades the reduction: 1 is the thesis's full J_Rᵀ F, 0 turns
it off while still reporting whether the subject is inside the cone (the
directional-performance metric of section 3.6.1, "78 % within 20°", is the
share of ticks with `active` true). A therapist fades assistance across
sessions by changing it, at run time through `set_level`.

What it does in closed loop, and why so little
----------------------------------------------
Next to nothing. On the thesis D with the sliding-mode controller (5 × 4 s, seed 0,
`rehab run --assist thesis`), level 1 changes the robot's RMS torque by 0.2 % for the
healthy virtual patient on the ideal plant and 1.0 % on the realistic one, and by under
0.02 % for the weak patient. The reason is the sign rule: the stiff tracker on a fixed
clock has already cancelled the subject's push before the scheme sees it, so inside the
cone the controller's torque has the opposite sign to J_Rᵀ F on 67–99 % of the joint-ticks
(healthy, weak, tremor and wrong-way patients, both plants), and a cut there would raise
|τ|, which the reduce-only rule forbids. (Measured with the records' torque_controller
and J_Rᵀ force over the in-cone exercise ticks; docs/validation.md, Assistance.) It is
not, as this note once said, the feedback restoring a cut: there is hardly a cut to
restore. Worse, the fixed clock brakes a subject who moves ahead of it: the robot does
−1.6 J of work on the healthy virtual patient's +2.2 J.

The scheme is kept as the `thesis` assistance mode, Fig. 3.6 as printed. The `as-needed`
mode (core.control.guidance) does what the thesis meant: its reference moves with the
patient, so their effort replaces the robot's. This module's `cone_test` is shared by
both.

Default minimum force
---------------------
`DEFAULT_MIN_FORCE_N` = 0.25 N, six counts of the sensor's 1/24 N resolution
per axis. A reading's quantisation error is at most √2/48 N ≈ 0.03 N, which at
0.25 N moves the direction by at most asin(0.03/0.25) ≈ 7°, a third of the
default tolerance; below it the cone test would be decided by quantisation.
It is well under the forces of the thesis's healthy subject (ranges of 0.8 N
in x and 2.5 N in y, Fig. 3.9).

Where it sits in the tick: controller → `apply` → safety supervisor → motors.
Plain floats in and out; no allocation beyond the returned tuple.
"""

from __future__ import annotations

import math

from core.errors import ParameterError, check_range
from core.kernels import kernel
from core.robot_terms import R_SIZE, joint_torque_terms
from core.trial import TOLERANCE_RANGE_RAD

FORCE_RESOLUTION_N = 1.0 / 24.0
"""One count of the thesis's ATI Nano25 in Fx and Fy (N)."""

DEFAULT_TOLERANCE_RAD = math.radians(20.0)
DEFAULT_MIN_FORCE_N = 6.0 * FORCE_RESOLUTION_N
MIN_FORCE_RANGE_N = (FORCE_RESOLUTION_N, 20.0)

# A direction shorter than this (a resting target) has no heading to compare with.
_MIN_DIRECTION_SQ = 1.0e-12


def check_tolerance(tolerance_rad: float) -> float:
    lo, hi = TOLERANCE_RANGE_RAD
    return check_range(
        "tolerance_rad", tolerance_rad, lo, hi, "rad",
        f"{math.degrees(lo):.0f}–{math.degrees(hi):.0f}°; beyond 90° a push against the path "
        "would count as help",
    )


def check_level(level: float) -> float:
    return check_range(
        "assistance_level", level, 0.0, 1.0, "",
        "0 = no reduction for the subject's effort, 1 = the thesis's full reduction J_Rᵀ F",
    )


def check_min_force(min_force_N: float) -> float:
    lo, hi = MIN_FORCE_RANGE_N
    return check_range(
        "min_force_N", min_force_N, lo, hi, "N",
        "at least one sensor count (1/24 N), below which the force has no direction; "
        "at most 20 N, above which a weak subject could never be credited",
    )


# The constants vector of `assisted_torques` (PerformanceAssistance.constants): the cone,
# the level, and the estimate of the patient's force that stands in for the sensor's
# (`judged_force`), with the tick it was made for and how old it may grow.
(A_TOLERANCE, A_LEVEL, A_MIN_FORCE_SQ, A_ESTIMATED, A_EST_FX, A_EST_FY, A_EST_TICK,
 A_EST_MAX_AGE, A_SIZE) = range(9)

ESTIMATE_MAX_AGE_S = 0.25
"""How old an estimate of the patient's force may be before the scheme stops judging by
it (s): four hops of the thesis's RMS envelope (0.0625 s). An EMG stream that stops, or
a console that stalls, leaves the robot giving full help, never judging a stale push."""


class PerformanceAssistance:
    """The scheme of Fig. 3.6 on a robot model; see the module docstring.

    The scheme is the kernel `assisted_torques` (compiled in the loop,
    core.kernels); this class validates its parameters and holds them. `level` and
    `tolerance_rad` may be changed between ticks (`set_level`, `set_tolerance`).
    """

    __slots__ = ("_robot", "constants")

    def __init__(
        self,
        robot,
        *,
        tolerance_rad: float = DEFAULT_TOLERANCE_RAD,
        level: float = 1.0,
        min_force_N: float = DEFAULT_MIN_FORCE_N,
    ) -> None:
        if len(getattr(robot, "constants", ())) != R_SIZE:
            raise ParameterError(
                "robot", type(robot).__name__, "a core.robot.RobotModel",
                "the reduction is J_Rᵀ F (eq. 3.34), from the robot's Jacobian",
            )
        self._robot = robot
        minimum = check_min_force(min_force_N)
        self.constants = [check_tolerance(tolerance_rad), check_level(level), minimum * minimum,
                          0.0, math.nan, math.nan, -math.inf, 0.0]

    @property
    def robot(self):
        """The robot model whose J_Rᵀ turns the subject's force into joint torques."""
        return self._robot

    @property
    def tolerance_rad(self) -> float:
        return self.constants[A_TOLERANCE]

    @property
    def level(self) -> float:
        return self.constants[A_LEVEL]

    @property
    def min_force_N(self) -> float:
        return math.sqrt(self.constants[A_MIN_FORCE_SQ])

    def set_level(self, level: float) -> None:
        """Change the graded level (0–1); refused by name when out of range."""
        self.constants[A_LEVEL] = check_level(level)

    def set_tolerance(self, tolerance_rad: float) -> None:
        """Change the cone's half-angle (rad); refused by name when out of range."""
        self.constants[A_TOLERANCE] = check_tolerance(tolerance_rad)

    @property
    def estimated(self) -> bool:
        """Whether the scheme judges an estimate of the patient's force (from EMG) in
        place of the force sensor's reading."""
        return self.constants[A_ESTIMATED] != 0.0

    def judge_estimate(self, period_s: float, max_age_s: float = ESTIMATE_MAX_AGE_S) -> None:
        """Judge the patient's force by the estimate `set_estimate` gives from now on, for
        ticks of `period_s`; an estimate older than `max_age_s` counts as none."""
        check_range("max_age_s", max_age_s, period_s, 5.0, "s",
                    "at least one tick; an estimate seconds old says nothing of the push now")
        self.constants[A_ESTIMATED] = 1.0
        self.constants[A_EST_MAX_AGE] = max_age_s / period_s

    def set_estimate(self, fx: float, fy: float, tick: int) -> None:
        """The latest estimate of the hand's force (global frame, N) and the tick it
        describes; NaN when the estimate is lost (the scheme then gives no way)."""
        self.constants[A_EST_FX] = float(fx)
        self.constants[A_EST_FY] = float(fy)
        self.constants[A_EST_TICK] = float(tick)

    def apply(self, q1, q2, tau1, tau2, fx, fy, dir_x, dir_y):
        """Reduce the controller's torques for the subject's in-direction effort.

        q1, q2: joint angles (rad); tau1, tau2: controller torques (N·m);
        fx, fy: hand force on the handle, global frame (N); dir_x, dir_y: desired
        direction of motion (need not be unit length).
        Returns (tau1_out, tau2_out, active, angle_rad); angle is NaN when |F| is
        below `min_force_N` or the direction is undefined. NaN inputs leave the
        torques unchanged and the scheme inactive.
        """
        return assisted_torques(self._robot.constants, self.constants, q1, q2, tau1, tau2,
                                fx, fy, dir_x, dir_y)


@kernel
def judged_force(a, tick, fx, fy):
    """The patient's force the scheme judges at `tick`: the sensor's (fx, fy), or, when
    the scheme judges an estimate (`PerformanceAssistance.judge_estimate`), the latest
    one, NaN (no push: the scheme inactive) once it is older than its limit or when it
    was made for a later tick than this one."""
    if a[A_ESTIMATED] == 0.0:
        return (fx, fy)
    age = tick - a[A_EST_TICK]
    # an estimate for a tick still to come is one from another trial's count: none
    if not (0.0 <= age <= a[A_EST_MAX_AGE]):
        return (math.nan, math.nan)
    return (a[A_EST_FX], a[A_EST_FY])


@kernel
def cone_test(a, fx, fy, dir_x, dir_y):
    """Whether the hand's force (fx, fy) lies within the tolerance cone about the desired
    direction (steps 2–3 of the module notes): (active, angle), the angle NaN when the
    force is below the minimum or the direction undefined (NaN inputs: inactive)."""
    force_sq = fx * fx + fy * fy
    dir_sq = dir_x * dir_x + dir_y * dir_y
    # Written as `not >=` so that NaN readings fall on the inactive side.
    if not (force_sq >= a[A_MIN_FORCE_SQ]) or not (dir_sq > _MIN_DIRECTION_SQ):
        return (False, math.nan)
    # atan2 of cross and dot stays accurate near 0 and π, where acos of a
    # normalised dot product loses half its digits.
    angle = math.atan2(abs(fx * dir_y - fy * dir_x), fx * dir_x + fy * dir_y)
    return (angle <= a[A_TOLERANCE], angle)


@kernel
def assisted_torques(robot, a, q1, q2, tau1, tau2, fx, fy, dir_x, dir_y):
    """PerformanceAssistance.apply on a RobotModel's constants `robot` and the scheme's
    constants `a`: (τ1, τ2, active, angle)."""
    active, angle = cone_test(a, fx, fy, dir_x, dir_y)
    if not active:
        return (tau1, tau2, False, angle)
    level = a[A_LEVEL]
    g1, g2 = joint_torque_terms(robot, q1, q2, fx, fy)
    r1 = level * g1
    r2 = level * g2
    if r1 * tau1 > 0.0:
        tau1 = tau1 - r1 if abs(r1) < abs(tau1) else 0.0
    if r2 * tau2 > 0.0:
        tau2 = tau2 - r2 if abs(r2) < abs(tau2) else 0.0
    return (tau1, tau2, True, angle)
