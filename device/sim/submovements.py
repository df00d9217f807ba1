"""A paretic arm's movements made of submovements (issue 31): the virtual patient's own
movement in the assessment tasks (device.sim.tasks) broken into overlapping minimum-jerk
pieces when its effort is lost.

After a stroke, a reach is not one smooth bell of speed but a train of smaller ones: early
in recovery movements are made of submovements of similar shape (Krebs HI, Aisen ML, Volpe
BT, Hogan N, "Quantization of continuous arm movements in humans with brain injury", PNAS
96(8):4645–4649, 1999, doi:10.1073/pnas.96.8.4645), and with recovery they grow larger,
fewer and more blended (Rohrer B et al., Motor Control 8(4):472–483, 2004), which is what
makes the movements smoother (Rohrer B et al., J Neurosci 22(18):8297–8304, 2002, for
point-to-point reaches and circles alike). Quoted from memory of the literature, as the
impedance values of device.sim.patients: the model below takes their direction, not
fitted numbers.

The model (this console's choice, not identified on people)
----------------------------------------------------------
* A patient of effort w < 1 moves by submovements of about SUBMOVEMENT_M / (1 − w) each
  (a healthy patient, w = 1, in one piece): a reach of distance L is made of
  n = max(1, ⌊L (1 − w) / SUBMOVEMENT_M + ½⌋) of them. The weak patient (w = 0.4) moves
  about 3.3 cm at a time: three pieces for the battery's 10 cm reaches, thirteen for a lap
  of its 7 cm circle.
* The pieces' amplitudes fall off (the first one carries the most, later ones close the
  gap, as a reach's primary and corrective submovements do): share k ∝ SHARE_RATIO^k,
  each varied from reach to reach by the caller, normalised to the whole distance.
* Each piece is a minimum-jerk profile (Flash & Hogan 1985) of the same duration D; piece
  k starts k·b·D after the first, so the movement lasts D (1 + (n − 1) b). The onset
  spacing b (1 = one piece after the other, speed zero between them; smaller = more
  blended) is BLEND_LOST·(1 − w) + BLEND_RECOVERED·w: the weaker, the less blended.
* The movement's time is the caller's (device.sim.tasks.movement_time_s): the pieces
  share it, they do not add to it.
* A circle at the patient's own pace (device.sim.tasks.own_circle) is walked by the same
  pieces along its arc, lap after lap, their shares varied from lap to lap (`OwnLaps`);
  with fewer than two pieces a lap keeps the constant pace. A patient slower than the dot
  stops when it stops, within STOP_S, as one asked to follow the dot does, so the drawing
  is a movement from rest to rest (the circle's smoothness is measured over it with the
  rest after: core.assessment.circle).

These are planned pieces: the plan does not react to where the hand is (a stroke
survivor's corrective submovements also answer the error they see; the virtual arm's
impedance pulls it to the plan instead).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from core.trajectory import Trajectory, TrajectorySample, minimum_jerk

SUBMOVEMENT_M = 0.02
"""The submovement's amplitude times the lost effort (m): 0.033 m for the weak patient."""
SHARE_RATIO = 0.7
"""Each piece's share of the distance over the one before it."""
BLEND_LOST = 1.0
"""The onset spacing over a piece's duration at no effort: one piece after the other (the
weak patient's 0.8 leaves the speed dipping between pieces; at 0.68 the hand's ripple on the
circle stayed under what SPARC sees: docs/assessments.md, Submovements)."""
BLEND_RECOVERED = 0.5
"""... and toward full effort (the pieces well blended)."""
STOP_S = 0.3
"""How a patient drawing the circle stops with the dot (a reaction time's order): at its
own pace its speed falls to rest over STOP_S about the dot's stop, at rest STOP_S/2 after
it; by pieces it begins none that would end later than that (until 2026-12-05 STOP_S after
it: the weak arm, its selectivity half lost, lagging its last piece, was still moving at
its drawing's mean speed when the hold after the circle ended)."""
HOLD_AFTER_S = 5.0
"""How long the plan holds where the patient stopped (the trial's hold after the exercise
is shorter: device.loop.plan.HOLD_S)."""


def piece_count(distance_m: float, effort: float) -> int:
    """How many submovements a patient of `effort` makes of a movement of `distance_m`."""
    lost = 1.0 - effort
    if lost <= 0.0:
        return 1
    return max(1, math.floor(distance_m * lost / SUBMOVEMENT_M + 0.5))


def onset_spacing(effort: float) -> float:
    """b: the spacing of the pieces' onsets over their duration (the module notes)."""
    return BLEND_LOST * (1.0 - effort) + BLEND_RECOVERED * effort


def nominal_shares(count: int) -> list[float]:
    """The pieces' shares of the distance before variation: SHARE_RATIO^k."""
    return [SHARE_RATIO ** k for k in range(count)]


def profile(t_s: np.ndarray, span_s: float, shares: Sequence[float], spacing: float,
            distance: float = 1.0, begun: int | None = None):
    """The distance covered, its rate and its acceleration at times `t_s` from the
    movement's start, for pieces of `shares` of `distance` (normalised here) whose onsets
    are `spacing` of a piece's duration apart over `span_s` in all; only the first
    `begun` pieces (default all) are made. One share gives the plain minimum-jerk
    profile, to the last bit (its products in the same order)."""
    t = np.asarray(t_s, dtype=float)
    weights = np.asarray(shares, dtype=float)
    weights = weights / weights.sum()
    duration = span_s / (1.0 + (len(weights) - 1) * spacing)
    s = np.zeros_like(t)
    sd = np.zeros_like(t)
    sdd = np.zeros_like(t)
    for k, share in enumerate(weights[:begun]):
        u = np.clip((t - k * spacing * duration) / duration, 0.0, 1.0)
        covered, rate, acceleration = minimum_jerk(u, duration, distance * float(share))
        s += covered
        sd += rate
        sdd += acceleration
    return s, sd, sdd


class OwnLaps:
    """A circle drawn lap after lap at the patient's own pace (device.sim.tasks.own_circle)
    by a patient who stops when the dot stops: `paced` (core.trajectory.Trajectory, the
    path at the patient's constant pace, enough laps to pass `stop_s`) walked either at
    that pace or, given `shares` (one row per lap: its pieces' shares of the lap,
    normalised per lap), by submovements whose onsets are `spacing` of a piece's duration
    apart (the module notes).

    At `stop_s` (the dot's last lap ends) the patient stops: at its own pace its speed
    falls to rest over STOP_S centred on the stop (a minimum-jerk fall: a patient at the
    dot's pace comes to rest where the dot stops, STOP_S/2 after it); by submovements it
    begins no piece that would end more than STOP_S/2 after the dot stopped. Then it holds where it
    stopped (no push) to `stop_s` + HOLD_AFTER_S. The pieces vary from lap to lap, so the
    plan is one traversal lasting the whole trial, as device.sim.tasks' OwnMovement is; it
    answers what device.sim.patients asks of a trajectory."""

    __slots__ = (
        "_kept",
        "_lap",
        "finished_s",
        "lap_s",
        "path_m",
        "shares",
        "spacing",
        "stop_s",
        "total_duration_s",
    )

    def __init__(self, paced: Trajectory, shares, spacing: float, stop_s: float):
        if paced.timing != "constant_speed":
            raise ValueError("own laps re-time a constant-pace trajectory")
        if paced.total_duration_s < stop_s:
            raise ValueError("the paced laps end before the stop")
        self.lap_s, self.path_m = paced.duration_s, paced.path.length
        self._lap = Trajectory(paced.path, paced.duration_s, 1, "constant_speed")
        self.stop_s, self.spacing = float(stop_s), float(spacing)
        self.shares = None if shares is None else np.asarray(shares, dtype=float)
        if self.shares is not None and (self.shares.ndim != 2
                                        or self.shares.shape[0] != paced.repetitions):
            raise ValueError("one row of shares per lap")
        self._kept, self.finished_s = self._stop()
        self.total_duration_s = self.stop_s + HOLD_AFTER_S

    @property
    def path(self):
        return self._lap.path

    @property
    def duration_s(self) -> float:
        return self.total_duration_s

    repetitions = 1

    def _stop(self) -> tuple[list[int], float]:
        """Each lap's pieces begun (by the stop rule) and when the plan comes to rest."""
        if self.shares is None:
            return [], self.stop_s + STOP_S / 2.0
        pieces = self.shares.shape[1]
        piece_s = self.lap_s / (1.0 + (pieces - 1) * self.spacing)
        kept, finished = [], 0.0
        for k in range(self.shares.shape[0]):
            ends = k * self.lap_s + np.arange(pieces) * self.spacing * piece_s + piece_s
            # a piece begun before the dot stopped, over when a patient at its own pace is
            # at rest (STOP_S/2 after the stop)
            at_rest = self.stop_s + STOP_S / 2.0
            begun = int(np.sum((ends <= at_rest) & (ends - piece_s < self.stop_s)))
            kept.append(begun)
            if begun:
                finished = float(ends[begun - 1])
        return kept, finished

    def arc(self, t_s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The arc length walked by `t_s` from the first lap's start, its rate and its
        acceleration."""
        t = np.asarray(t_s, dtype=float).ravel()
        pace = self.path_m / self.lap_s
        if self.shares is None:
            # the speed falls over STOP_S centred on the stop, as 1 − the minimum-jerk
            # profile (its integral over [0, u] below): it covers half of what the pace
            # would, so the hand comes to rest where the dot's pace would be at the stop
            falling = self.stop_s - STOP_S / 2.0
            u = np.clip((t - falling) / STOP_S, 0.0, 1.0)
            u2 = u * u
            slowing = u - 2.5 * u2 * u2 + 3.0 * u2 * u2 * u - u2 * u2 * u2
            walked = pace * np.clip(t, 0.0, falling) + pace * STOP_S * slowing
            fallen, _, _ = minimum_jerk(u, STOP_S, 1.0)
            speed = np.where((t >= 0.0) & (u < 1.0), pace * (1.0 - fallen), 0.0)
            along = -minimum_jerk(u, STOP_S, pace)[1]
            return walked, speed, along
        walked, speed, along = (np.zeros(t.size) for _ in range(3))
        for k, (row, begun) in enumerate(zip(self.shares, self._kept, strict=True)):
            if begun:
                s, sd, sdd = profile(t - k * self.lap_s, self.lap_s, row, self.spacing,
                                     self.path_m, begun)
                walked += s
                speed += sd
                along += sdd
        return walked, speed, along

    def sample(self, t_s) -> TrajectorySample:
        """The path's point at the arc walked by `t_s`: one lap's constant-pace sample at
        the time that pace reaches it, the velocity along the tangent at the walked speed,
        the acceleration its rate plus the curvature's (v² κ), κ read from the constant
        pace's acceleration; no direction to push in once the plan is at rest."""
        t = np.asarray(t_s, dtype=float).ravel()
        walked, speed, along = self.arc(t)
        pace = self.path_m / self.lap_s
        within = np.mod(walked, self.path_m) / pace
        base = self._lap.sample(np.where(within < self.lap_s, within, 0.0))
        curvature = base.acceleration_m_s2 / (pace * pace)
        moving = ((t >= 0.0) & (t < self.finished_s))[:, None]
        return TrajectorySample(t, base.position_m, base.direction * speed[:, None],
                                base.direction * along[:, None]
                                + curvature * (speed * speed)[:, None],
                                np.where(moving, base.direction, 0.0), base.segment,
                                (t >= self.total_duration_s).astype(int))

    def at(self, t: float):
        """(x, y, vx, vy, ax, ay, direction x, y) at one time, floats."""
        s = self.sample([t])
        return (*s.position_m[0], *s.velocity_m_s[0], *s.acceleration_m_s2[0],
                *s.direction[0])
