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
  `TOLERANCE_MIN_DEG`);
* at or below `EASIER_AT_PCT` (60 %), one step easier, in the reverse order: a wider
  tolerance back up to the thesis's 20° first, then more assistance, then slower;
* in between, or after a trial that did not complete, the same again.

One change at a time, so that the patient's next figures say what it did. The proposal
names its reason in one line with display units; the registry keeps it and what the
therapist decided (app.records.registry.proposals).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from core.errors import CoreError
from core.trial import DURATION_RANGE_S, TrialParameters, check_trial

HARDER_AT_PCT = 80.0
EASIER_AT_PCT = 60.0
LEVEL_STEP = 0.1
SPEED_STEP = 0.1
TOLERANCE_STEP_DEG = 2.0
TOLERANCE_MIN_DEG = 10.0
TOLERANCE_DEFAULT_DEG = 20.0
TARGET_PCT = 70.0


@dataclass(frozen=True, slots=True)
class Proposal:
    """The next trial's assistance level (0–1), traversal time (s) and tolerance (rad),
    what changed (`change`: "assistance", "speed", "tolerance" or "none") and why."""

    assistance_level: float
    duration_s: float
    tolerance_rad: float
    change: str
    reason: str

    def applied_to(self, parameters: TrialParameters) -> TrialParameters:
        return parameters.replace(assistance_level=self.assistance_level,
                                  duration_s=self.duration_s, tolerance_rad=self.tolerance_rad)

    def to_dict(self) -> dict:
        return {"assistance_level": self.assistance_level, "duration_s": self.duration_s,
                "tolerance_rad": self.tolerance_rad, "change": self.change,
                "reason": self.reason}

    @classmethod
    def from_dict(cls, values: dict) -> Proposal:
        return cls(float(values["assistance_level"]), float(values["duration_s"]),
                   float(values["tolerance_rad"]), str(values["change"]),
                   str(values["reason"]))


def success(parameters: TrialParameters, metrics: dict) -> tuple[float, str]:
    """The figure the difficulty aims at 70 % of, and its words: in the thesis mode the
    directional performance; in the as-needed mode the share of the exercise the patient
    led (the module notes say why)."""
    if parameters.assist == "as-needed":
        pct = float(metrics.get("led_pct", math.nan))
        return pct, f"kept up without help {pct:.0f} % of the time"
    pct = float(metrics.get("directional_performance_pct", math.nan))
    return pct, f"pushed the right way {pct:.0f} % of the time"


def propose(parameters: TrialParameters, metrics: dict, status: str) -> Proposal:
    """The proposal after a trial run with `parameters`, its `metrics` (TrialMetrics'
    names) and `status`."""
    level, duration, tolerance = (parameters.assistance_level, parameters.duration_s,
                                  parameters.tolerance_rad)

    def same(reason: str) -> Proposal:
        return Proposal(level, duration, tolerance, "none", reason)

    if status != "complete":
        return same(f"the trial did not complete ({status.replace('_', ' ')}): "
                    "the same again")
    pct, shown = success(parameters, metrics)
    if not math.isfinite(pct):
        return same("no figure to go by was measured: the same again")
    if EASIER_AT_PCT < pct < HARDER_AT_PCT:
        return same(f"{shown}, near the {TARGET_PCT:.0f} % aimed at: the same again")
    if pct >= HARDER_AT_PCT:
        if level > 0.0:
            new = round(max(0.0, level - LEVEL_STEP), 2)
            return Proposal(new, duration, tolerance, "assistance",
                            f"{shown}: less assistance, {level:.0%} → {new:.0%}")
        faster = round(duration * (1.0 - SPEED_STEP), 2)
        if faster >= DURATION_RANGE_S[0] and _reachable(parameters.replace(duration_s=faster)):
            return Proposal(level, faster, tolerance, "speed",
                            f"{shown} with no assistance: faster, {duration:g} s → "
                            f"{faster:g} s per traversal")
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
    if level < 1.0:
        new = round(min(1.0, level + LEVEL_STEP), 2)
        return Proposal(new, duration, tolerance, "assistance",
                        f"{shown}: more assistance, {level:.0%} → {new:.0%}")
    slower = round(min(DURATION_RANGE_S[1], duration * (1.0 + SPEED_STEP)), 2)
    if slower > duration:
        return Proposal(level, slower, tolerance, "speed",
                        f"{shown} with full assistance: slower, {duration:g} s → "
                        f"{slower:g} s per traversal")
    return same(f"{shown} at the easiest settings: the same again")


def _reachable(parameters: TrialParameters) -> bool:
    """Whether a faster trial is still allowed (its peak speed among the limits)."""
    try:
        return check_trial(parameters).ok
    except CoreError:
        return False
