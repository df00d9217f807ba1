"""What a virtual patient does of its own in the assessment tasks (issue 31): it sees the
task's cues on the screen and moves when and how it chooses, not on the reference's clock.

In an exercise a virtual patient follows the trial's reference (device.sim.patients); in
the transparent mode of the reaching and active range tasks nothing moves the hand but the
patient, and what the figures measure is the patient's own timing and path. So the patient
is given its own movement plan (`OwnMovement`), made from the task's cues
(core.assessment.protocol.cues: when each target and the centre appear):

* reaching: at each target's appearance the patient waits its reaction time, then moves
  to the target along a straight minimum-jerk profile (Flash & Hogan 1985, J Neurosci
  5:1688, doi 10.1523/JNEUROSCI.05-07-01688.1985) of its own movement time, holds there,
  and on the centre's appearance returns the same way. A patient who lost effort makes
  the movement of overlapping submovements instead (device.sim.submovements: the weak
  patient's 10 cm reach in three), their shares varied from reach to reach.
* circle drawing: it draws the trial's circle at its own pace, lap after lap, and stops
  when the dot on the screen (which keeps the protocol's pace) stops; a patient who lost
  effort by submovements along the arc, varied from lap to lap (device.sim.submovements.
  OwnLaps).
* active range: at each direction's appearance it moves out along that direction to a
  fraction of the distance the robot and its arm allow there
  (core.assessment.workspace.extent_m), holds, and returns.

The plan then drives the patient's effort exactly as a reference would (impedance,
feed-forward and the push along the plan, scaled by the effort), so a weak patient lags
its own plan as it lags a path, and a passive patient has no effort and never moves.

The timing is this console's model, not identified on people: a healthy reaction time of
0.30 s (simple visual reaction times of young adults are about 0.2–0.3 s), a movement time
growing with distance, 0.35 s + 2.5 s/m (0.6 s for a 10 cm reach: a minimum-jerk peak
speed of 0.31 m/s), both varying from reach to reach by a coefficient of variation of 0.15,
drawn by the trial's seed. A patient of effort w (device.sim.patients: 1 healthy, 0.4 weak)
reacts (0.25 s)(1 − w) later, moves (and laps the circle) 1/(0.5 + 0.5 w) times slower,
and in the range task
goes out to 0.5 + 0.45 w of the allowed distance (healthy 95 %, weak 68 %): slowness and a
reduced active range in proportion to the lost effort, so a population's spread of effort
(device.sim) spreads the figures with it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from core.arrays import groups
from core.assessment.protocol import cues
from core.assessment.workspace import extent_m, range_box
from core.errors import ParameterError, check_range
from core.robot import RobotModel
from core.trajectory import Trajectory, TrajectorySample
from core.trial import TrialParameters
from device.sim.patient_parameters import DEFAULT_EFFORT
from device.sim.submovements import (
    OwnLaps,
    nominal_shares,
    onset_spacing,
    piece_count,
    profile,
)

OWN_MOVEMENT_TASKS = ("reaching", "circle", "range")
"""The tasks whose patient moves on its own plan (the others follow the reference, or the
robot's mode for them decides: circle, strength, position)."""
REACTION_S = 0.30
TASK_OPTIONS = ("reaction_time_s", "speed_scale")
"""Patient options of a subject's own movement (a virtual population's: device.sim.
population), taken here and not by device.sim.patients.make_patient: the healthy reaction
time the effort's slowing adds to (default REACTION_S) and a factor on the movement speed
(default 1; the circle's pace is never faster than the dot's)."""
REACTION_RANGE_S = (0.1, 2.0)
SPEED_SCALE_RANGE = (0.2, 5.0)
REACTION_SLOWING_S = 0.25
MOVE_BASE_S = 0.35
MOVE_PER_M_S = 2.5
VARIATION = 0.15
RANGE_FULL = 0.95
RANGE_LOST = 0.45


@dataclass(frozen=True, slots=True)
class Move:
    """One straight movement from `start_m` to `end_m` over [t0_s, t1_s]: one
    minimum-jerk piece, or submovements of `shares` of the distance whose onsets are
    `spacing` of a piece's duration apart (device.sim.submovements)."""

    t0_s: float
    t1_s: float
    start_m: tuple[float, float]
    end_m: tuple[float, float]
    shares: tuple[float, ...] = (1.0,)
    spacing: float = 1.0


class OwnMovement:
    """A patient's own movement plan: at rest at `home_m`, then `moves` in order, resting
    at each one's end until the next. It answers what device.sim.patients asks of a
    core.trajectory.Trajectory (one traversal lasting the whole trial)."""

    __slots__ = ("duration_s", "home_m", "moves", "repetitions", "total_duration_s")

    def __init__(self, home_m: tuple[float, float], moves: Sequence[Move], total_s: float):
        self.home_m = (float(home_m[0]), float(home_m[1]))
        self.moves = tuple(moves)
        self.duration_s = float(total_s)
        self.total_duration_s = float(total_s)
        self.repetitions = 1

    def sample(self, t_s) -> TrajectorySample:
        """Position, velocity, acceleration and unit direction (zero at rest) at `t_s`."""
        t = np.asarray(t_s, dtype=float).ravel()
        position = np.tile(np.asarray(self.home_m), (t.size, 1))
        velocity = np.zeros((t.size, 2))
        acceleration = np.zeros((t.size, 2))
        direction = np.zeros((t.size, 2))
        segment = np.full(t.size, -1)
        # each sample belongs to the last move begun by then (sorted, never overlapping)
        starts = np.array([move.t0_s for move in self.moves])
        owner = np.searchsorted(starts, t, side="right") - 1
        # each move's samples, in order (core.arrays.groups)
        for k, mine in enumerate(groups(owner, len(self.moves))):
            if not mine.size:
                continue
            move = self.moves[k]
            d = np.subtract(move.end_m, move.start_m)
            length = float(np.hypot(*d))
            unit = d / length if length > 0.0 else np.zeros(2)
            local = t[mine] - move.t0_s
            moving = (local / (move.t1_s - move.t0_s) < 1.0)[:, None]
            s, sd, sdd = profile(local, move.t1_s - move.t0_s, move.shares, move.spacing,
                                 length)
            position[mine] = np.asarray(move.start_m) + s[:, None] * unit
            velocity[mine] = sd[:, None] * unit
            acceleration[mine] = sdd[:, None] * unit
            direction[mine] = np.where(moving, unit, 0.0)
            segment[mine] = k
        finished = (t >= self.total_duration_s) | (t < 0.0)
        velocity[finished] = 0.0
        acceleration[finished] = 0.0
        direction[finished] = 0.0
        return TrajectorySample(t, position, velocity, acceleration, direction, segment,
                                finished.astype(int))

    def at(self, t: float):
        """(x, y, vx, vy, ax, ay, direction x, y) at one time, floats."""
        s = self.sample([t])
        return (*s.position_m[0], *s.velocity_m_s[0], *s.acceleration_m_s2[0],
                *s.direction[0])


def movement_time_s(distance_m: float, effort: float, speed_scale: float = 1.0) -> float:
    """A reach's movement time for a patient of `effort` (the module notes)."""
    return (MOVE_BASE_S + MOVE_PER_M_S * distance_m) / ((0.5 + 0.5 * effort) * speed_scale)


def reaction_time_s(effort: float, healthy_s: float = REACTION_S) -> float:
    return healthy_s + REACTION_SLOWING_S * (1.0 - effort)


def split_options(trial: TrialParameters, options: Mapping[str, object]
                  ) -> tuple[dict, dict]:
    """(make_patient's options, the own movement's: TASK_OPTIONS) of a trial's patient
    options; the own movement's are refused by name for a trial whose patient follows the
    reference, where they would change nothing."""
    own = {k: v for k, v in options.items() if k in TASK_OPTIONS}
    if own and trial.assessment not in OWN_MOVEMENT_TASKS:
        name = next(iter(own))
        raise ParameterError(name, own[name], "no value for this trial",
                             "only the patient's own movement in the "
                             + ", ".join(OWN_MOVEMENT_TASKS) + " tasks has it")
    return {k: v for k, v in options.items() if k not in TASK_OPTIONS}, own


def range_fraction(effort: float) -> float:
    """The share of the allowed distance a patient of `effort` goes out in the range task."""
    return RANGE_FULL - RANGE_LOST * (1.0 - effort)


def own_circle(trial: TrialParameters, effort: float, speed_scale: float = 1.0,
               varied: Callable[[float], float] | None = None) -> Trajectory | OwnLaps:
    """The circle at the patient's own pace: the trial's circle, each lap
    1/((0.5 + 0.5 w)·speed_scale) times the dot's lap (a healthy patient keeps the dot's
    pace), until the dot stops, when the patient comes to rest too
    (device.sim.submovements.OwnLaps); a lap of two submovements or more walked by them,
    each piece's share varied by `varied`."""
    lap_s = trial.duration_s / ((0.5 + 0.5 * effort) * speed_scale)
    stop_s = trial.duration_s * trial.repetitions
    laps = max(1, math.ceil(stop_s / lap_s - 1e-9))
    paced = Trajectory(trial.path(), lap_s, laps, trial.timing)
    pieces = piece_count(paced.path.length, effort)
    if paced.timing != "constant_speed":
        return paced
    if pieces < 2:
        return OwnLaps(paced, None, 1.0, stop_s)
    vary = varied or (lambda value: value)
    shares = [[vary(1.0) for _ in range(pieces)] for _ in range(laps)]
    return OwnLaps(paced, shares, onset_spacing(effort), stop_s)


def own_movement(trial: TrialParameters, kind: str, options: Mapping[str, object],
                 seed, robot: RobotModel) -> OwnMovement | Trajectory | None:
    """The patient's own plan for an assessment trial whose task has one
    (OWN_MOVEMENT_TASKS), None otherwise (the patient follows the reference). `seed` (an
    int or a numpy SeedSequence, the patient's) draws each movement's variation from a
    stream of its own."""
    if trial.assessment not in OWN_MOVEMENT_TASKS:
        return None
    effort = check_range("effort", options.get("effort", DEFAULT_EFFORT.get(kind, 1.0)),
                         0.0, 1.0)
    healthy_reaction = check_range("reaction_time_s", options.get("reaction_time_s",
                                                                  REACTION_S),
                                   *REACTION_RANGE_S, "s")
    speed = check_range("speed_scale", options.get("speed_scale", 1.0), *SPEED_SCALE_RANGE)
    rng = np.random.default_rng(_stream(seed))
    sigma = math.sqrt(math.log1p(VARIATION ** 2))

    def varied(value: float) -> float:
        return value * math.exp(rng.normal(-sigma * sigma / 2.0, sigma))

    if trial.assessment == "circle":
        return own_circle(trial, effort, min(speed, 1.0), varied)

    centre = trial.centre_m
    box = range_box(trial)
    moves: list[Move] = []
    here = centre
    free_at = 0.0
    for cue in cues(trial):
        if cue.kind == "target":
            goal = cue.point_m
            if trial.assessment == "range":
                direction = math.atan2(cue.point_m[1] - centre[1], cue.point_m[0] - centre[0])
                reach = range_fraction(effort) * extent_m(trial, robot, direction, box)
                goal = (centre[0] + reach * math.cos(direction),
                        centre[1] + reach * math.sin(direction))
        else:
            goal = centre
        distance = math.dist(here, goal)
        if distance < 1e-6:
            continue
        t0 = max(cue.time_s + varied(reaction_time_s(effort, healthy_reaction)), free_at)
        t1 = t0 + varied(movement_time_s(distance, effort, speed))
        pieces = piece_count(distance, effort)
        # one piece draws nothing more (a healthy patient's draws stay what they were)
        shares = (tuple(varied(share) for share in nominal_shares(pieces)) if pieces > 1
                  else (1.0,))
        moves.append(Move(t0, t1, here, goal, shares, onset_spacing(effort)))
        here, free_at = goal, t1
    total = trial.duration_s * trial.repetitions
    return OwnMovement(centre, moves, max(total, free_at))


def _stream(seed) -> np.random.SeedSequence:
    """The movements' own stream of the patient's seed (device.sim.patients.trial_factors
    uses spawn key 13; this one 17), so the other draws of a seed stay what they were."""
    if isinstance(seed, np.random.SeedSequence):
        return np.random.SeedSequence(seed.entropy, spawn_key=(*seed.spawn_key, 17))
    return np.random.SeedSequence(int(seed), spawn_key=(17,))
