"""The games' difficulty between rounds: a weighted up-down staircase on an ordered ladder.

Rule. Kaernbach's weighted up-down (Kaernbach 1991, Percept Psychophys 49:227): after a
success the difficulty goes up by S_up, after a failure down by S_down, with
S_down / S_up = p / (1 − p); the expected change is zero where the success rate is p, so it
converges to any chosen p (here TARGET_SUCCESS = 0.70, the rate clinics aim for: Metzger et
al. 2014, J NeuroEng Rehabil 11:154; Levitt's 2-down-1-up converges to 70.7 %). We use it
rather than Levitt's transformed up-down (1971, J Acoust Soc Am 49:467) because a round of a
game holds several movements (8 targets, 5 laps): Levitt's rule reads one binary response
per step, so it would either need rounds of one movement or throw away how many of a round's
movements succeeded; Kaernbach's counts every one. In rungs of the ladder: each hit adds
(1 − p) to a credit and each miss takes p away, so a round of h hits and m misses adds
h(1 − p) − m p = n (q − p) for a success rate q = h / n.

Steps. Difficulty is a rung on an ordered ladder (`Dial`s over the trial's variables, each a
row of values from easy to hard; rung k has taken the first k notches of the dials in turn,
the first dial first: help, then time or channel width, then size). Between rounds it moves at
most one rung: up when the credit reaches +1, down when it reaches −1, the rung's worth taken
from the credit; the credit is then kept within ±CREDIT_LIMIT (what that cuts off is kept in
`cut`), so one bad round does not bank several rounds of steps. The books balance exactly:
over N movements of success rate q̄, N (q̄ − p) = Δcredit + Δrung + cut; since the credit and
the rung are bounded, the mean success differs from p by at most (ladder length +
2·CREDIT_LIMIT + |cut|) / N, and the cut grows only at the ladder's ends or while the rung is
still far from the player's (tests/core/games/test_staircase.py checks the books with
hypothesis; tests/app/games/test_staircase_loop.py the convergence on virtual patients).

Lock. The therapist may lock the difficulty: a locked staircase keeps its rung and says so.

State. `Staircase` is plain data (to_json / from_json): the ladder, the rung, the credit, the
lock, the target, the round count and why it is where it is; it travels with each round's
TrialParameters (`staircase`), so after a restart the next round continues from the last
trial's file or registry row (app.games).
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError, check_range
from core.trial import (
    CHANNEL_HALF_WIDTH_RANGE_M,
    DURATION_RANGE_S,
    TARGET_RADIUS_RANGE_M,
    TIME_ALLOWED_RANGE_S,
    TrialParameters,
    target_spacing_s,
)
from core.trial_check import MAX_PATH_SPEED_M_S

TARGET_SUCCESS = 0.70
TARGET_RANGE = (0.5, 0.9)
CREDIT_LIMIT = 2.0
DIAL_FIELDS = ("assistance_level", "time_allowed_s", "target_radius_m",
               "channel_half_width_m", "duration_s", "radius_m")
"""The variables a ladder may turn: help, time allowed, target size, channel width, pace,
distance (all SI, as TrialParameters holds them)."""
HELP_STEPS = (1.0, 0.8, 0.6, 0.4, 0.2, 0.0)
"""The as-needed mode's help, from full to the channel alone."""
TIME_SHARES = (1.0, 0.8, 0.64, 0.51, 0.41, 0.33)
"""The reaching game's time allowed as a share of the time between two targets."""
TARGET_RADII_M = (0.03, 0.024, 0.019, 0.015, 0.012, 0.01, 0.008)
CHANNEL_HALF_WIDTHS_M = (0.04, 0.032, 0.025, 0.02, 0.016, 0.012, 0.01, 0.008, 0.006)
"""The path game's channel half-widths, widest first; a path's ladder keeps those that fit
it (`channel_widths`)."""
CHANNEL_SHARE_OF_INSIDE = 2.0 / 3.0
"""The widest channel's half-width as a share of the path's inside half-width (half the
narrower side of the box round the path: r/2 for a D of radius r, r for a circle or a
loop of the figure eight): the channel's two inner edges leave a third of the inside
between them, so a hand cutting across the inside leaves the channel. At 4 cm either
side whatever the path, the first rung covered the whole inside of a 6 cm D (3 cm from
the path at most): it could not be lost."""
NO_INSIDE_M = 0.001
"""A path whose box is narrower than this has no inside (the straight reach, out and back
on one line): its channel is not bounded by one."""
PACE_SHARES = (1.0, 0.85, 0.72, 0.61)
"""The path game's traversal time as a share of the prescribed one."""


@dataclass(frozen=True, slots=True)
class Dial:
    """One variable of the ladder: its TrialParameters field and its values, easiest
    first (SI)."""

    field: str
    values: tuple[float, ...]

    def __post_init__(self) -> None:
        if self.field not in DIAL_FIELDS:
            raise ParameterError("dial", self.field, "one of " + ", ".join(DIAL_FIELDS))
        values = tuple(self.values)
        if not values or not all(isinstance(v, int | float) and not isinstance(v, bool)
                                 and math.isfinite(v) for v in values):
            raise ParameterError(self.field, self.values, "one or more finite values")
        object.__setattr__(self, "values", tuple(float(v) for v in values))


@dataclass(frozen=True, slots=True)
class Staircase:
    """Where a game's difficulty stands (see the module docstring)."""

    ladder: tuple[Dial, ...]
    rung: int = 0
    credit: float = 0.0
    locked: bool = False
    target: float = TARGET_SUCCESS
    rounds: int = 0
    why: str = "the first round, at the rung given"
    cut: float = 0.0
    """The credit the ±CREDIT_LIMIT bound has cut off so far (signed, rungs)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "ladder", tuple(
            d if isinstance(d, Dial) else Dial(d[0], tuple(d[1])) for d in self.ladder))
        if not self.ladder:
            raise ParameterError("ladder", (), "at least one dial")
        if isinstance(self.rung, bool) or not isinstance(self.rung, int):
            raise ParameterError("rung", self.rung, f"a whole number in [0, {self.top}]")
        check_range("rung", self.rung, 0, self.top, "", "a rung of the ladder")
        check_range("credit", self.credit, -CREDIT_LIMIT, CREDIT_LIMIT)
        check_range("cut", self.cut, -1e9, 1e9)
        if isinstance(self.rounds, bool) or not isinstance(self.rounds, int) or self.rounds < 0:
            raise ParameterError("rounds", self.rounds, "a whole number >= 0")
        check_range("target", self.target, *TARGET_RANGE, "",
                    "the success rate the difficulty aims for")
        if not isinstance(self.locked, bool):
            raise ParameterError("locked", self.locked, "True or False")
        if not isinstance(self.why, str):
            raise ParameterError("why", self.why, "text")

    @property
    def top(self) -> int:
        """The hardest rung."""
        return sum(len(d.values) - 1 for d in self.ladder)

    def notches(self) -> tuple[int, ...]:
        """How many notches each dial has turned at this rung."""
        return notches_at(self.ladder, self.rung)

    def values(self) -> dict[str, float]:
        """The rung's value of each dial's field."""
        return {d.field: d.values[n] for d, n in zip(self.ladder, self.notches(), strict=True)}

    def apply(self, base: TrialParameters) -> TrialParameters:
        """The round's parameters: the base (the prescription) at this rung, with this
        state recorded in its `staircase` field."""
        return base.replace(**self.values(), staircase=self.to_json())

    def to_dict(self) -> dict:
        return {"ladder": [[d.field, list(d.values)] for d in self.ladder], "rung": self.rung,
                "credit": self.credit, "locked": self.locked, "target": self.target,
                "rounds": self.rounds, "why": self.why, "cut": self.cut}

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), separators=(",", ":"), allow_nan=False)

    @classmethod
    def from_json(cls, text: str) -> Staircase:
        """The state from `to_json`'s text; anything else refused in one line."""
        try:
            values = json.loads(text)
        except (TypeError, ValueError, RecursionError):
            raise ParameterError("staircase", _short(text), "the JSON of a staircase's state",
                                 "it is not JSON") from None
        names = {f.name for f in dataclasses.fields(cls)}
        if not isinstance(values, dict) or set(values) != names:
            raise ParameterError("staircase", _short(text), "an object with "
                                 + ", ".join(sorted(names)))
        ladder = values["ladder"]
        if not isinstance(ladder, list) or not all(
                isinstance(d, list) and len(d) == 2 and isinstance(d[1], list) for d in ladder):
            raise ParameterError("staircase ladder", _short(ladder),
                                 "a list of [field, [values…]]")
        try:
            return cls(**values)
        except TypeError as exc:  # a value of the wrong type inside a dial
            raise ParameterError("staircase", _short(text), "numbers in the dials",
                                 str(exc)) from None


def notches_at(ladder: tuple[Dial, ...], rung: int) -> tuple[int, ...]:
    """The dials' notches at `rung`: the first `rung` notches dealt to the dials in turn,
    skipping a dial once it is at its hardest."""
    turned = [0] * len(ladder)
    left = rung
    while left > 0:
        for i, dial in enumerate(ladder):
            if left and turned[i] < len(dial.values) - 1:
                turned[i] += 1
                left -= 1
    return tuple(turned)


def default_ladder(base: TrialParameters) -> tuple[Dial, ...]:
    """The ladder of the base's game, easiest first: the as-needed mode's help (only where
    the level is the help: core.control.guidance), then the reaching game's time allowed
    (a share of the time between targets at the base's pace) and its target size, or the
    path game's channel width and pace (never faster than the path's speed limit)."""
    ladder = []
    if base.assist == "as-needed":
        ladder.append(Dial("assistance_level", HELP_STEPS))
    if base.game == "reach":
        spacing = target_spacing_s(base.shape, base.duration_s, base.n_targets)
        low, high = TIME_ALLOWED_RANGE_S
        times = sorted({min(high, max(low, round(spacing * s, 3))) for s in TIME_SHARES},
                       reverse=True)
        ladder += [Dial("time_allowed_s", tuple(times)),
                   Dial("target_radius_m", _within(TARGET_RADII_M, TARGET_RADIUS_RANGE_M))]
    elif base.game == "path":
        ladder.append(Dial("channel_half_width_m", channel_widths(base)))
        # the fastest traversal the speed limit allows (core.trial_check.check_trial's rule)
        fastest = max(DURATION_RANGE_S[0],
                      base.trajectory().peak_speed_m_s * base.duration_s / MAX_PATH_SPEED_M_S)
        paces = tuple(round(base.duration_s * s, 3) for s in PACE_SHARES
                      if base.duration_s * s >= fastest)
        if len(paces) > 1:
            ladder.append(Dial("duration_s", paces))
    else:
        raise ParameterError("game", base.game, "'path' or 'reach'",
                             "a staircase sets a game's difficulty")
    return tuple(ladder)


def channel_widths(base: TrialParameters) -> tuple[float, ...]:
    """The path game's channel half-widths on the base's path, widest first: those of
    CHANNEL_HALF_WIDTHS_M within the trial's range and at most CHANNEL_SHARE_OF_INSIDE of
    the path's inside half-width (all of them on a path with no inside), the narrowest
    at least (a path too small for any keeps it)."""
    row = _within(CHANNEL_HALF_WIDTHS_M, CHANNEL_HALF_WIDTH_RANGE_M)
    inside_m = 0.5 * float(np.ptp(base.trajectory().path.points(), axis=0).min())
    if inside_m < NO_INSIDE_M:
        return row
    # to the row's 0.1 mm: the box of points 2 mm apart falls short of the arc's
    # by micrometres, which would drop a 6 cm D's 2 cm
    widest = round(CHANNEL_SHARE_OF_INSIDE * inside_m, 4)
    return tuple(v for v in row if v <= widest) or row[-1:]


def start(base: TrialParameters, *, rung: int = 0, locked: bool = False,
          target: float = TARGET_SUCCESS, ladder: tuple[Dial, ...] | None = None) -> Staircase:
    """A new staircase for the base's game (default_ladder unless one is given)."""
    why = (f"locked by the therapist at rung {rung}" if locked
           else f"the first round, at rung {rung}")
    return Staircase(ladder or default_ladder(base), rung, 0.0, locked, target, 0, why)


def next_round(state: Staircase, hits: int, misses: int) -> Staircase:
    """The staircase after a round of `hits` and `misses` (the game's figures): at most one
    rung on, and why (see the module docstring)."""
    for name, count in (("hits", hits), ("misses", misses)):
        if isinstance(count, bool) or not isinstance(count, int) or count < 0:
            raise ParameterError(name, count, "a whole number >= 0")
    played = f"round {state.rounds + 1}: {hits} hit{'s' * (hits != 1)}, {misses} " \
             f"miss{'es' * (misses != 1)}"
    if state.locked:
        return dataclasses.replace(state, rounds=state.rounds + 1,
                                   why=f"{played}; locked by the therapist at rung "
                                       f"{state.rung}")
    p = state.target
    credit = state.credit + hits * (1.0 - p) - misses * p
    rung = state.rung
    if credit >= 1.0 and rung < state.top:
        rung, credit, moved = rung + 1, credit - 1.0, "one rung harder"
    elif credit <= -1.0 and rung > 0:
        rung, credit, moved = rung - 1, credit + 1.0, "one rung easier"
    elif credit >= 1.0:
        moved = "at the hardest rung"
    elif credit <= -1.0:
        moved = "at the easiest rung"
    else:
        moved = "the same rung"
    kept = min(CREDIT_LIMIT, max(-CREDIT_LIMIT, credit))
    cut, credit = state.cut + (credit - kept), kept
    rate = f" ({100.0 * hits / (hits + misses):.0f} %)" if hits + misses else ""
    why = (f"{played}{rate} against {100.0 * p:.0f} %: credit {credit:+.2f}; {moved} "
           f"(rung {rung} of {state.top})")
    return dataclasses.replace(state, rung=rung, credit=credit, rounds=state.rounds + 1,
                               why=why, cut=cut)


def _within(values: tuple[float, ...], bounds: tuple[float, float]) -> tuple[float, ...]:
    return tuple(v for v in values if bounds[0] <= v <= bounds[1])


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
