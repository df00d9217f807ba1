"""A session plan: the therapist's prescription for one sitting, as a list of blocks.

A block is one exercise (any shape of core.trajectory.SHAPES, or a game on it:
core.trial.GAMES) done for a number of laps or for an
active time, at an assistance mode and level, a pace (the seconds one lap takes,
`duration_s`) and a tolerance, then a rest. A block runs as `rounds` trials (one for a
plain exercise; a game's rounds, whose difficulty may change between them), each a
trial like any other (registry and trial file).

The dose is counted in *movements* (`MOVEMENTS_PER_LAP`): a point-to-point move out or
back for the reaching shapes (the unit of InMotion's dose, e.g. 1,024 reaching
movements a session: Krebs et al. 2003, Autonomous Robots 15:7), a closed loop for the
D and the circle, one lobe of the figure eight. `movements_in_path` counts the
movements a trial's reference made, from its samples (the same rule on the file as on
the plan: a movement is done when the reference arrives at the point it ends at).

Plain data, SI inside (seconds, radians, metres), validated: every bad value is refused
in one line naming the block and the field (core.errors.ParameterError), and the plan
is built from and written to plain dicts (JSON) with unknown keys refused.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from core.assessment.protocol import without_task
from core.errors import ParameterError, as_number, check_range, check_whole
from core.trajectory import SHAPES
from core.trial import (
    ASSIST_MODES,
    DURATION_RANGE_S,
    GAMES,
    RADIUS_RANGE_M,
    REACH_GAME_SHAPES,
    REPETITIONS_RANGE,
    TOLERANCE_RANGE_RAD,
    TrialParameters,
    level_that_runs,
)
from core.trial_check import SI_UNITS, MessageUnits

BLOCKS_RANGE = (1, 20)
"""A sitting of 20 blocks is already three hours of exercise at their longest."""
ROUNDS_RANGE = (1, 20)
REST_RANGE_S = (0.0, 600.0)
"""Up to ten minutes between blocks; a longer break ends the plan."""
ACTIVE_RANGE_S = (1.0, 3600.0)
"""A block by time: at least a second, at most an hour of exercise."""
NAME_MAX_CHARS = 80


MOVEMENTS_PER_LAP_FIXED = {"d": 1, "circle": 1, "reach": 2, "figure8": 2}
"""Movements in one lap of each shape but the targets (2 per target: out and back)."""


def movements_per_lap(shape: str, n_targets: int = 8) -> int:
    """Movements in one lap of `shape`: a D or a circle is one closed movement, a straight
    reach two (out, back), the figure eight two lobes, the centre-out targets two per
    target (out to it, back home)."""
    if shape == "targets":
        return 2 * int(n_targets)
    return MOVEMENTS_PER_LAP_FIXED[shape]


def movement_ends(parameters: TrialParameters) -> np.ndarray:
    """The points, in the robot's frame (m), where one of the trial's movements ends:
    the path's start for a D and a circle, the far end and the start of a reach, the
    crossing of a figure eight, each target and home of the centre-out."""
    segments = parameters.path().segments
    start = segments[0].geometry(0.0)[:2]
    if parameters.shape in ("d", "circle", "figure8"):
        return np.array([start], dtype=float)
    ends = [seg.geometry(seg.length)[:2] for seg in segments]
    return np.unique(np.round(np.array(ends, dtype=float), 9), axis=0)


def movements_in_path(parameters: TrialParameters, desired_m: np.ndarray,
                      reference_m: np.ndarray | None = None) -> int:
    """The movements the points `desired_m` (N, 2, m, in order: the reference's, or the
    hand's in the transparent mode, app.plans.dose) completed. A movement is done when the
    points turn at its end: they come within `TURN_FRACTION` of the exercise's radius of a
    movement's end point, then leave it by more than `LEAVE_FRACTION` (on to the next
    movement); the last one, after which they stop, when they arrive within
    `ARRIVAL_FRACTION`. A reference
    resting on a point counts once, and the start, where it begins, only once it comes
    back. The turn's margin is the as-needed mode's: its reference follows the hand where
    the path doubles back, so a weak virtual patient's turned 7 mm before a 6 cm reach's
    far end and a passive one's 23 mm (measured on the simulator, seed 3-5), within 40 %
    of its radius (24 mm); a trial stopped on the way to an end counts that movement only
    if it got there.

    The hand's points (`reference_m` given: the reference's, N', 2) end the last movement
    with the turn's margin, as they turn at every other end, once the reference has
    arrived at that end: a hand never settles within 2 % of the radius as the reference
    does. Held to the reference's 2 mm on a 10 cm D, a healthy virtual patient's last lap
    in the transparent mode went uncounted at every pace (it came within 3–4.5 mm, or passed
    by and swung 4 cm on), and a plan of one such lap a round ended "3 of 4 movements"
    although the path game scored the lap clean. Whether the last movement was due is the
    reference's to say: a trial stopped on the way counts it not, wherever the hand is."""
    desired = np.asarray(desired_m, dtype=float)
    if desired.ndim != 2 or desired.shape[1] != 2 or len(desired) == 0:
        return 0
    ends = movement_ends(parameters)
    size = parameters.radius_m
    turn, leave, arrive = (TURN_FRACTION * size, LEAVE_FRACTION * size,
                           ARRIVAL_FRACTION * size)
    # distance from every sample to every end: (N, E)
    distance = np.hypot(desired[:, None, 0] - ends[None, :, 0],
                        desired[:, None, 1] - ends[None, :, 1])
    nearest = np.argmin(distance, axis=1)
    count = 0
    at = int(nearest[0]) if distance[0, nearest[0]] <= turn else -1  # the end it is at
    came = False  # whether it came to `at` (not began there)
    entered = 0  # the sample it came within `turn` of `at`
    for i in range(len(desired)):
        if at >= 0:
            if distance[i, at] > leave:
                count += came  # it turned at this end and went on
                at = -1
            continue
        k = int(nearest[i])
        if distance[i, k] <= turn:
            at, came, entered = k, True, i
    if at >= 0 and came and _arrived(desired[entered:], reference_m, ends[at], arrive):
        count += 1  # the last movement: it stopped at its end
    return count


def _arrived(points: np.ndarray, reference_m: np.ndarray | None, end: np.ndarray,
             arrive: float) -> bool:
    """Whether the last movement, whose points came within the turn's margin of `end`
    and stayed, arrived there: the points themselves within `arrive`, or with the hand's
    points, the reference's last point (movements_in_path)."""
    if reference_m is None:
        return bool(np.hypot(*(points - end).T).min() <= arrive)
    reference = np.asarray(reference_m, dtype=float)
    if reference.ndim != 2 or reference.shape[1] != 2 or len(reference) == 0:
        return False
    return bool(math.dist(reference[-1], end) <= arrive)


TURN_FRACTION = 0.4
"""Within 40 % of the exercise's radius of a movement's end, the reference has turned
there once it leaves (the as-needed mode's reference cuts a reach's turn: see
movements_in_path)."""
LEAVE_FRACTION = 0.6
"""Left once 60 % of the radius away: every end is at least a radius from the next, so
no point is within TURN of one end and LEAVE of none."""
ARRIVAL_FRACTION = 0.02
"""The last movement, where the reference stops: arrived within 2 % of the radius (2 mm
on a 10 cm D; the reference passes each end within one tick's travel, < 1 mm)."""


@dataclass(frozen=True, slots=True)
class Block:
    """One block of a plan. Either `repetitions` (laps per round) or `active_s` (the
    exercise's time per round, s) is given, the other None. `radius_m` None keeps the
    size the patient's setup gives; `game` "" is a plain exercise."""

    shape: str = "d"
    repetitions: int | None = 3
    active_s: float | None = None
    assist: str = "as-needed"
    assistance_level: float = 1.0
    duration_s: float = 4.0
    tolerance_rad: float = math.radians(20.0)
    rest_s: float = 60.0
    rounds: int = 1
    game: str = ""
    radius_m: float | None = None
    name: str = ""

    def __post_init__(self) -> None:
        _choice("shape", self.shape, SHAPES)
        _choice("assist", self.assist, ASSIST_MODES)
        _choice("game", self.game, GAMES)
        if self.game == "reach" and self.shape not in REACH_GAME_SHAPES:
            raise ParameterError("shape", self.shape, "one of " + ", ".join(REACH_GAME_SHAPES)
                                 + " with game 'reach'", "the reaching game's targets are "
                                 "the ends of the layout's reaches")
        if not isinstance(self.name, str) or len(self.name) > NAME_MAX_CHARS or any(
                ord(c) < 32 for c in self.name):
            raise ParameterError("name", self.name, f"text of at most {NAME_MAX_CHARS} "
                                 "characters on one line")
        if (self.repetitions is None) == (self.active_s is None):
            raise ParameterError("repetitions", self.repetitions,
                                 "a number of laps, or active_s a time, not both nor neither",
                                 "a block is done for laps or for minutes")
        for name in ("assistance_level", "duration_s", "tolerance_rad", "rest_s"):
            object.__setattr__(self, name, as_number(name, getattr(self, name)))
        check_range("duration_s", self.duration_s, *DURATION_RANGE_S, "s",
                    "the time one lap takes: the pace")
        check_range("assistance_level", self.assistance_level, 0.0, 1.0, "",
                    "0 = no help, 1 = full help")
        object.__setattr__(self, "assistance_level",
                           level_that_runs(self.assist, self.assistance_level))
        lo, hi = TOLERANCE_RANGE_RAD
        check_range("tolerance_rad", self.tolerance_rad, lo, hi, "rad",
                    f"{math.degrees(lo):.0f}–{math.degrees(hi):.0f}°")
        check_range("rest_s", self.rest_s, *REST_RANGE_S, "s", "the rest after the block")
        check_whole("rounds", self.rounds, *ROUNDS_RANGE)
        object.__setattr__(self, "rounds", int(self.rounds))
        if self.repetitions is not None:
            check_whole("repetitions", self.repetitions, *REPETITIONS_RANGE)
            object.__setattr__(self, "repetitions", int(self.repetitions))
        else:
            object.__setattr__(self, "active_s", as_number("active_s", self.active_s))
            check_range("active_s", self.active_s, *ACTIVE_RANGE_S, "s",
                        "the exercise's time in each round")
            laps = math.ceil(self.active_s / self.duration_s - 1e-9)
            if laps > REPETITIONS_RANGE[1]:
                raise ParameterError("active_s", self.active_s,
                                     f"at most {REPETITIONS_RANGE[1]} laps of "
                                     f"{self.duration_s:g} s", "a slower pace, or fewer "
                                     "minutes: a round is one trial of at most 100 laps")
        if self.radius_m is not None:
            object.__setattr__(self, "radius_m", as_number("radius_m", self.radius_m))
            check_range("radius_m", self.radius_m, *RADIUS_RANGE_M, "m")

    @property
    def laps(self) -> int:
        """Laps in each round: the repetitions, or as many whole laps as fill the active
        time (rounded up: the patient does at least the time prescribed)."""
        if self.repetitions is not None:
            return self.repetitions
        return max(1, math.ceil(self.active_s / self.duration_s - 1e-9))

    def parameters(self, base: TrialParameters) -> TrialParameters:
        """The trial of one round: the patient's setup `base` (body, shoulder, centre,
        controller) with this block's exercise, laps, pace, mode, level, tolerance and
        game (none: a plain exercise, whatever game the form held). A task's trial set up
        in the form is not a setup: its protocol's fields are an exercise's again
        (core.assessment.protocol.without_task)."""
        changes = {"shape": self.shape, "repetitions": self.laps,
                   "duration_s": self.duration_s, "assist": self.assist,
                   "assistance_level": self.assistance_level,
                   "tolerance_rad": self.tolerance_rad, "game": self.game}
        if self.radius_m is not None:
            changes["radius_m"] = self.radius_m
        if not self.game:  # the form's game's own settings go with it
            changes["staircase"] = changes["neglect_side"] = ""
        return without_task(base).replace(**changes)

    def planned_movements(self, n_targets: int = 8) -> int:
        return self.rounds * self.laps * movements_per_lap(self.shape, n_targets)

    def planned_active_s(self) -> float:
        return self.rounds * self.laps * self.duration_s

    def exercise(self) -> tuple[str, str, str]:
        """What makes two blocks the same exercise (a proposal after one applies to the
        next of the same): the shape, the game and the assistance mode."""
        return (self.shape, self.game, self.assist)

    def replace(self, **changes) -> Block:
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, values: dict, where: str = "block") -> Block:
        if not isinstance(values, dict):
            raise ParameterError(where, values, "a mapping of block fields")
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - names)
        if unknown:
            raise ParameterError(f"{where}.{unknown[0]}", values[unknown[0]],
                                 ", ".join(sorted(names)), "unknown block field")
        values = dict(values)
        if "active_s" in values and values["active_s"] is not None \
                and "repetitions" not in values:
            values["repetitions"] = None  # a block by time names only its time
        try:
            return cls(**values)
        except ParameterError as exc:
            raise ParameterError(f"{where}.{exc.field}", exc.value, exc.allowed,
                                 exc.why) from None


@dataclass(frozen=True, slots=True)
class Plan:
    """A session plan: a name and its blocks, in the order they run. The rest after the
    last block is not taken (the plan ends with it)."""

    name: str
    blocks: tuple[Block, ...]

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip() or \
                len(self.name) > NAME_MAX_CHARS or any(ord(c) < 32 for c in self.name):
            raise ParameterError("name", self.name, f"a name of 1–{NAME_MAX_CHARS} "
                                 "characters on one line")
        blocks = tuple(self.blocks)
        if not all(isinstance(b, Block) for b in blocks):
            raise ParameterError("blocks", blocks, "Block values")
        lo, hi = BLOCKS_RANGE
        if not lo <= len(blocks) <= hi:
            raise ParameterError("blocks", len(blocks), f"{lo}–{hi} blocks")
        object.__setattr__(self, "blocks", blocks)

    def with_block(self, index: int, block: Block) -> Plan:
        """This plan with block `index` (0-based) replaced: today's change."""
        if not 0 <= index < len(self.blocks):
            raise ParameterError("block", index + 1, f"1–{len(self.blocks)}",
                                 "the plan's blocks are numbered from 1")
        blocks = list(self.blocks)
        blocks[index] = block
        return Plan(self.name, tuple(blocks))

    def planned_movements(self, n_targets: int = 8) -> int:
        return sum(b.planned_movements(n_targets) for b in self.blocks)

    def planned_active_s(self) -> float:
        return sum(b.planned_active_s() for b in self.blocks)

    def planned_rest_s(self) -> float:
        return sum(b.rest_s for b in self.blocks[:-1])

    def to_dict(self) -> dict:
        return {"name": self.name, "blocks": [b.to_dict() for b in self.blocks]}

    @classmethod
    def from_dict(cls, values: dict) -> Plan:
        if not isinstance(values, dict):
            raise ParameterError("plan", values, "a mapping with name and blocks")
        unknown = sorted(set(values) - {"name", "blocks"})
        if unknown:
            raise ParameterError(f"plan.{unknown[0]}", values[unknown[0]], "name, blocks",
                                 "unknown plan field")
        blocks = values.get("blocks")
        if not isinstance(blocks, list | tuple):
            raise ParameterError("blocks", blocks, "a list of blocks")
        return cls(values.get("name"), tuple(
            Block.from_dict(b, f"block {i + 1}") for i, b in enumerate(blocks)))


def check_plan(plan: Plan, base: TrialParameters, robot=None,
               units: MessageUnits = SI_UNITS) -> tuple[str, ...]:
    """What keeps `plan` from running for the patient whose setup is `base`: each block's
    trial walked by core.trial_check.check_trial (the robot's and the arm's reach, the path's
    speed), one line per block that cannot run, naming it and, when a smaller size would
    run, that size (fitting_radius_m), written in `units` (the window's are the form's own,
    app.units.SCREEN); () when every block can."""
    from core.trial_check import check_trial

    problems = []
    for k, block in enumerate(plan.blocks, 1):
        try:
            found = check_trial(block.parameters(base), robot, units=units).problems
        except ParameterError as exc:
            found = (str(exc),)
        if found:
            line = f"block {k} ({block.name or block.shape}): {found[0]}"
            radius = fitting_radius_m(block, base, robot)
            if radius is not None:  # the size at which it would run, said as a fact:
                # the window's Plan table has no radius to change (rehab plan change has)
                line = f"{line.rstrip('.')}; at a radius of {_size(units, radius)} it fits."
            problems.append(line)
    return tuple(problems)


FIT_STEP_M = 0.005
"""A block too large for the patient is made smaller half a centimetre at a time: the
sizes the Parameters tab's radius field is typed in."""


def fitting_radius_m(block: Block, base: TrialParameters, robot=None) -> float | None:
    """The largest size (radius_m, on the half-centimetre below the block's own, or the
    setup's when the block keeps it) at which `block` runs for the patient whose setup is
    `base`; None when it runs as it is or no size from RADIUS_RANGE_M's smallest up does
    (then its centre or the shoulder must move: check_plan says where)."""
    from core.trial_check import check_trial

    def runs(radius_m: float | None) -> bool:
        try:
            changed = block if radius_m is None else block.replace(radius_m=radius_m)
            return check_trial(changed.parameters(base), robot).ok
        except ParameterError:
            return False

    if runs(None):
        return None
    size = block.radius_m if block.radius_m is not None else base.radius_m
    steps = math.floor((size - RADIUS_RANGE_M[0]) / FIT_STEP_M + 1e-9)
    for k in range(steps, -1, -1):
        radius = round(RADIUS_RANGE_M[0] + k * FIT_STEP_M, 6)
        if radius < size and runs(radius):
            return radius
    return None


def fit_plan(plan: Plan, base: TrialParameters, robot=None,
             units: MessageUnits = SI_UNITS) -> tuple[Plan, tuple[str, ...]]:
    """`plan` (a template) made to fit the patient whose setup is `base`: each block the
    robot or the arm cannot follow made as small as it needs (fitting_radius_m), and one
    line per block so changed, naming it and its new size, in `units`. A block no size
    fits is left as it is; check_plan refuses it, saying what to move."""
    notes = []
    for k, block in enumerate(plan.blocks, 1):
        radius = fitting_radius_m(block, base, robot)
        if radius is None:
            continue
        size = block.radius_m if block.radius_m is not None else base.radius_m
        plan = plan.with_block(k - 1, block.replace(radius_m=radius))
        notes.append(f"block {k} ({block.name or block.shape}): radius "
                     f"{_size(units, radius)}, not {_size(units, size)}, "
                     "to stay within this patient's reach and the robot's")
    return plan, tuple(notes)


def _size(units: MessageUnits, radius_m: float) -> str:
    """A fitted size in `units`, with the one decimal more its half centimetre needs
    ("5.5 cm", "0.055 m") and no more ("5 cm" stays "5.0 cm", not "5.00 cm")."""
    shown = radius_m * units.per_m
    exact = abs(round(shown, units.decimals) - shown) < 1e-9
    return units.of_length(radius_m, 0 if exact else 1)


def _choice(name: str, value: object, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise ParameterError(name, value, "one of " + ", ".join(repr(a) for a in allowed))


