"""The staircase between rounds from what the records say: a finished round's parameters
carry the staircase that set them (TrialParameters.staircase) and its metrics the round's
hits and misses, so the next round follows from the last trial's file or registry row alone,
after a restart too."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

from app.errors import AppError
from core.games.staircase import Staircase, next_round, start
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


def staircase_rounds(*, rung: int = 0, locked: bool = False) -> Callable[
        [TrialParameters, Sequence[Mapping[str, float]]], TrialParameters]:
    """A game block's rounds with the staircase between them, as the plan's runner asks
    (app.plans.runner.NextRound: the round's parameters as the block gives them, the figures
    of the block's rounds so far -> the parameters to run). The staircase is replayed from
    the block's rounds (a new one at `rung`, locked or not, then `next_round` with each
    round's game_hits and game_misses; a round without game figures moves nothing), so the
    runner keeps no state of its own and the same rounds always give the same difficulty. A
    block without a game runs as it is."""

    def next_for(parameters: TrialParameters,
                 rounds_so_far: Sequence[Mapping[str, float]]) -> TrialParameters:
        if not parameters.game:
            return parameters
        state = start(parameters, rung=rung, locked=locked)
        for figures in rounds_so_far:
            hits, misses = figures.get("game_hits"), figures.get("game_misses")
            if hits is None or misses is None or not (math.isfinite(hits)
                                                      and math.isfinite(misses)):
                continue
            state = next_round(state, int(hits), int(misses))
        return state.apply(parameters)

    return next_for
