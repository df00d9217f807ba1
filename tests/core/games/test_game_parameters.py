"""The game's fields on TrialParameters: one-line refusals, old files read as no game."""

import math

import pytest

from core.errors import ParameterError
from core.trial import TrialParameters

REACH = dict(game="reach", shape="targets", duration_s=8.0)


@pytest.mark.parametrize(("changes", "field", "says"), [
    (dict(game="pong"), "game", "'' (no game), 'path' or 'reach'"),
    (dict(game=None), "game", "'path' or 'reach'"),
    (dict(target_radius_m=0.001), "target_radius_m", "[0.005, 0.08] m"),
    (dict(target_radius_m=math.nan), "target_radius_m", "a finite number"),
    (dict(target_radius_m="2 cm"), "target_radius_m", "a number"),
    (dict(channel_half_width_m=0.2), "channel_half_width_m", "[0.003, 0.08] m"),
    (dict(channel_half_width_m=True), "channel_half_width_m", "a number"),
    (dict(time_allowed_s=0.05), "time_allowed_s", "[0.2, 30] s"),
    (dict(time_allowed_s=math.inf), "time_allowed_s", "a finite number"),
    (dict(n_distractors=-1), "n_distractors", "[0, 8]"),
    (dict(n_distractors=1.5), "n_distractors", "a whole number"),
    (dict(game="reach", shape="d"), "shape", "targets, reach with game 'reach'"),
    (dict(REACH, time_allowed_s=1.5), "time_allowed_s", "at most 1 s"),
    (dict(REACH, shape="reach", n_distractors=3), "n_distractors", "at most 2"),
    (dict(REACH, n_targets=4, duration_s=4.0, n_distractors=5), "n_distractors", "at most 4"),
])
def test_a_bad_game_field_is_refused_in_one_line(changes, field, says):
    with pytest.raises(ParameterError) as refused:
        TrialParameters(**changes)
    message = str(refused.value)
    assert refused.value.field == field
    assert says in message
    assert "\n" not in message


def test_the_reaching_games_time_is_checked_only_for_that_game():
    # the path game and no game ignore the reaching game's window
    TrialParameters(game="path", time_allowed_s=3.0)
    TrialParameters(time_allowed_s=3.0)
    p = TrialParameters(**REACH, time_allowed_s=1.0)  # 8 targets in 8 s: one a second
    assert p.time_allowed_s == 1.0


def test_a_file_from_before_the_games_reads_as_no_game():
    old = TrialParameters().to_dict()
    for name in ("game", "target_radius_m", "channel_half_width_m", "time_allowed_s",
                 "n_distractors"):
        del old[name]
    assert TrialParameters.from_dict(old).game == ""


def test_game_fields_round_trip():
    p = TrialParameters(**REACH, time_allowed_s=0.8, target_radius_m=0.015, n_distractors=4)
    assert TrialParameters.from_dict(p.to_dict()) == p
