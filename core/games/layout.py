"""What a game shows, from the trial's parameters alone: the reaching game's targets and
distractors, the path game's channel. The layout is a pure function of TrialParameters, so
the file's /parameters recreate exactly what the patient saw.

Reaching game (shape "targets": core.trajectory.centre_out; shape "reach": straight_reach):
each straight reach *away from home* is a target, a disc of `target_radius_m` at the reach's
end, appearing when the robot's reference starts along that reach
(core.reaches.reaches_from_trajectory: repetition r, segment k starts at
r·duration_s + segment_times_s[k]) and open for `time_allowed_s`. The reaches back home are
not targets: the patient returns with the robot. Distractors (`n_distractors`) are discs of the
same radius at the targets' distance from home, halfway in angle between two neighbouring
targets (centre-out: the gaps after targets 0, g, 2g, … with g = gaps // n_distractors, so
they spread round the circle, or over the half circle of a neglect layout; straight reach:
either side of the target, ±30°), shown for the whole exercise. A neglect layout
(`neglect_side`) turns the targets, the robot's path with them, toward the patient's neglected
side (core.trajectory.centre_out_angles), so the file's parameters recreate it too.

Path game (any shape, the D by default): a channel of `channel_half_width_m` either side of
the path; the ball is the hand. A lap is one traversal of the path on the clock,
[r·duration_s, (r+1)·duration_s).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from core.trajectory import (
    AHEAD_RAD,
    NEGLECT_REACH_TURN_RAD,
    Arc,
    Line,
    Path,
    centre_out_angles,
    toward_side,
)
from core.trial import TrialParameters

# A straight reach has no neighbours: its distractors sit this far either side of it.
REACH_DISTRACTOR_ANGLE_RAD = math.radians(30.0)


@dataclass(frozen=True, slots=True)
class Target:
    """One target of the reaching game: a disc (m) open from `onset_s` for `window_s`,
    game time (s from the exercise's start). `index` counts targets in order."""

    index: int
    centre_m: tuple[float, float]
    radius_m: float
    onset_s: float
    window_s: float

    @property
    def closes_s(self) -> float:
        return self.onset_s + self.window_s


@dataclass(frozen=True, slots=True)
class Disc:
    """A distractor of the reaching game: a disc (m) to avoid for the whole exercise."""

    centre_m: tuple[float, float]
    radius_m: float


@dataclass(frozen=True, slots=True)
class GameLayout:
    """What the game shows. `game` is "path" or "reach"; `total_s` is the exercise's length
    on the clock (duration_s · repetitions); `home_m` the reaching layout's home (the path's
    start in the path game). Path game: `path`, `channel_half_width_m`, `lap_s`, `laps`.
    Reaching game: `targets` (in order of onset), `distractors`."""

    game: str
    total_s: float
    home_m: tuple[float, float]
    path: Path
    channel_half_width_m: float = 0.0
    lap_s: float = 0.0
    laps: int = 0
    targets: tuple[Target, ...] = ()
    distractors: tuple[Disc, ...] = ()

    def to_dict(self) -> dict:
        """Plain values for the trial's metrics and the patient's screen (m, s)."""
        out = {"game": self.game, "total_s": self.total_s, "home_m": list(self.home_m)}
        if self.game == "path":
            out.update(channel_half_width_m=self.channel_half_width_m, lap_s=self.lap_s,
                       laps=self.laps)
        else:
            out["targets"] = [[*t.centre_m, t.radius_m, t.onset_s, t.window_s]
                              for t in self.targets]
            out["distractors"] = [[*d.centre_m, d.radius_m] for d in self.distractors]
        return out


def game_layout(parameters: TrialParameters) -> GameLayout:
    """The layout of the trial's game; ValueError when the trial is not a game."""
    p = parameters
    if p.game == "":
        raise ValueError("the trial is not a game (game = '')")
    trajectory = p.trajectory()
    path = trajectory.path
    start = path.segments[0].geometry(0.0)
    home = (float(start[0]), float(start[1]))
    total = trajectory.total_duration_s
    if p.game == "path":
        return GameLayout("path", total, home, path, p.channel_half_width_m, p.duration_s,
                          p.repetitions)
    targets = []
    times = trajectory.segment_times_s
    for rep in range(p.repetitions):
        for k, segment in enumerate(path.segments):
            # outward reaches only: each leaves home (centre_out and straight_reach both
            # start every outward line there)
            if isinstance(segment, Line) and segment.start == home:
                targets.append(Target(len(targets), segment.end, p.target_radius_m,
                                      rep * p.duration_s + times[k], p.time_allowed_s))
    return GameLayout("reach", total, home, path, targets=tuple(targets),
                      distractors=_distractors(p, home))


def _distractors(p: TrialParameters, home: tuple[float, float]) -> tuple[Disc, ...]:
    if p.n_distractors == 0:
        return ()
    toward = toward_side(p.neglect_side)
    if p.shape == "reach":
        distance = 2.0 * p.radius_m
        ahead = AHEAD_RAD + toward * NEGLECT_REACH_TURN_RAD
        angles = [ahead + REACH_DISTRACTOR_ANGLE_RAD, ahead - REACH_DISTRACTOR_ANGLE_RAD]
    else:
        distance = p.radius_m
        targets = centre_out_angles(p.n_targets, toward)
        if toward == 0.0:  # round the circle: the last gap closes it
            targets.append(targets[0] + 2.0 * math.pi)
        gaps = [0.5 * (a + b) for a, b in itertools.pairwise(targets)]
        every = len(gaps) // p.n_distractors
        angles = [gaps[i * every] for i in range(p.n_distractors)]
    return tuple(Disc((home[0] + distance * math.cos(a), home[1] + distance * math.sin(a)),
                      p.target_radius_m) for a in angles[:p.n_distractors])


def distance_to_path(path: Path, x: float, y: float) -> float:
    """The shortest distance (m) from (x, y) to the path (its lines and arcs), plain floats:
    the path game's one formula for 'inside the channel', the same live and from the file."""
    best = math.inf
    for segment in path.segments:
        d = _to_line(segment, x, y) if isinstance(segment, Line) else _to_arc(segment, x, y)
        best = d if d < best else best
    return best


def _to_line(line: Line, x: float, y: float) -> float:
    (ax, ay), (bx, by) = line.start, line.end
    ux, uy = bx - ax, by - ay
    share = ((x - ax) * ux + (y - ay) * uy) / (ux * ux + uy * uy)
    share = 0.0 if share < 0.0 else 1.0 if share > 1.0 else share
    return math.hypot(x - ax - share * ux, y - ay - share * uy)


def _to_arc(arc: Arc, x: float, y: float) -> float:
    cx, cy = arc.centre
    dx, dy = x - cx, y - cy
    # how far round the arc the point's angle lies, from its start in its sweep's sense
    turned = math.atan2(dy, dx) - arc.start_rad
    if arc.sweep_rad < 0.0:
        turned = -turned
    turned %= 2.0 * math.pi
    if turned <= abs(arc.sweep_rad):
        return abs(math.hypot(dx, dy) - arc.radius)
    ends = (arc.geometry(0.0), arc.geometry(arc.length))
    return min(math.hypot(x - e[0], y - e[1]) for e in ends)


def channel_points(layout: GameLayout, spacing_m: float = 0.002) -> np.ndarray:
    """The path game's channel for drawing: (N, 2) centre-line points (m) at most
    `spacing_m` apart; its edges are `layout.channel_half_width_m` either side."""
    return layout.path.points(spacing_m)
