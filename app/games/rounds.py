"""The staircase between rounds from what the records say: a finished round's parameters
carry the staircase that set them (TrialParameters.staircase) and its metrics the round's
hits and misses, so the next round follows from the last trial's file or registry row alone,
after a restart too."""

from __future__ import annotations

import math
from collections.abc import Mapping

from app.errors import AppError
from core.games.staircase import Staircase, next_round
from core.trial import TrialParameters


def next_staircase(parameters: TrialParameters, metrics: Mapping[str, float]) -> Staircase:
    """The staircase for the round after the one these parameters and metrics describe.
    AppError in one line when the round had no staircase or no game figures (a trial
    stopped before its figures could be measured: play the round again at the same rung)."""
    if not parameters.staircase:
        raise AppError("the trial's difficulty was not set by a staircase "
                       "(its parameters have no 'staircase'): start one for the next round")
    state = Staircase.from_json(parameters.staircase)
    hits, misses = metrics.get("game_hits"), metrics.get("game_misses")
    if hits is None or misses is None or not (math.isfinite(hits) and math.isfinite(misses)):
        raise AppError("the trial has no game figures (game_hits, game_misses): "
                       "play the round again at the same difficulty")
    return next_round(state, int(hits), int(misses))
