"""A game round compares with an earlier trial only at the same game and difficulty (seen in
the window: the reaching game's third round, given 1.2 s a target where the second had
1.5 s, was called "worse" on the patient's page for leading 89 % of the time, not 93 %)."""

from __future__ import annotations

import pytest
from hypothesis import given, strategies as st

from app.reports.compare import Baseline, compare
from app.trials.assistance_timeline import AssistanceInEffect
from core.trial import THESIS_SUBJECT

LEVELS = AssistanceInEffect(((0.0, 0.8),))
REACH = THESIS_SUBJECT.replace(shape="targets", game="reach", assist="as-needed",
                               assistance_level=0.8, time_allowed_s=1.5,
                               target_radius_m=0.03, repetitions=1, duration_s=12.0)
PATH = THESIS_SUBJECT.replace(game="path", assist="transparent", assistance_level=0.0,
                              channel_half_width_m=0.04, duration_s=6.0)
BEFORE = {"led_pct": 93.0, "rmse_x_m": 0.016, "rmse_y_m": 0.001,
          "shoulder_rom_rad": 0.4, "elbow_rom_rad": 0.6}
AFTER = {"led_pct": 89.0, "rmse_x_m": 0.015, "rmse_y_m": 0.001,
         "shoulder_rom_rad": 0.4, "elbow_rom_rad": 0.58}


def _compared(before, after):
    levels = AssistanceInEffect(((0.0, after.assistance_level),))
    baseline = Baseline(BEFORE, before.to_dict(), 1, 5,
                        levels=AssistanceInEffect(((0.0, before.assistance_level),)))
    return compare("previous trial", baseline, AFTER, after, levels=levels)


@pytest.mark.parametrize(("before", "after", "words"), [
    (REACH, REACH.replace(time_allowed_s=1.2), "gave less time to reach a target (1.20 s; "
                                               "before, 1.50 s)"),
    (REACH, REACH.replace(target_radius_m=0.024), "had smaller targets (radius 2.4 cm; "
                                                  "before, 3.0 cm)"),
    (REACH, REACH.replace(n_distractors=2), "had more crossed-out circles"),
    (PATH, PATH.replace(channel_half_width_m=0.032), "had a narrower channel (3.2 cm either "
                                                     "side of the path; before, 4.0 cm)"),
    (PATH.replace(game=""), PATH, "This trial was the path game (before, the exercise "
                                  "without a game)"),
    (REACH, REACH.replace(game=""), "(before, the reaching game)"),
], ids=["time-allowed", "target-size", "distractors", "channel", "game-vs-none", "none-vs-game"])
def test_another_game_or_difficulty_is_not_compared(before, after, words):
    comparison = _compared(before, after)
    assert not comparison.comparable
    assert any(words in caution for caution in comparison.cautions), comparison.cautions
    assert comparison.changes
    assert {change.verdict for change in comparison.changes} == {""}


@given(game=st.sampled_from([REACH, PATH]), rung=st.integers(0, 3))
def test_the_same_game_at_the_same_difficulty_compares(game, rung):
    # the staircase's dials as one rung sets them, the same on both rounds
    parameters = game.replace(time_allowed_s=1.5 * 0.8 ** rung,
                              channel_half_width_m=0.04 * 0.8 ** rung)
    comparison = _compared(parameters, parameters)
    assert comparison.comparable, comparison.cautions
    assert "" not in {change.verdict for change in comparison.changes}
