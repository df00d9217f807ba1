"""The games' rules: hits, misses, score and time, the same live in any chunking as from
the whole arrays."""

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from core.games import GameScorer, game_layout, score_game
from core.games.scoring import (
    COVERAGE,
    DISTRACTOR_POINTS,
    HIT_POINTS,
    LAP_POINTS,
    POINTS_PER_S_OUTSIDE,
)
from core.trial import TrialParameters

PERIOD_S = 0.002
REACH = TrialParameters(game="reach", shape="targets", n_targets=4, duration_s=4.0,
                        repetitions=2, time_allowed_s=1.0, timing="minimum_jerk",
                        n_distractors=2)
PATH = TrialParameters(game="path", shape="d", duration_s=4.0, repetitions=3,
                       channel_half_width_m=0.01)


def reference(p: TrialParameters, lag_s: float = 0.0, start_s: float = 0.0):
    """Tick times of the exercise on a trial clock starting at `start_s`, and the robot's
    reference `lag_s` late (a hand that follows it)."""
    total = p.duration_s * p.repetitions
    t = np.arange(round(total / PERIOD_S)) * PERIOD_S
    position = p.trajectory().sample(np.maximum(t - lag_s, 0.0)).position_m
    return t + start_s, position[:, 0].copy(), position[:, 1].copy()


def test_a_hand_on_the_reference_hits_every_target():
    figures = score_game(game_layout(REACH), *reference(REACH))
    assert (figures.hits, figures.misses, figures.touches) == (8, 0, 0)
    assert figures.score == 8 * HIT_POINTS
    assert figures.success == 1.0
    assert figures.time_s == pytest.approx(8.0)
    # a minimum-jerk reach of 0.5 s enters a 2 cm disc 10 cm away late in its course
    assert 0.2 < figures.mean_time_to_hit_s < 0.5
    assert [o.index for o in figures.outcomes] == list(range(8))


def test_a_hand_too_slow_misses_and_one_still_at_home_misses_all():
    t, x, y = reference(REACH, lag_s=1.2)  # reaches each target after its window closed
    assert score_game(game_layout(REACH), t, x, y).hits == 0
    still = score_game(game_layout(REACH), t, np.full_like(x, REACH.centre_m[0]),
                       np.full_like(y, REACH.centre_m[1]))
    assert (still.hits, still.misses, still.score) == (0, 8, 0.0)
    assert math.isnan(still.mean_time_to_hit_s)
    assert still.success == 0.0


def test_each_entry_into_a_distractor_costs_points():
    layout = game_layout(REACH)
    disc = layout.distractors[0]
    home = REACH.centre_m
    t = np.arange(400) * PERIOD_S
    # in and out of the first distractor twice, staying home otherwise
    inside = ((t >= 0.1) & (t < 0.2)) | ((t >= 0.5) & (t < 0.6))
    x = np.where(inside, disc.centre_m[0], home[0])
    y = np.where(inside, disc.centre_m[1], home[1])
    figures = score_game(layout, t, x, y)
    assert figures.touches == 2
    assert figures.score == -2 * DISTRACTOR_POINTS


def test_a_hand_on_the_path_completes_every_lap_and_one_still_completes_none():
    layout = game_layout(PATH)
    figures = score_game(layout, *reference(PATH))
    assert (figures.hits, figures.misses, figures.points_lost) == (3, 0, 0.0)
    assert figures.score == 3 * LAP_POINTS
    t, x, y = reference(PATH)
    still = score_game(layout, t, np.full_like(x, x[0]), np.full_like(y, y[0]))
    assert (still.hits, still.misses, still.time_outside_s) == (0, 3, 0.0), \
        "inside the channel but not moving along it is not a lap"
    assert COVERAGE > 0.5


def test_time_outside_the_channel_costs_points_and_the_lap():
    layout = game_layout(PATH)
    t, x, y = reference(PATH)
    # pushed 3 cm off the path (beyond the 1 cm half-width) for 0.5 s of the second lap
    off = (t >= 5.0) & (t < 5.5)
    x = np.where(off, x - 0.03, x)  # away from the D's arc: 3 cm from every part of it
    figures = score_game(layout, t, x, y)
    assert (figures.hits, figures.misses) == (2, 1)
    assert figures.outcomes[1].hit is False
    assert figures.time_outside_s == pytest.approx(0.5, abs=2 * PERIOD_S)
    assert figures.points_lost == pytest.approx(POINTS_PER_S_OUTSIDE * figures.time_outside_s)
    assert figures.score == pytest.approx(2 * LAP_POINTS - figures.points_lost)


def test_the_clock_starts_at_the_exercise_and_other_phases_are_not_played():
    t, x, y = reference(REACH, start_s=1.5)
    approach = np.arange(0.0, 1.5, PERIOD_S)
    hold = t[-1] + PERIOD_S * np.arange(1, 200)
    home = REACH.centre_m
    # during the approach and the hold the hand sits on target 0: no hit may come of it
    target = game_layout(REACH).targets[0].centre_m
    all_t = np.concatenate((approach, t, hold))
    all_x = np.concatenate((np.full(approach.size, target[0]), x, np.full(hold.size, home[0])))
    all_y = np.concatenate((np.full(approach.size, target[1]), y, np.full(hold.size, home[1])))
    phase = np.concatenate((np.ones(approach.size), np.full(t.size, 2), np.full(hold.size, 3)))
    shifted = score_game(game_layout(REACH), all_t, all_x, all_y, phase)
    alone = score_game(game_layout(REACH), *reference(REACH))
    assert (shifted.hits, shifted.misses, shifted.score) == (alone.hits, alone.misses, 8 * 10)
    # the same samples, their times shifted by 1.5 s and back (rounding only)
    assert shifted.mean_time_to_hit_s == pytest.approx(alone.mean_time_to_hit_s, abs=1e-9)
    assert shifted.time_s == pytest.approx(alone.time_s)


def test_a_stopped_trial_scores_only_the_windows_it_played():
    t, _x, _y = reference(REACH)
    stop = t < 2.3  # targets 0 and 1 played (open 0-1 s and 1-2 s), target 2 open at the stop
    still = score_game(game_layout(REACH), t[stop], np.full(stop.sum(), REACH.centre_m[0]),
                       np.full(stop.sum(), REACH.centre_m[1]))
    assert (still.hits, still.misses) == (0, 2)
    assert still.time_s == pytest.approx(2.3, abs=2 * PERIOD_S)


def test_the_live_state_says_the_current_target_and_time_left():
    scorer = GameScorer(game_layout(REACH))
    t, x, y = reference(REACH)
    state = scorer.feed(t[:10], np.full(10, REACH.centre_m[0]), np.full(10, REACH.centre_m[1]))
    assert state.started
    assert state.current == 0
    assert state.current_since_s == 0.0
    assert state.current_left_s == pytest.approx(1.0 - 9 * PERIOD_S)
    assert state.time_left_s == pytest.approx(8.0 - 9 * PERIOD_S)
    state = scorer.feed(t[10:400], x[10:400], y[10:400])  # target 0 hit by 0.8 s
    assert state.current == -1
    assert state.hits == 1
    assert state.last.hit
    assert state.score == HIT_POINTS
    state = scorer.feed(t[400:600], x[400:600], y[400:600])  # target 1 opened at 1.0 s
    assert state.current == 1
    assert state.current_since_s == pytest.approx(1.0)


def test_samples_out_of_order_are_refused():
    scorer = GameScorer(game_layout(PATH))
    scorer.feed([0.0, 0.002], [-0.3, -0.3], [0.2, 0.2])
    with pytest.raises(ValueError, match="time order"):
        scorer.feed([0.001], [-0.3], [0.2])
    with pytest.raises(ValueError, match="one length"):
        scorer.feed([0.004, 0.006], [-0.3], [0.2, 0.2])


def same(a, b) -> bool:
    """Figures equal to the last bit, NaN equal to NaN."""
    def key(f):
        return repr((f.to_metrics(), f.outcomes))
    return key(a) == key(b)


def wandering(p, seed, noise_m):
    """The reference with a random slow wander and jitter: hits, misses, exits, touches."""
    t, x, y = reference(p, lag_s=0.1)
    rng = np.random.default_rng(seed)
    drift = np.cumsum(rng.normal(0.0, noise_m, (2, t.size)), axis=1) * 0.05
    return t, x + drift[0] + rng.normal(0, noise_m, t.size), y + drift[1]


@given(game=st.sampled_from(["reach", "path"]), seed=st.integers(0, 2**32 - 1),
       noise=st.floats(0.0, 0.01), cuts=st.lists(st.integers(0, 6000), max_size=30))
def test_streaming_in_any_chunking_gives_the_whole_arrays_figures(game, seed, noise, cuts):
    p = (REACH if game == "reach" else PATH).replace(repetitions=1)
    t, x, y = wandering(p, seed, noise)
    layout = game_layout(p)
    whole = score_game(layout, t, x, y)
    scorer = GameScorer(layout)
    bounds = [0, *sorted(c % (t.size + 1) for c in cuts), t.size]
    states = [scorer.feed(t[a:b], x[a:b], y[a:b]) for a, b in itertools.pairwise(bounds)]
    assert same(scorer.finish(), whole)
    assert states[-1].hits + states[-1].misses <= whole.hits + whole.misses
    # the live score never runs ahead of the final one's hits
    assert all(s.hits <= whole.hits for s in states)
