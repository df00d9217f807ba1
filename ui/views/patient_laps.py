"""A lap of a plain exercise judged for the patient's screen, without Qt: whether the hand
followed the path (`round_travelled`, the path game's rule), how close it kept
(`round_quality`), and the words the screen says for it (`lap_words`): the result first,
then its quality (knowledge of results, then of performance), in words, not millimetres,
as the screen shows no clinical figure the therapist has not chosen."""

from __future__ import annotations

import math

import numpy as np

from core.games.layout import distance_to_path
from core.games.scoring import COVERAGE
from core.trial import TrialParameters
from ui.views.trialview import TrialView

QUALITY_POINTS = 50
"""Samples of a lap its quality is judged on, spread evenly over it (one judgement per
frame, cheap at 60 frames a second)."""
QUALITY_WORDS = ((0.005, "Right on the path"), (0.015, "Close to the path"))
"""The hand's RMS distance from the path over a lap (m) at most which each is said: 5 mm
is the thesis subject's tracking with the robot's help (8.68 / 7.02 mm RMSE, section 3.6,
is a whole healthy trial's), 15 mm a third of the D's width off it."""
QUALITY_ELSE = "Stay closer to the path"
QUALITY_STILL = "Now follow the whole path"
QUALITY_STILL_LAST = "next time, follow the whole path"
"""A lap whose hand moved less than COVERAGE of the path's length: still at the start,
it is on the path, but did not follow it (a relaxed hand in the transparent mode, which
nothing moves); said in white, not as a success."""


def lap_judged(view: TrialView, p: TrialParameters, t0: float, n: int) -> str | None:
    """Lap `n`'s quality in words ("" when it cannot be judged), or None when the hand did
    not follow the path (`round_travelled`): a success is a lap whose hand followed it."""
    span = (t0 + (n - 1) * p.duration_s, t0 + n * p.duration_s)
    if round_travelled(view, p, *span):
        return round_quality(view, p, *span)
    return None


def lap_words(n: int, quality: str | None, last: bool) -> str:
    """Lap `n`'s result as the screen says it: done with its `quality` ("" when it could
    not be judged), or not followed (None). At the trial's end with the lap's number
    ("Lap 3 done! Right on the path", on two lines if need be); during the next lap
    without it, on one line at the screen's letter size: the top band says which lap is
    under way, and the table's foot is watched. With the number ("Lap 12 done! Stay
    closer to the path", "Lap 1 over: now follow the whole path") it was shrunk to 16 mm,
    not 20, full screen on 22 inches."""
    if last:
        if quality is None:
            return f"Lap {n} over: {QUALITY_STILL_LAST}"
        return f"Lap {n} done!" + (f" {quality}" if quality else "")
    if quality is None:
        return QUALITY_STILL
    return "Done!" + (f" {quality}" if quality else "")


def round_travelled(view: TrialView, parameters: TrialParameters, start_s: float,
                    end_s: float) -> bool:
    """The hand moved at least COVERAGE of the path's length between `start_s` and
    `end_s` (trial clock), the path game's rule for a lap that counts
    (core.games.scoring); True when the view holds too little of the round to judge."""
    a, b = np.searchsorted(view.time, [start_s, end_s])
    if b - a < 2:
        return True
    position = view.column("position")[:, a:b]
    steps = np.diff(position, axis=1)
    moved = float(np.nansum(np.hypot(steps[0], steps[1])))
    return moved >= COVERAGE * parameters.path().length


def round_quality(view: TrialView, parameters: TrialParameters, start_s: float,
                  end_s: float) -> str:
    """The quality of the round between `start_s` and `end_s` (trial clock) in words: the
    hand's RMS distance from the path (core.games.layout.distance_to_path, the path game's
    formula) over QUALITY_POINTS of its samples, against QUALITY_WORDS; "" when the view
    holds too little of the round to judge."""
    a, b = np.searchsorted(view.time, [start_s, end_s])
    if b - a < 2:
        return ""
    picks = np.linspace(a, b - 1, min(QUALITY_POINTS, b - a)).astype(int)
    position = view.column("position")[:, picks]
    finite = np.isfinite(position).all(axis=0)
    if not finite.any():
        return ""
    path = parameters.path()
    off = [distance_to_path(path, float(x), float(y)) for x, y in position[:, finite].T]
    rms = math.sqrt(sum(d * d for d in off) / len(off))
    for most, words in QUALITY_WORDS:
        if rms <= most:
            return words
    return QUALITY_ELSE
