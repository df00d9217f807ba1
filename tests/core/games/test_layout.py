"""The games' layouts from the trial's parameters."""

import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from core.games import distance_to_path, game_layout
from core.reaches import reaches_from_trajectory
from core.trajectory import SHAPES, make_path
from core.trial import TrialParameters


def test_the_reaching_games_targets_are_the_outward_reaches_on_the_clock():
    p = TrialParameters(game="reach", shape="targets", duration_s=8.0, repetitions=2,
                        time_allowed_s=0.7, target_radius_m=0.015)
    layout = game_layout(p)
    outward = [r for r in reaches_from_trajectory(p.trajectory()) if r.start_m == p.centre_m]
    assert len(layout.targets) == 16 == len(outward)
    for k, (target, reach) in enumerate(zip(layout.targets, outward, strict=True)):
        assert target.index == k
        assert target.centre_m == pytest.approx(reach.target_m)
        assert target.onset_s == pytest.approx(reach.onset_s)
        assert target.window_s == 0.7
        assert target.radius_m == 0.015
        assert math.dist(target.centre_m, p.centre_m) == pytest.approx(p.radius_m)
    onsets = [t.onset_s for t in layout.targets]
    assert onsets == sorted(onsets)
    assert onsets[1] - onsets[0] == pytest.approx(1.0)
    assert layout.total_s == 16.0
    assert layout.home_m == p.centre_m


def test_a_straight_reach_has_one_target_per_repetition_at_its_far_end():
    p = TrialParameters(game="reach", shape="reach", duration_s=3.0, repetitions=4,
                        n_distractors=2)
    layout = game_layout(p)
    assert [t.onset_s for t in layout.targets] == [0.0, 3.0, 6.0, 9.0]
    far = (p.centre_m[0], p.centre_m[1] - 2 * p.radius_m)
    assert layout.targets[0].centre_m == pytest.approx(far)
    assert len(layout.distractors) == 2
    for disc in layout.distractors:
        assert math.dist(disc.centre_m, p.centre_m) == pytest.approx(2 * p.radius_m)
        assert math.dist(disc.centre_m, far) > 2 * p.target_radius_m


@pytest.mark.parametrize(("n_targets", "n_distractors"), [(8, 1), (8, 3), (8, 8), (4, 2), (5, 5)])
def test_distractors_sit_between_targets_and_spread_round(n_targets, n_distractors):
    p = TrialParameters(game="reach", shape="targets", n_targets=n_targets,
                        duration_s=2.0 * n_targets, n_distractors=n_distractors,
                        target_radius_m=0.01)
    layout = game_layout(p)
    assert len(layout.distractors) == n_distractors
    ends = {t.centre_m for t in layout.targets}
    gap = 2 * p.radius_m * math.sin(math.pi / (2 * n_targets))  # target to half-step point
    for disc in layout.distractors:
        assert min(math.dist(disc.centre_m, e) for e in ends) == pytest.approx(gap)
    assert len({d.centre_m for d in layout.distractors}) == n_distractors
    assert game_layout(p) == layout, "placed from the parameters alone"


@pytest.mark.parametrize("shape", SHAPES)
def test_the_path_games_laps_are_the_traversals(shape):
    p = TrialParameters(game="path", shape=shape, duration_s=6.0, repetitions=3,
                        channel_half_width_m=0.01)
    layout = game_layout(p)
    assert (layout.laps, layout.lap_s, layout.total_s) == (3, 6.0, 18.0)
    assert layout.channel_half_width_m == 0.01
    assert layout.to_dict()["game"] == "path"


def test_a_trial_without_a_game_has_no_layout():
    with pytest.raises(ValueError, match="not a game"):
        game_layout(TrialParameters())


@given(shape=st.sampled_from(SHAPES), clockwise=st.booleans(),
       x=st.floats(-0.6, 0.1), y=st.floats(0.05, 0.6))
def test_distance_to_the_path_is_the_nearest_of_its_points(shape, clockwise, x, y):
    path = make_path(shape, (-0.3, 0.3), 0.1, clockwise=clockwise, n_targets=5)
    spacing = 0.0005
    dense = path.points(spacing)
    nearest = float(np.min(np.hypot(dense[:, 0] - x, dense[:, 1] - y)))
    d = distance_to_path(path, x, y)
    # exact distance is at most the sampled one, and within half a spacing of it
    assert d <= nearest + 1e-12
    assert nearest - d <= spacing / 2 + 1e-9


@pytest.mark.parametrize(("side", "sign"), [("left", 1.0), ("right", -1.0)])
def test_a_neglect_layout_puts_every_target_on_the_neglected_side(side, sign):
    """The patient sits on +y facing −y: the patient's left is +x (docs/frames.md)."""
    p = TrialParameters(game="reach", shape="targets", n_targets=5, duration_s=10.0,
                        neglect_side=side, n_distractors=4)
    layout = game_layout(p)
    cx = p.centre_m[0]
    sides = [sign * (t.centre_m[0] - cx) for t in layout.targets]
    assert sides[0] == pytest.approx(0.0, abs=1e-12), "the first target straight ahead"
    assert all(s >= -1e-12 for s in sides)
    assert max(sides) == pytest.approx(p.radius_m)
    assert all(sign * (d.centre_m[0] - cx) > 0 for d in layout.distractors)
    # the robot's path goes to the same targets: they are its reaches' ends
    ends = {seg.end for seg in p.path().segments if seg.start == p.centre_m}
    assert {t.centre_m for t in layout.targets} == ends
    reach = game_layout(p.replace(shape="reach", n_distractors=0, duration_s=2.0))
    assert sign * (reach.targets[0].centre_m[0] - cx) == pytest.approx(
        2 * p.radius_m * math.sin(math.pi / 4))


@pytest.mark.parametrize(("changes", "field"), [
    (dict(neglect_side="up"), "neglect_side"),
    (dict(neglect_side="left"), "neglect_side"),  # the D is not a reaching layout
    (dict(shape="targets", game="reach", neglect_side="left", n_targets=4,
          duration_s=8.0, n_distractors=4), "n_distractors"),
])
def test_a_bad_neglect_side_is_refused_in_one_line(changes, field):
    with pytest.raises(ValueError, match=field) as refused:
        TrialParameters(**changes)
    assert "\n" not in str(refused.value)
