"""The next round from the last round's records alone (a restart continues the staircase)."""

import json

import pytest

from app.errors import AppError
from app.games.rounds import next_staircase, staircase_rounds
from core.games.staircase import Staircase, next_round, start
from core.trial import TrialParameters

BASE = TrialParameters(game="reach", shape="targets", duration_s=12.0, assist="as-needed")


def test_the_next_round_follows_from_the_stored_parameters_and_metrics():
    state = next_round(start(BASE, rung=4), 8, 0)
    played = TrialParameters.from_dict(json.loads(json.dumps(state.apply(BASE).to_dict())))
    metrics = {"game_hits": 3.0, "game_misses": 5.0, "rmse_x_m": 0.01}
    after = next_staircase(played, metrics)
    assert after == next_round(state, 3, 5)
    assert after.rounds == 2


@pytest.mark.parametrize(("parameters", "metrics", "says"), [
    (BASE, {"game_hits": 1.0, "game_misses": 1.0}, "not set by a staircase"),
    (start(BASE).apply(BASE), {}, "no game figures"),
    (start(BASE).apply(BASE), {"game_hits": float("nan"), "game_misses": 1.0},
     "no game figures"),
])
def test_a_round_without_a_staircase_or_figures_is_said_in_one_line(parameters, metrics, says):
    with pytest.raises(AppError, match=says) as refused:
        next_staircase(parameters, metrics)
    assert "\n" not in str(refused.value)


def test_the_plans_rounds_replay_the_staircase_from_the_blocks_figures():
    block_round = BASE.replace(repetitions=2)
    rounds = staircase_rounds(rung=2)
    figures = [{"game_hits": 8.0, "game_misses": 0.0, "rmse_x_m": 0.01},
               {"rmse_x_m": 0.02},  # a round stopped before its figures: moves nothing
               {"game_hits": 8.0, "game_misses": 0.0}]
    expected = next_round(next_round(start(block_round, rung=2), 8, 0), 8, 0)
    assert rounds(block_round, figures) == expected.apply(block_round)
    assert rounds(block_round, ()) == start(block_round, rung=2).apply(block_round)
    locked = staircase_rounds(rung=6, locked=True)(block_round, figures)
    assert Staircase.from_json(locked.staircase).rung == 6
    plain = TrialParameters()
    assert rounds(plain, figures) is plain
