"""The games' rules: one scorer, fed the hand's samples in order, live or from the file.

`GameScorer(layout).feed(t_s, x_m, y_m, phase)` takes any chunk of samples (the window's
16 ms batches, or a whole trial at once) and returns the live `GameState`; `finish()` gives
the `GameFigures`. `score_game` is the after-trial function: the same scorer fed the whole
arrays, so the figures live and from the file come from one formula. Every sample is scored
one at a time with plain floats in order, so how the samples are split into chunks never
changes a figure (tests/core/games/test_scoring.py checks random chunkings with hypothesis).

The clock: game time is s from the exercise's start, the first sample of the exercise phase
(phase 2, device.loop.pipeline.PHASE_EXERCISE; every sample when no phase is given), unless
`start_s` names it. Samples outside the exercise phase, and from `layout.total_s` on, are not
played. Each sample stands for the time since the sample before it.

Reaching game: target k is *hit* at the first sample in [onset, onset + time allowed) whose
hand lies within the target's radius (distance ≤ radius); a target whose window closes
unhit is a *miss*. A hit scores HIT_POINTS; each entry of the hand into a distractor's disc is
a *touch* and costs DISTRACTOR_POINTS. Score = HIT_POINTS·hits − DISTRACTOR_POINTS·touches.
Time = the mean time from a target's appearance to its hit (knowledge of results, Act.Sens
protocol, doi 10.1186/s40814-021-00948-3).

Path game: the ball (the hand) is *inside* when its distance to the path is at most the
channel's half-width (layout.distance_to_path). A lap is a *hit* when no sample of it was
outside and the hand moved at least COVERAGE of the path's length during it (staying still in
the channel is not playing); otherwise a *miss*. Every second outside costs
POINTS_PER_S_OUTSIDE: Score = LAP_POINTS·hits − POINTS_PER_S_OUTSIDE·(time outside).

A unit (target or lap) whose window had not closed when the samples ended (the trial was
stopped) is neither a hit nor a miss: `finish` closes the windows that end within one and a
half sample intervals of the last sample, the exercise's last tick standing for the interval
up to its end. Success = hits / (hits + misses), the staircase's measure
(core.games.staircase).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError
from core.games.layout import GameLayout, distance_to_path

EXERCISE_PHASE = 2
"""The exercise's phase number in the trial file (device.loop.pipeline.PHASE_EXERCISE)."""
HIT_POINTS = 10.0
DISTRACTOR_POINTS = 5.0
LAP_POINTS = 10.0
POINTS_PER_S_OUTSIDE = 10.0
COVERAGE = 0.8
"""The share of the path's length the hand must move in a lap for it to count."""
_CLOSE_WITHIN_INTERVALS = 1.5


@dataclass(frozen=True, slots=True)
class Outcome:
    """One finished target or lap, for knowledge of results after each movement.
    `at_s` game time it ended (the hit, or its window's close); `time_s`: reaching game,
    time from the target's appearance to the hit (NaN for a miss); path game, time outside
    the channel in the lap."""

    index: int
    hit: bool
    at_s: float
    time_s: float


@dataclass(frozen=True, slots=True)
class GameState:
    """The game now, for the patient's screen. Times in s of game time.

    started: an exercise sample has been played. t_s: the last one's game time.
    time_left_s: until the exercise's end on the clock.
    current: the open target's index (reaching game; -1 while none is open: before the
    first, after a hit, between windows) or the lap's (path game; -1 once all are over).
    current_since_s: when it opened; current_left_s: time left to hit it / in the lap.
    inside: path game, the ball is inside the channel (reaching game: always True).
    points_lost: path game, points lost outside the channel so far.
    touches: reaching game, entries into distractors so far.
    last: the last finished target or lap (None before the first)."""

    game: str
    started: bool
    t_s: float
    time_left_s: float
    current: int
    current_since_s: float
    current_left_s: float
    hits: int
    misses: int
    score: float
    inside: bool
    points_lost: float
    touches: int
    last: Outcome | None


@dataclass(frozen=True, slots=True)
class GameFigures:
    """A game trial's figures (see the module docstring for each formula). success is
    hits / (hits + misses), NaN when none finished; time_s the time played (s);
    mean_time_to_hit_s: reaching game (NaN without a hit); time_outside_s: path game."""

    game: str
    score: float
    hits: int
    misses: int
    success: float
    time_s: float
    mean_time_to_hit_s: float
    touches: int
    time_outside_s: float
    points_lost: float
    outcomes: tuple[Outcome, ...]

    def to_metrics(self) -> dict[str, float]:
        """The figures as the trial's metrics (file /metrics, the registry's metrics JSON):
        plain numbers under names starting 'game_'."""
        return {
            "game_score": self.score, "game_hits": float(self.hits),
            "game_misses": float(self.misses), "game_success": self.success,
            "game_time_s": self.time_s, "game_time_to_hit_s": self.mean_time_to_hit_s,
            "game_touches": float(self.touches), "game_time_outside_s": self.time_outside_s,
            "game_points_lost": self.points_lost,
        }


class GameScorer:
    """The game's rules fed the hand's samples in order (see the module docstring)."""

    def __init__(self, layout: GameLayout, start_s: float | None = None) -> None:
        self.layout = layout
        self._start = None if start_s is None else float(start_s)
        self._t = math.nan  # game time of the last sample played
        self._dt = 0.0  # its interval
        self._x = self._y = math.nan
        self._ended = False  # a sample came from the exercise's end on
        self._k = 0  # the target or lap whose window is next to close
        self._resolved = False  # target k was hit
        self._hits = 0
        self._misses = 0
        self._outcomes: list[Outcome] = []
        self._times_to_hit: list[float] = []
        self._touching = [False] * len(layout.distractors)
        self._touches = 0
        self._inside = True
        self._outside_s = 0.0
        self._lap_outside_s = 0.0
        self._lap_left = False
        self._lap_moved_m = 0.0
        self._path_length = layout.path.length if layout.game == "path" else 0.0

    # ------------------------------------------------------------------ feeding
    def feed(self, t_s, x_m, y_m, phase=None) -> GameState:
        """Score a chunk of samples (1-D arrays or sequences of equal length, in time order:
        t in s on the trial's clock, the hand's x, y in m, the phase per sample or None)."""
        t = np.asarray(t_s, dtype=float).ravel()
        x = np.asarray(x_m, dtype=float).ravel()
        y = np.asarray(y_m, dtype=float).ravel()
        ph = None if phase is None else np.asarray(phase).ravel()
        if not (t.size == x.size == y.size) or (ph is not None and ph.size != t.size):
            raise ParameterError("samples", (t.size, x.size, y.size),
                                 "t, x, y (and phase) of one length")
        if ph is not None:
            keep = ph == EXERCISE_PHASE
            t, x, y = t[keep], x[keep], y[keep]
        for ti, xi, yi in zip(t.tolist(), x.tolist(), y.tolist(), strict=True):
            self._sample(ti, xi, yi)
        return self.state

    def _sample(self, t: float, x: float, y: float) -> None:
        if self._start is None:
            self._start = t
        g = t - self._start
        if g < 0.0 or self._ended:
            return
        if g >= self.layout.total_s:
            self._ended = True
            return
        if math.isnan(self._t):
            self._dt = 0.0
        elif g <= self._t:
            raise ParameterError("t_s", t, "times after the last sample's",
                                 "samples must come in time order")
        else:
            self._dt = g - self._t
        moved = 0.0 if math.isnan(self._x) else math.hypot(x - self._x, y - self._y)
        self._t, self._x, self._y = g, x, y
        if self.layout.game == "reach":
            self._reach(g, x, y)
        else:
            self._lap(g, x, y, moved)

    def _reach(self, g: float, x: float, y: float) -> None:
        targets = self.layout.targets
        self._close_targets(g)
        if self._k < len(targets) and not self._resolved:
            target = targets[self._k]
            if g >= target.onset_s and _within(x, y, target.centre_m, target.radius_m):
                self._resolved = True
                self._hits += 1
                self._times_to_hit.append(g - target.onset_s)
                self._outcomes.append(Outcome(self._k, True, g, g - target.onset_s))
        for i, disc in enumerate(self.layout.distractors):
            inside = _within(x, y, disc.centre_m, disc.radius_m)
            if inside and not self._touching[i]:
                self._touches += 1
            self._touching[i] = inside

    def _close_targets(self, until_s: float) -> None:
        targets = self.layout.targets
        while self._k < len(targets) and targets[self._k].closes_s <= until_s:
            if not self._resolved:
                self._misses += 1
                self._outcomes.append(Outcome(self._k, False, targets[self._k].closes_s,
                                              math.nan))
            self._k += 1
            self._resolved = False

    def _lap(self, g: float, x: float, y: float, moved: float) -> None:
        self._close_laps(g)
        self._inside = distance_to_path(self.layout.path, x, y) <= \
            self.layout.channel_half_width_m
        if not self._inside:
            self._lap_left = True
            self._outside_s += self._dt
            self._lap_outside_s += self._dt
        self._lap_moved_m += moved

    def _close_laps(self, until_s: float) -> None:
        lap_s = self.layout.lap_s
        while self._k < self.layout.laps and (self._k + 1) * lap_s <= until_s:
            hit = not self._lap_left and self._lap_moved_m >= COVERAGE * self._path_length
            self._hits += hit
            self._misses += not hit
            self._outcomes.append(Outcome(self._k, hit, (self._k + 1) * lap_s,
                                          self._lap_outside_s))
            self._k += 1
            self._lap_left = False
            self._lap_outside_s = 0.0
            self._lap_moved_m = 0.0

    # ------------------------------------------------------------------ reading
    @property
    def state(self) -> GameState:
        layout = self.layout
        started = not math.isnan(self._t)
        g = self._t if started else 0.0
        current, since, left = -1, math.nan, math.nan
        if layout.game == "reach":
            if self._k < len(layout.targets) and not self._resolved:
                target = layout.targets[self._k]
                if started and g >= target.onset_s:
                    current, since, left = self._k, target.onset_s, target.closes_s - g
        elif self._k < layout.laps:
            current, since = self._k, self._k * layout.lap_s
            left = since + layout.lap_s - g
        return GameState(layout.game, started, g, layout.total_s - g, current, since, left,
                         self._hits, self._misses, self._score(), self._inside,
                         POINTS_PER_S_OUTSIDE * self._outside_s, self._touches,
                         self._outcomes[-1] if self._outcomes else None)

    def _score(self) -> float:
        if self.layout.game == "reach":
            return HIT_POINTS * self._hits - DISTRACTOR_POINTS * self._touches
        return LAP_POINTS * self._hits - POINTS_PER_S_OUTSIDE * self._outside_s

    def finish(self) -> GameFigures:
        """Close the windows the samples covered (see the module docstring) and return the
        figures. The scorer may be read again; feeding it after finish is not meaningful."""
        played = 0.0
        if not math.isnan(self._t):
            covered = self._t + _CLOSE_WITHIN_INTERVALS * self._dt
            if self._ended:
                covered = self.layout.total_s
            if self.layout.game == "reach":
                self._close_targets(covered)
            else:
                self._close_laps(covered)
            played = min(self._t + self._dt, self.layout.total_s)
            if self._ended:
                played = self.layout.total_s
        finished = self._hits + self._misses
        mean_hit = (sum(self._times_to_hit) / len(self._times_to_hit)
                    if self._times_to_hit else math.nan)
        return GameFigures(
            self.layout.game, self._score(), self._hits, self._misses,
            self._hits / finished if finished else math.nan, played, mean_hit,
            self._touches, self._outside_s, POINTS_PER_S_OUTSIDE * self._outside_s,
            tuple(self._outcomes),
        )


def score_game(layout: GameLayout, t_s, x_m, y_m, phase=None,
               start_s: float | None = None) -> GameFigures:
    """The after-trial figures from whole arrays: the live scorer fed them at once."""
    scorer = GameScorer(layout, start_s)
    scorer.feed(t_s, x_m, y_m, phase)
    return scorer.finish()


def _within(x: float, y: float, centre: tuple[float, float], radius: float) -> bool:
    return math.hypot(x - centre[0], y - centre[1]) <= radius
