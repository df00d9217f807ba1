"""Assist-as-needed guidance: a compliant channel around the path whose reference moves
with the patient, help along the path that the patient earns back, and a feedforward
learned across repetitions that the robot forgets when it is not needed.

This is the `as-needed` assistance mode of a trial (`TrialParameters.assist`); the
thesis's own scheme, a stiff tracker on a fixed clock with the reduce-only cut of
Fig. 3.6, is the `thesis` mode (core.control.assistance). Why a second mode: on the
thesis's D the reduce-only cut changes the robot's torque by under 0.05 %, because the
stiff tracker has already cancelled the patient's push before the cut could act, and
the fixed clock brakes a patient who moves ahead of it (docs/validation.md,
Assistance). The intent of section 3.5, "the robot should do less when the patient
does more", needs the patient's progress to move the reference.

The law, each tick of the exercise
----------------------------------
With p the handle (eq. 3.2), v = J_R θ̇ its velocity (eq. 3.3, the tracker's θ̇), and
the path tabulated at the loop rate (the trial's reference rows):

1. **Where the patient is**: σ_h, the row of the path nearest to the handle, searched
   in a window around the last one and never more than 0.3 s of path behind the
   furthest row reached (so the D's repetitions, which overlap in space, are told
   apart by where the patient has been).
2. **Where the robot leads**: the reference row σ_r = max(σ_h, k − D), with k the
   clock's row and D the therapist's delay (`delay_s`). A patient ahead of the clock
   or less than D behind it is not pulled back or along: the reference is the
   patient's own place on the path. One who falls further behind than D is led
   along at the path's own pace, D behind the clock.
3. **The channel**, across the path: with p_h the path's point at σ_h (the hand's
   nearest), t̂ the path's tangent there and n̂ its normal, a spring-damper
   F_n = K_n (p_h − p) − B_n (v·n̂) n̂, at most `channel_limit_N`, holds the hand near
   the path without a clock. On a smooth stretch p_h − p lies along n̂; at the D's
   corners it pulls into the corner.
4. **Help along the path**, only when the reference leads (σ_r > σ_h):
   F_t = ρ · level · (K_t ℓ + B_t (v_r − v)·ĥ) + level · u(σ_r), clipped to
   [0, `help_limit_N`], along ĥ: never against the patient's motion, never more than
   the limit. ℓ is the lead, the distance from the hand's point of the path to the
   reference's, ĥ the direction from the one to the other (the tangent on a straight
   stretch; round the corner at the D's corners, where the tangent would push the hand
   on past the corner), and v_r the path's velocity at the reference.
   Once the hand reaches the path's end the reference stops there, and the same spring
   and damper hold the hand at the end both ways, so that it does not coast past it.
   u is the learned feedforward (5), ρ the patient's earned relief (6), `level` the
   therapist's assistance level (0: the channel alone; 1: full help).
5. **The learned feedforward** (Emken et al. 2007, J NeuroEng Rehabil 4:8): the path of
   one repetition is cut into `bins` bins; on leaving a bin the robot updates its
   force there, u ← f u + g ē, with ē the mean lead ℓ of the visit beyond a
   dead-band (`deadband_m`) and f < 1 the forgetting factor. A patient who keeps up
   makes ē zero and the force decays by f every repetition: the robot relaxes faster
   than the patient learns (f = 0.7 halves it in two repetitions). u is interpolated
   between the bins' centres and clipped to [0, `feedforward_limit_N`].
6. **Relief earned within a repetition** (the thesis's directional performance, section
   3.6.1): while the patient's force lies within the tolerance cone of the path's
   direction (the thesis's test, core.control.assistance.cone_test) and the hand is
   within `error_tolerance_m` of the path, ρ falls at `relief_rate_1_s`; outside the
   cone (with a force above the minimum) or off the path it rises at
   `recovery_rate_1_s`; ρ ∈ [`relief_floor`, 1]. The thesis's reduce-only rule stays
   as a bound: the help is never negative, so what the patient earns only takes help
   away, and the sum never exceeds the limit.
7. **Transparency**: the robot's own joint stiffness and a share of its friction, from
   its model (eq. 3.6), are compensated so that the patient feels less of the robot:
   τ = K̂_R(θ − θ_R0) + c f̂(θ̇) + J_Rᵀ (F_n + F_t ĥ), c = `friction_compensation` < 1
   so that the robot's friction left over is dissipation, not a source.

Why it is passive where it should be, and bounded where it cannot be
--------------------------------------------------------------------
With the reference still (a patient stalled less than D behind the clock), the
channel is a spring to a fixed line plus a damper: the energy it can give back is what
the spring stored, ½ K_n |p_h − p|², and the damper only takes; the friction compensation
(c < 1) leaves net friction. The help along the path is the only source, by design:
it is what assistance is. Its force is in [0, `help_limit_N`] and acts only along the
path's tangent while the reference leads, so the work it does over a trial is at most
`help_limit_N` × the distance the handle travels along the path, whatever the patient
does (tests/core/control/test_guidance.py measures both in closed loop).

Where the guidance is not used: the approach to the start point and the hold at the
end run the trial's tracking controller (SMC or CT-PID) on the clock, as in the thesis
mode, so that the patient is brought to the path and held at its end.

The constants (`GuidanceGains.constants`, GC_* names) and the state (GS_*) are flat
vectors; the law is the kernel `guidance_command` (core.kernels), compiled in the loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

from core.control.assistance import A_LEVEL, A_MIN_FORCE_SQ, cone_test
from core.errors import ParameterError, check_range
from core.kernels import kernel
from core.robot_terms import friction_of, jacobian_of, position_of, stiffness_terms, trig


@dataclass(frozen=True, slots=True)
class GuidanceGains:
    """The guidance's gains, in SI units; each is checked against its range by name.

    The defaults were chosen on the simulator's realistic plant (device.sim.plant) with
    the thesis's D (docs/validation.md, Assistance): the channel's stiffness is what the
    drives can hold (2.2 N·m at about 0.35 m of lever is 6 N, 7.5 mm of the channel's
    spring) and the damping about critical for the arm and the robot at the handle
    (a few kg).
    """

    channel_stiffness_N_m: float = 800.0
    channel_damping_Ns_m: float = 25.0
    channel_limit_N: float = 5.0
    lead_stiffness_N_m: float = 300.0
    lead_damping_Ns_m: float = 20.0
    help_limit_N: float = 5.0
    delay_s: float = 0.3
    bins: int = 20
    forgetting: float = 0.7
    learning_N_m: float = 150.0
    deadband_m: float = 0.002
    feedforward_limit_N: float = 3.0
    relief_floor: float = 0.3
    relief_rate_1_s: float = 1.0
    recovery_rate_1_s: float = 2.0
    error_tolerance_m: float = 0.005
    friction_compensation: float = 0.8

    def __post_init__(self) -> None:
        for f in fields(self):
            low, high, unit, why = GAIN_RANGES[f.name]
            value = getattr(self, f.name)
            if f.name == "bins" and (isinstance(value, bool) or not isinstance(value, int)):
                raise ParameterError("bins", value, f"a whole number in {low}–{high}")
            check_range(f.name, value, low, high, unit, why)

    def replace(self, **changes) -> GuidanceGains:
        return replace(self, **changes)

    def to_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_dict(cls, values: dict) -> GuidanceGains:
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(values) - names)
        if unknown:
            raise ParameterError("guidance", ", ".join(unknown), ", ".join(sorted(names)),
                                 "unknown guidance gain")
        return cls(**values)

    def constants(self, *, period_s: float, repetition_s: float,
                  ) -> list[float]:
        """The kernel's constants vector for a trial (GC_* names)."""
        c = [0.0] * GC_SIZE
        c[GC_ON] = 1.0
        c[GC_KN] = self.channel_stiffness_N_m
        c[GC_BN] = self.channel_damping_Ns_m
        c[GC_CHANNEL_MAX] = self.channel_limit_N
        c[GC_KT] = self.lead_stiffness_N_m
        c[GC_BT] = self.lead_damping_Ns_m
        c[GC_HELP_MAX] = self.help_limit_N
        c[GC_DELAY_ROWS] = float(round(self.delay_s / period_s))
        c[GC_REP_ROWS] = float(round(repetition_s / period_s))
        c[GC_BINS] = float(self.bins)
        c[GC_FORGET] = self.forgetting
        c[GC_LEARN] = self.learning_N_m
        c[GC_DEADBAND] = self.deadband_m
        c[GC_FF_MAX] = self.feedforward_limit_N
        c[GC_RHO_MIN] = self.relief_floor
        c[GC_RHO_DOWN] = self.relief_rate_1_s * period_s
        c[GC_RHO_UP] = self.recovery_rate_1_s * period_s
        c[GC_E_TOL] = self.error_tolerance_m
        c[GC_FRICTION] = self.friction_compensation
        return c


GAIN_RANGES = {
    # name: (low, high, unit, why)
    "channel_stiffness_N_m": (0.0, 3000.0, "N/m",
                              "the channel's wall across the path; 0 leaves the hand free"),
    "channel_damping_Ns_m": (0.0, 200.0, "N·s/m", "damping across the path"),
    "channel_limit_N": (0.0, 30.0, "N", "the most force the channel uses to bring the hand "
                        "back to the path"),
    "lead_stiffness_N_m": (0.0, 3000.0, "N/m",
                           "the pull along the path once the patient is D behind the clock"),
    "lead_damping_Ns_m": (0.0, 200.0, "N·s/m", "damping of the pull along the path"),
    "help_limit_N": (0.0, 20.0, "N", "the most help the robot may add along the path"),
    "delay_s": (0.0, 5.0, "s", "how far behind the clock the patient may fall before the "
                "robot leads"),
    "bins": (2, 200, "", "bins of the learned feedforward over one repetition"),
    "forgetting": (0.0, 1.0, "", "the share of the learned force kept per repetition"),
    "learning_N_m": (0.0, 3000.0, "N/m", "force learned per metre of lag per repetition"),
    "deadband_m": (0.0, 0.05, "m", "lag the feedforward ignores (natural variability)"),
    "feedforward_limit_N": (0.0, 20.0, "N", "the most the learned force may be"),
    "relief_floor": (0.0, 1.0, "", "the lowest share of the lead a good patient can earn"),
    "relief_rate_1_s": (0.0, 20.0, "1/s", "how fast good pushing lowers the lead"),
    "recovery_rate_1_s": (0.0, 20.0, "1/s", "how fast the lead comes back"),
    "error_tolerance_m": (0.0, 0.05, "m", "distance from the path still counted as on it"),
    "friction_compensation": (0.0, 0.95, "",
                              "share of the modelled friction compensated; below 1 so that "
                              "the robot stays dissipative"),
}

# The constants vector (GuidanceGains.constants).
(GC_ON, GC_KN, GC_BN, GC_KT, GC_BT, GC_HELP_MAX, GC_DELAY_ROWS, GC_REP_ROWS, GC_BINS,
 GC_FORGET, GC_LEARN, GC_DEADBAND, GC_FF_MAX, GC_RHO_MIN, GC_RHO_DOWN, GC_RHO_UP, GC_E_TOL,
 GC_FRICTION, GC_CHANNEL_MAX, GC_SIZE) = range(20)
OFF = (0.0,) * GC_SIZE
"""The constants of a trial in the thesis mode (no guidance)."""

# The state (`state_size(bins, repetitions)` floats): whether the exercise has begun,
# the patient's row σ_h and the reference's σ_r, the relief ρ, the bin and repetition
# the reference is in, the visit's lag sum and count, how many repetitions' forces are
# kept, the furthest row the hand has reached, then the learned force per bin, then its
# value at the end of each repetition.
(GS_STARTED, GS_SIGMA_H, GS_SIGMA_R, GS_RHO, GS_BIN, GS_REP, GS_LAG_SUM, GS_LAG_N,
 GS_KEPT, GS_FURTHEST, GS_U) = range(11)
WINDOW_BACK_ROWS = 25
"""How far back (rows, 50 ms at the path's pace) the patient's row is searched: a patient
pushed back by a wrong-way push is followed, a long way back only over several ticks."""
BEHIND_FURTHEST_ROWS = 150
"""How far behind the furthest row it has reached (0.3 s of path) the hand's row may go:
a patient pushing the wrong way at the start of a repetition is not taken for one at the
end of the last (the D's start and end are the same point)."""
WINDOW_AHEAD_ROWS = 300
"""How far ahead (rows, 0.6 s of path): beyond any hand's speed in one tick, and far
enough that a hand cutting a corner of the D is found on the stretch after the corner
rather than held to the one before it."""


def state_size(bins: int, repetitions: int) -> int:
    """The state vector's length for a trial of `repetitions` with `bins` per repetition."""
    return GS_U + bins * (repetitions + 1)


@kernel
def feedforward_at(g, s, rel):
    """The learned force (N) at `rel` rows into the exercise, interpolated between the
    bins' centres of one repetition (wrapping round from the last bin to the first)."""
    bins = int(g[GC_BINS])
    rep = g[GC_REP_ROWS]
    phase = (rel % rep) / rep * bins - 0.5
    if phase < 0.0:
        phase += bins
    i = int(phase)
    frac = phase - i
    j = i + 1 if i + 1 < bins else 0
    return (1.0 - frac) * s[GS_U + i] + frac * s[GS_U + j]


@kernel
def learn(g, s, bin_index, rep_index):
    """Leave a bin: u ← f u + g ē (the visit's mean lag beyond the dead-band), clipped;
    on leaving a repetition, keep a copy of every bin's force for the trial's file."""
    n = s[GS_LAG_N]
    mean = s[GS_LAG_SUM] / n if n > 0.0 else 0.0
    k = GS_U + bin_index
    u = g[GC_FORGET] * s[k] + g[GC_LEARN] * mean
    s[k] = 0.0 if u < 0.0 else (g[GC_FF_MAX] if u > g[GC_FF_MAX] else u)
    s[GS_LAG_SUM] = 0.0
    s[GS_LAG_N] = 0.0


@kernel
def keep_repetition(g, s, rep_index):
    """Copy the learned force of every bin into the history row of `rep_index`."""
    bins = int(g[GC_BINS])
    at = GS_U + bins * (1 + rep_index)
    if at + bins <= len(s):
        for b in range(bins):
            s[at + b] = s[GS_U + b]
        if s[GS_KEPT] < rep_index + 1:
            s[GS_KEPT] = rep_index + 1


@kernel
def search_window(first, last, around):
    """The rows `nearest_row` searches: [around − back, around + ahead] ∩ [first, last]."""
    lo = around - WINDOW_BACK_ROWS
    hi = around + WINDOW_AHEAD_ROWS
    lo = first if lo < first else lo
    hi = last if hi > last else hi
    return lo, hi


@kernel
def nearest_row(rows, rows_from, first, last, around, x, y):
    """The row in [around − back, around + ahead] ∩ [first, last] nearest to (x, y); `first`
    is the lowest row it may be. `rows` holds the path's rows from row `rows_from`."""
    lo, hi = search_window(first, last, around)
    best = lo
    best_d = math.inf
    for i in range(lo, hi + 1):
        row = rows[i - rows_from]
        dx = row[0] - x
        dy = row[1] - y
        d = dx * dx + dy * dy
        if d < best_d:
            best_d = d
            best = i
    return best


@kernel
def lowest_row(s, first):
    """The lowest row the hand's row may be found at: not before the exercise's first,
    nor more than BEHIND_FURTHEST_ROWS behind the furthest reached."""
    lowest = int(s[GS_FURTHEST]) - BEHIND_FURTHEST_ROWS
    return first if lowest < first else lowest


@kernel
def guidance_rows(g, s, first, last, tick):
    """The lowest and highest row `guidance_command` may read at `tick`, from the state `s`
    before it (rows first…last the exercise's): the hand's row is searched around the
    last one (`search_window`), the reference is that or the clock's row less the
    delay. A headless run loads the rows a stretch of ticks needs from this, so the
    whole path need not be held (device.loop.engine.run_ticks)."""
    if s[GS_STARTED] == 0.0:
        lo, hi = search_window(first, last, first)
    else:
        lo, hi = search_window(lowest_row(s, first), last, int(s[GS_SIGMA_H]))
    clock = tick - int(g[GC_DELAY_ROWS])
    clock = last if clock > last else (first if clock < first else clock)
    return (clock if clock < lo else lo, clock if clock > hi else hi)


@kernel
def guidance_command(robot, g, a, s, rows, rows_from, n_rows, first, tick, q1, q2, qd1, qd2,
                     fx, fy):
    """One tick of the guidance (the module notes): (reference row σ_r, the hand's row
    σ_h, τ1, τ2 without the help, τ1, τ2 with it, whether the force is in the cone, its
    angle). `robot` is
    the controller's RobotModel constants, `g` the guidance's constants, `a` the
    assistance's (its tolerance cone, minimum force and level), `s` the state, `rows`
    the trial's reference rows from row `rows_from` (at least those `guidance_rows`
    names) of its n_rows, with the exercise from row `first`; (fx, fy) the hand's force
    (global frame, N)."""
    last = n_rows - 1
    if s[GS_STARTED] == 0.0:
        s[GS_STARTED] = 1.0
        s[GS_SIGMA_H] = first
        s[GS_SIGMA_R] = first
        s[GS_FURTHEST] = first
        s[GS_RHO] = 1.0
        s[GS_BIN] = 0.0
        s[GS_REP] = 0.0
        s[GS_LAG_SUM] = 0.0
        s[GS_LAG_N] = 0.0
    t = trig(q1, q2)
    x, y = position_of(robot, t)
    j11, j12, j21, j22 = jacobian_of(robot, t)
    vx = j11 * qd1 + j12 * qd2
    vy = j21 * qd1 + j22 * qd2

    sigma_h = nearest_row(rows, rows_from, lowest_row(s, first), last, int(s[GS_SIGMA_H]),
                          x, y)
    if sigma_h > s[GS_FURTHEST]:
        s[GS_FURTHEST] = sigma_h
    clock = tick - int(g[GC_DELAY_ROWS])
    sigma_r = sigma_h if sigma_h > clock else clock
    sigma_r = last if sigma_r > last else (first if sigma_r < first else sigma_r)
    s[GS_SIGMA_H] = sigma_h
    s[GS_SIGMA_R] = sigma_r
    # across the path and its direction where the hand is; the lead towards the reference
    here = rows[sigma_h - rows_from]
    tx = here[4]
    ty = here[5]
    norm = math.sqrt(tx * tx + ty * ty)
    if norm > 0.0:
        tx /= norm
        ty /= norm
    nx = -ty
    ny = tx
    active, angle = cone_test(a, fx, fy, tx, ty)
    # the spring pulls to the hand's nearest point of the path: across the path on a
    # smooth stretch, into the corner at a corner (where a normal has no meaning)
    ex = here[0] - x
    ey = here[1] - y
    e_n = math.sqrt(ex * ex + ey * ey)
    v_n = vx * nx + vy * ny
    v_t = vx * tx + vy * ty
    row = rows[sigma_r - rows_from]
    # how far the reference leads: the chord from the hand's point of the path to it
    # (within a few cm of path, chord and arc differ by under 1 %)
    ax = row[0] - here[0]
    ay = row[1] - here[1]
    # products, not `** 2`: Python's pow and numba's differ in the last bit
    lead = math.sqrt(ax * ax + ay * ay)
    # the help points from the hand's point of the path to the reference: along the
    # tangent on a straight stretch, round the corner at the D's corners (the tangent
    # there would push the hand on past the corner)
    hx = tx
    hy = ty
    if lead > 1e-9:
        hx = ax / lead
        hy = ay / lead
    fx_c = g[GC_KN] * ex - g[GC_BN] * v_n * nx
    fy_c = g[GC_KN] * ey - g[GC_BN] * v_n * ny
    size = math.sqrt(fx_c * fx_c + fy_c * fy_c)
    if size > g[GC_CHANNEL_MAX]:
        # a hand pushed far off the path is brought back at the limit, not flung back
        fx_c *= g[GC_CHANNEL_MAX] / size
        fy_c *= g[GC_CHANNEL_MAX] / size

    # relief earned inside the cone and on the path, lost outside either
    rho = s[GS_RHO]
    on_path = abs(e_n) <= g[GC_E_TOL]
    pushing = fx * fx + fy * fy >= a[A_MIN_FORCE_SQ]
    if active and on_path:
        rho -= g[GC_RHO_DOWN]
    elif pushing or not on_path:
        rho += g[GC_RHO_UP]
    rho = g[GC_RHO_MIN] if rho < g[GC_RHO_MIN] else (1.0 if rho > 1.0 else rho)
    s[GS_RHO] = rho

    # the learned feedforward: where the reference is in its repetition
    rel = sigma_r - first
    rep_rows = g[GC_REP_ROWS]
    rep_index = int(rel // rep_rows)
    bin_index = int((rel % rep_rows) / rep_rows * g[GC_BINS])
    if bin_index != int(s[GS_BIN]) or rep_index != int(s[GS_REP]):
        learn(g, s, int(s[GS_BIN]), int(s[GS_REP]))
        if rep_index != int(s[GS_REP]):
            keep_repetition(g, s, int(s[GS_REP]))
        s[GS_BIN] = bin_index
        s[GS_REP] = rep_index
    lag = lead - g[GC_DEADBAND]
    s[GS_LAG_SUM] += lag if lag > 0.0 else 0.0
    s[GS_LAG_N] += 1.0
    level = a[A_LEVEL]
    u = level * feedforward_at(g, s, rel)
    help_t = 0.0
    if sigma_r == last:
        keep_repetition(g, s, rep_index)
    if sigma_h == last:
        # the hand at the path's end: the reference stops there, and the robot holds it
        # both ways (as the hold does after it) rather than let the hand coast past it
        help_t = g[GC_KT] * ((here[0] - x) * tx + (here[1] - y) * ty) - g[GC_BT] * v_t
        limit = g[GC_HELP_MAX]
        help_t = limit if help_t > limit else (-limit if help_t < -limit else help_t)
    elif sigma_r > sigma_h:
        v_ref = row[2] * hx + row[3] * hy
        help_t = rho * level * (g[GC_KT] * lead + g[GC_BT] * (v_ref - (vx * hx + vy * hy)))
        help_t += u
        help_t = 0.0 if help_t < 0.0 else (g[GC_HELP_MAX] if help_t > g[GC_HELP_MAX]
                                           else help_t)

    k1, k2 = stiffness_terms(robot, q1, q2)
    f1, f2 = friction_of(robot, t, qd1, qd2)
    c = g[GC_FRICTION]
    base1 = k1 + c * f1 + j11 * fx_c + j21 * fy_c
    base2 = k2 + c * f2 + j12 * fx_c + j22 * fy_c
    if sigma_h == last:
        hx = tx
        hy = ty
    out1 = base1 + (j11 * hx + j21 * hy) * help_t
    out2 = base2 + (j12 * hx + j22 * hy) * help_t
    return (sigma_r, sigma_h, base1, base2, out1, out2, active, angle)
