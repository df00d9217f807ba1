"""The weighted up-down staircase: its books balance, it moves at most one rung a round, a
lock holds it, its state survives a restart as text, bad states are refused in one line."""

import json

import pytest
from hypothesis import given, strategies as st

from core.errors import ParameterError
from core.games import game_layout
from core.games.layout import distance_to_path
from core.games.staircase import (
    CHANNEL_HALF_WIDTHS_M,
    CREDIT_LIMIT,
    Dial,
    Staircase,
    channel_widths,
    default_ladder,
    next_round,
    notches_at,
    start,
)
from core.trial import TrialParameters
from core.trial_check import MAX_PATH_SPEED_M_S, check_trial

REACH = TrialParameters(game="reach", shape="targets", duration_s=12.0, assist="as-needed",
                        centre_m=(-0.3, 0.35), radius_m=0.08)
PATH = TrialParameters(game="path", duration_s=6.0, assist="as-needed")

rounds = st.lists(st.tuples(st.integers(0, 10), st.integers(0, 10)), max_size=60)


@given(rounds=rounds, rung=st.integers(0, 16), target=st.floats(0.5, 0.9))
def test_the_books_balance_and_the_rung_moves_at_most_one_a_round(rounds, rung, target):
    state = start(REACH, rung=rung, target=target)
    banked = 0.0
    for hits, misses in rounds:
        after = next_round(state, hits, misses)
        assert abs(after.rung - state.rung) <= 1
        assert 0 <= after.rung <= after.top
        assert -CREDIT_LIMIT <= after.credit <= CREDIT_LIMIT
        # with nothing owed, a round of successes never makes it easier, nor one of failures
        # harder (a step owed from before is carried by the credit)
        if misses == 0 and state.credit >= 0:
            assert after.rung >= state.rung
        if hits == 0 and state.credit <= 0:
            assert after.rung <= state.rung
        banked += hits * (1 - target) - misses * target
        state = after
    # N (q − p) = Δcredit + Δrung + cut, exactly as the docstring says
    assert banked == pytest.approx(state.credit + (state.rung - rung) + state.cut, abs=1e-9)
    assert state.rounds == len(rounds)


@given(rounds=rounds)
def test_a_locked_staircase_keeps_its_rung_and_says_so(rounds):
    state = start(REACH, rung=5, locked=True)
    for hits, misses in rounds:
        state = next_round(state, hits, misses)
        assert state.rung == 5
        assert "locked by the therapist" in state.why


def test_a_player_at_the_target_rate_stays_and_one_above_climbs():
    state = start(REACH, rung=4)
    for _ in range(30):  # 7 of 10 every round: the credit stays put
        state = next_round(state, 7, 3)
    assert state.rung == 4
    assert state.credit == pytest.approx(0.0, abs=1e-9)
    for _ in range(3):
        state = next_round(state, 10, 0)
    assert state.rung == 7
    assert "one rung harder" in state.why
    assert "10 hits, 0 misses (100 %)" in state.why


@given(rung=st.integers(0, 40))
def test_rungs_deal_the_notches_in_turn(rung):
    ladder = default_ladder(REACH)
    top = sum(len(d.values) - 1 for d in ladder)
    notches = notches_at(ladder, min(rung, top))
    assert sum(notches) == min(rung, top)
    assert all(0 <= n < len(d.values) for n, d in zip(notches, ladder, strict=True))
    # no dial runs more than one notch ahead of one that still has notches left
    open_dials = [n for n, d in zip(notches, ladder, strict=True) if n < len(d.values) - 1]
    assert not open_dials or max(notches) <= min(open_dials) + 1


def test_every_rung_of_the_default_ladders_is_a_valid_reachable_trial():
    for base in (REACH, PATH, REACH.replace(assist="thesis", shape="reach", duration_s=3.0)):
        state = start(base)
        for rung in range(state.top + 1):
            p = Staircase(state.ladder, rung).apply(base)
            assert check_trial(p).ok, (rung, check_trial(p).problems)
    path = start(PATH)
    hardest = Staircase(path.ladder, path.top).apply(PATH)
    assert hardest.trajectory().peak_speed_m_s <= MAX_PATH_SPEED_M_S
    assert hardest.channel_half_width_m < PATH.channel_half_width_m
    assert [d.field for d in path.ladder] == ["assistance_level", "channel_half_width_m",
                                              "duration_s"]


def test_the_first_channel_fits_the_path_it_is_played_on():
    """A 4 cm channel either side covered the whole inside of a 6 cm D (nowhere inside is
    more than 3 cm from the path): the first rung could not be lost. The widest channel
    is two thirds of the path's inside half-width, so the middle of the D's inside is out
    of it; paths with room keep the row's 4 cm, a straight reach (no inside) the row."""
    small = PATH.replace(shape="d", radius_m=0.06, assist="transparent")
    (dial,) = start(small).ladder[:1]
    assert dial.field == "channel_half_width_m"
    first = Staircase(start(small).ladder, 0).apply(small)
    layout = game_layout(first)
    cx, cy = first.centre_m
    middle = distance_to_path(layout.path, cx + 0.5 * first.radius_m, cy)  # 3 cm
    assert first.channel_half_width_m < middle
    assert first.channel_half_width_m == 0.02  # the row's own value, recorded as played
    assert channel_widths(small)[-1] == CHANNEL_HALF_WIDTHS_M[-1]  # as hard at the end
    for roomy in (small.replace(radius_m=0.15), small.replace(shape="circle"),
                  small.replace(shape="reach")):
        assert channel_widths(roomy) == CHANNEL_HALF_WIDTHS_M, roomy.shape
    tiny = small.replace(radius_m=0.02)  # 1 cm of inside: the narrowest alone
    assert channel_widths(tiny) == CHANNEL_HALF_WIDTHS_M[-1:]


def test_the_state_travels_with_the_rounds_parameters_and_restarts_there():
    state = next_round(next_round(start(REACH, rung=3), 8, 0), 5, 3)
    p = state.apply(REACH)
    again = TrialParameters.from_dict(json.loads(json.dumps(p.to_dict())))
    assert Staircase.from_json(again.staircase) == state
    assert again.target_radius_m == state.values()["target_radius_m"]


@pytest.mark.parametrize("text", [
    "not json", "[]", '{"rung": 1}', "{" * 100000,
    json.dumps({**start(REACH).to_dict(), "rung": 99}),
    json.dumps({**start(REACH).to_dict(), "rung": True}),
    json.dumps({**start(REACH).to_dict(), "ladder": [["colour", [1, 2]]]}),
    json.dumps({**start(REACH).to_dict(), "ladder": [["assistance_level", ["a"]]]}),
    json.dumps({**start(REACH).to_dict(), "ladder": "x"}),
    json.dumps({**start(REACH).to_dict(), "credit": 5.0}),
    json.dumps({**start(REACH).to_dict(), "target": 1.0}),
    json.dumps({**start(REACH).to_dict(), "locked": "no"}),
])
def test_a_bad_staircase_state_is_refused_in_one_line(text):
    with pytest.raises(ParameterError) as refused:
        TrialParameters(staircase=text)
    assert "\n" not in str(refused.value)


def test_bad_rounds_and_games_are_refused():
    with pytest.raises(ParameterError, match="hits"):
        next_round(start(REACH), -1, 3)
    with pytest.raises(ParameterError, match="misses"):
        next_round(start(REACH), 1, 2.5)
    with pytest.raises(ParameterError, match="a staircase sets a game's difficulty"):
        start(TrialParameters())
    with pytest.raises(ParameterError, match="dial"):
        Dial("colour", (1.0,))
