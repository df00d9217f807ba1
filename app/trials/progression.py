"""What the next trial should ask of the patient: a proposal from this trial's figures,
which the therapist accepts or changes (performance-based progressive therapy).

The rule follows MIT-Manus's practice (Krebs et al. 2003, Autonomous Robots 15:7):
between trials, adjust the difficulty from performance so that the patient succeeds
about 70 % of the time (clinical adaptation practice, J NeuroEng Rehabil 11:154).

What counts as success depends on the assistance mode. In the thesis mode it is the
directional performance, the share of the exercise the push pointed within the
tolerance of the path's direction (section 3.6.1): against a stiff tracker on a clock, a
patient's effort shows as force on the handle. In the as-needed mode the robot is
nearly transparent along the path, so a patient's effort shows as motion and the force
on the handle is only what moving the robot takes (often under the 0.25 N the cone test
needs). There, success is the share of the exercise the patient led, with no help from
the robot (`led_pct`). Measured with the virtual patients (bench/progression.py), a
slower path lowered the healthy patient's directional performance in the as-needed mode
(less force), so a rule on it would have made the exercise ever slower; the share led
rises as the path slows, as a measure of success must.

The steps:

* at or above `HARDER_AT_PCT` (80 %), one step harder: less assistance (by
  `LEVEL_STEP`); with none left, faster (the traversal `SPEED_STEP` shorter); at the
  fastest the path allows, a narrower tolerance (by `TOLERANCE_STEP_DEG`, down to
  `TOLERANCE_MIN_DEG`). In the as-needed mode, a patient who led at least
  `HARDLY_HELPED_PCT` (95 %) of the exercise gets faster first, the assistance kept as
  a safety net, and less assistance only at the fastest pace: the robot helped in at
  most 5 % of the exercise, so less of its help would change little. Measured
  (bench/slacking.py, before this rule): the healthy virtual patient led 99 % at every
  level from 100 % to 0, and ten trials of lowering the assistance changed nothing it
  did, while its effort slackened to 77 % of its capability;
* at or below `EASIER_AT_PCT` (60 %), one step easier, in the reverse order: a wider
  tolerance back up to the thesis's 20° first, then more assistance, then slower;
* in between, or after a trial that did not complete, the same again.

The assistance moves as a staircase: each time it turns back (raised after a trial that
lowered it, or lowered after one that raised it) its step is halved, down to
`LEVEL_STEP_MIN` and in whole percent as the form sets it (10, 5, 2 %), so it settles
between two levels instead of swinging between them.
With a fixed 10 % step the weak virtual patient led 85 % of the exercise at 40 % help and
9 % at 30 %, and the proposals alternated between the two for ever (bench/progression.py).
The step travels with the proposal (`level_step`, signed: the change it made), and the
trial that ran with an accepted proposal passes it on (`propose(..., previous=...)`).
The traversal time moves as a staircase too (`speed_step`, the relative change: 10 %,
then 5 %, then 2.5 %). With a fixed 10 % step the wrong-way virtual patient, who keeps up
to about 1.5 s per traversal with full help, was proposed 1.40 s (31 % led) and 1.54 s
in turn for ever (bench/progression.py).

A proposal changes only settings that act in the trial's mode. In the thesis mode the
assistance level hardly acts at all: level 1 against 0 changes the robot's RMS torque over
the exercise by 0.01–0.19 % and the time in the cone by under 0.4 points (four virtual
patients, both plants, seed 0; core.control.assistance says why, docs/validation.md
gives the table), so there the level is never proposed: a harder step is a faster path,
then a narrower tolerance; an easier one a wider tolerance back to 20°, then a slower
path. The level a proposal keeps is the one in effect at the end of the trial's
exercise (app.trials.finalize gives `propose` the parameters as they ran), so a trial the
therapist lowered to 60 % is followed by a step from 60 %, not from its built level.

In the transparent mode (core.control.transparent) the console proposes no change: the
robot adds no help, so there is no level to propose, and no figure it measures is a
success to aim at 70 % of. The push's direction is only what moving the robot takes
(mostly toward the centre of a curve, the hand's acceleration): the healthy virtual
patient, who kept to the thesis's D within 8 mm RMS, pushed within 20° of the path's
direction 45 % of the time (two laps, seed 0, realistic plant), so the thesis mode's rule
would make its path ever slower; and nothing is led or helped. The proposal is "the same
again" and says why: the therapist sets the pace, or a game sets its own difficulty
between rounds (core.games).

One change at a time, so that the patient's next figures say what it did. The proposal
names its reason in one line with display units; the registry keeps it and what the
therapist decided (app.records.registry.proposals).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from app.units import assistance_percent
from core.errors import CoreError
from core.trial import DURATION_DECIMALS, DURATION_RANGE_S, TrialParameters
from core.trial_check import check_trial

HARDER_AT_PCT = 80.0
HARDLY_HELPED_PCT = 95.0
EASIER_AT_PCT = 60.0
LEVEL_STEP = 0.1
LEVEL_STEP_MIN = 0.02
SPEED_STEP = 0.1
SPEED_STEP_MIN = 0.025
TOLERANCE_STEP_DEG = 2.0
TOLERANCE_MIN_DEG = 10.0
TOLERANCE_DEFAULT_DEG = 20.0
TARGET_PCT = 70.0
TRANSPARENT_REASON = ("transparent mode: the robot adds no help, so there is no "
                      "assistance to propose and no success figure to aim at; the same "
                      "again (set the pace yourself, or play a game, whose difficulty "
                      "adapts by itself)")
"""Why a transparent trial's proposal changes nothing (the module notes)."""


@dataclass(frozen=True, slots=True)
class Proposal:
    """The next trial's assistance level (0–1), traversal time (s) and tolerance (rad),
    what changed (`change`: "assistance", "speed", "tolerance" or "none") and why."""

    assistance_level: float
    duration_s: float
    tolerance_rad: float
    change: str
    reason: str
    level_step: float = 0.0
    """The change of the assistance level this proposal makes (signed, 0 when it changes
    something else), from which the next proposal's step follows (the module notes)."""
    speed_step: float = 0.0
    """The relative change of the traversal time this proposal makes (signed: −0.1 is
    10 % shorter, 0 when it changes something else), the speed's staircase."""

    def applied_to(self, parameters: TrialParameters) -> TrialParameters:
        return parameters.replace(assistance_level=self.assistance_level,
                                  duration_s=self.duration_s, tolerance_rad=self.tolerance_rad)

    def to_dict(self) -> dict:
        return {"assistance_level": self.assistance_level, "duration_s": self.duration_s,
                "tolerance_rad": self.tolerance_rad, "change": self.change,
                "reason": self.reason, "level_step": self.level_step,
                "speed_step": self.speed_step}

    @classmethod
    def from_dict(cls, values: dict) -> Proposal:
        # proposals stored before the staircases have no steps: a full step then
        return cls(float(values["assistance_level"]), float(values["duration_s"]),
                   float(values["tolerance_rad"]), str(values["change"]),
                   str(values["reason"]), float(values.get("level_step", 0.0)),
                   float(values.get("speed_step", 0.0)))


def _staircase(direction: int, last: float, full: float, smallest: float, halve) -> float:
    """The next signed step (`direction` −1 or +1) after the signed step `last` (0: none
    yet): the same size again, `halve`d down to `smallest` when it turns back."""
    if last == 0.0:
        return direction * full
    size = abs(last)
    if last * direction < 0:
        size = max(smallest, halve(size))
    return direction * size


def level_step(direction: int, previous: Proposal | None) -> float:
    """The assistance's next change, signed (`direction` −1 less help, +1 more): the last
    step's size again, halved (down to LEVEL_STEP_MIN) when it turns back."""
    last = previous.level_step if previous is not None else 0.0
    # halved in whole percent (the form's unit), so a proposal can be accepted as is
    return _staircase(direction, last, LEVEL_STEP, LEVEL_STEP_MIN,
                      lambda size: math.floor(round(size * 100) / 2) / 100)


def speed_step(direction: int, previous: Proposal | None) -> float:
    """The traversal time's next relative change, signed (`direction` −1 faster, +1
    slower): the last one's size again, halved (down to SPEED_STEP_MIN) when it turns
    back."""
    last = previous.speed_step if previous is not None else 0.0
    return _staircase(direction, last, SPEED_STEP, SPEED_STEP_MIN, lambda size: size / 2)


def success(parameters: TrialParameters, metrics: dict) -> tuple[float, str]:
    """The figure the difficulty aims at 70 % of, and its words: in the thesis mode the
    directional performance; in the as-needed mode the share of the exercise the patient
    led (the module notes say why)."""
    if parameters.assist == "as-needed":
        pct = float(metrics.get("led_pct", math.nan))
        return pct, f"kept up without help {pct:.0f} % of the time"
    pct = float(metrics.get("directional_performance_pct", math.nan))
    return pct, f"pushed the right way {pct:.0f} % of the time"


def propose(parameters: TrialParameters, metrics: dict, status: str,
            previous: Proposal | None = None) -> Proposal:
    """The proposal after a trial run with `parameters` (as it ran: the assistance level
    in effect at the end of its exercise), its `metrics` (TrialMetrics' names) and
    `status`; `previous`, the proposal that trial ran with, if it did, sets the steps (the
    module notes). In the thesis mode the level is kept (it does not act there); in the
    transparent mode nothing changes (the module notes say why)."""
    level, duration, tolerance = (parameters.assistance_level, parameters.duration_s,
                                  parameters.tolerance_rad)

    def same(reason: str) -> Proposal:
        return Proposal(level, duration, tolerance, "none", reason)

    if parameters.assist == "transparent":
        return same(TRANSPARENT_REASON)
    if status != "complete":
        return same(f"the trial did not complete ({status.replace('_', ' ')}): "
                    "the same again")
    pct, shown = success(parameters, metrics)
    if not math.isfinite(pct):
        return same("no figure to go by was measured: the same again")
    if EASIER_AT_PCT < pct < HARDER_AT_PCT:
        return same(f"{shown}, near the {TARGET_PCT:.0f} % aimed at: the same again")
    level_acts = level_acts_in(parameters.assist)
    if pct >= HARDER_AT_PCT:
        def less_assistance() -> Proposal:
            new = round(max(0.0, level + level_step(-1, previous)), 2)
            return Proposal(new, duration, tolerance, "assistance",
                            f"{shown}: less assistance, {assistance_percent(level)} → "
                            f"{assistance_percent(new)}", round(new - level, 2))

        helping = level_acts and level > 0.0
        hardly_helped = parameters.assist == "as-needed" and pct >= HARDLY_HELPED_PCT
        if helping and not hardly_helped:
            return less_assistance()
        step = speed_step(-1, previous)
        faster = paced(duration, step)
        if faster >= DURATION_RANGE_S[0] and _reachable(parameters.replace(duration_s=faster)):
            why = (shown if not level_acts else f"{shown} with no assistance"
                   if level == 0.0 else f"{shown}, so the assistance was hardly needed")
            kept = f" (the assistance stays at {assistance_percent(level)})" if helping else ""
            return Proposal(level, faster, tolerance, "speed",
                            f"{why}: faster, {paces(duration, faster)} per "
                            f"traversal{kept}", speed_step=step)
        if helping:
            return less_assistance()
        narrower = max(TOLERANCE_MIN_DEG, math.degrees(tolerance) - TOLERANCE_STEP_DEG)
        if narrower < math.degrees(tolerance) - 1e-9:
            return Proposal(level, duration, math.radians(narrower), "tolerance",
                            f"{shown} at full speed: a narrower tolerance, "
                            f"{math.degrees(tolerance):.0f}° → {narrower:.0f}°")
        return same(f"{shown} at the hardest settings: the same again")
    # pct <= EASIER_AT_PCT
    if math.degrees(tolerance) < TOLERANCE_DEFAULT_DEG - 1e-9:
        wider = min(TOLERANCE_DEFAULT_DEG, math.degrees(tolerance) + TOLERANCE_STEP_DEG)
        return Proposal(level, duration, math.radians(wider), "tolerance",
                        f"{shown}: a wider tolerance, {math.degrees(tolerance):.0f}° → "
                        f"{wider:.0f}°")
    if level_acts and level < 1.0:
        new = round(min(1.0, level + level_step(+1, previous)), 2)
        return Proposal(new, duration, tolerance, "assistance",
                        f"{shown}: more assistance, {assistance_percent(level)} → "
                        f"{assistance_percent(new)}", round(new - level, 2))
    step = speed_step(+1, previous)
    slower = min(DURATION_RANGE_S[1], paced(duration, step))
    if slower > duration:
        helped = " with full assistance" if level_acts else ""
        return Proposal(level, slower, tolerance, "speed",
                        f"{shown}{helped}: slower, {paces(duration, slower)} per "
                        "traversal", speed_step=step)
    return same(f"{shown} at the easiest settings: the same again")


def paced(duration_s: float, step: float) -> float:
    """The traversal time `duration_s`·(1 + `step`) in the form's resolution
    (DURATION_DECIMALS), at least one of its steps away from `duration_s` in the step's
    direction. The form kept tenths of a second and a proposal hundredths: a proposal of
    4.05 s was taken as 4.0 s, ran as 4.0 s and was recorded as changed by the therapist,
    not as taken."""
    scale = 10 ** DURATION_DECIMALS
    units = round(duration_s * (1.0 + step) * scale)
    if units == round(duration_s * scale):
        units += 1 if step > 0 else -1
    return units / scale


def paces(before_s: float, after_s: float) -> str:
    """'4.5 s → 4.05 s': a pace's change in the words of a proposal, each as the Parameters
    form keeps it (DURATION_DECIMALS: `paced`), so what is said is what is applied."""
    return f"{before_s:g} s → {after_s:g} s"


def level_acts_in(assist: str) -> bool:
    """Whether the assistance level acts in this mode enough to be proposed: in the
    as-needed mode it sets the help along the path; in the thesis mode it scales a cut the
    sign rule all but forbids; the transparent mode has none (the module notes)."""
    return assist == "as-needed"


def _reachable(parameters: TrialParameters) -> bool:
    """Whether a faster trial is still allowed (its peak speed among the limits)."""
    try:
        return check_trial(parameters).ok
    except CoreError:
        return False
