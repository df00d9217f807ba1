"""A session plan (core.plan): validated blocks, plain data, and the movements counted the
same way on the plan and on a trial's reference."""

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from core.assessment.protocol import PROTOCOLS
from core.errors import ParameterError
from core.plan import (
    Block,
    Plan,
    movement_ends,
    movements_in_path,
    movements_per_lap,
)
from core.trajectory import SHAPES
from core.trial import ASSIST_MODES, THESIS_SUBJECT

blocks = st.builds(
    Block,
    shape=st.sampled_from(SHAPES),
    repetitions=st.integers(1, 100),
    assist=st.sampled_from(ASSIST_MODES),
    assistance_level=st.floats(0.0, 1.0),
    duration_s=st.floats(1.0, 120.0),
    tolerance_rad=st.floats(math.radians(1.0), math.radians(90.0)),
    rest_s=st.floats(0.0, 600.0),
    rounds=st.integers(1, 20),
    radius_m=st.none() | st.floats(0.02, 0.25),
    name=st.text(st.characters(min_codepoint=32, max_codepoint=0x2FFF), max_size=80),
)
timed = st.builds(Block, repetitions=st.none(), active_s=st.floats(1.0, 400.0),
                  duration_s=st.floats(4.0, 120.0))


@settings(max_examples=60, deadline=None)
@given(st.lists(blocks | timed, min_size=1, max_size=20))
def test_a_plan_goes_through_json_and_back_unchanged(block_list):
    plan = Plan("Today", tuple(block_list))
    again = Plan.from_dict(json.loads(json.dumps(plan.to_dict(), allow_nan=False)))
    assert again == plan


@pytest.mark.parametrize(("values", "words"), [
    ({"shape": "square"}, "block 2.shape = 'square'"),
    ({"repetitions": 0}, "block 2.repetitions = 0"),
    ({"repetitions": 2.5}, "block 2.repetitions = 2.5"),
    ({"repetitions": None}, "block 2.repetitions = None"),  # neither laps nor a time
    ({"active_s": 60.0}, "block 2.repetitions = 3"),  # both
    ({"repetitions": None, "active_s": 0.5}, "block 2.active_s = 0.5"),
    ({"repetitions": None, "active_s": 600.0, "duration_s": 2.0}, "block 2.active_s = 600"),
    ({"assist": "robot"}, "block 2.assist = 'robot'"),
    ({"assistance_level": 1.5}, "block 2.assistance_level = 1.5"),
    ({"assistance_level": "high"}, "block 2.assistance_level = 'high'"),
    ({"duration_s": float("nan")}, "block 2.duration_s = NaN"),
    ({"tolerance_rad": 3.0}, "block 2.tolerance_rad = 3"),
    ({"rest_s": -1.0}, "block 2.rest_s = -1"),
    ({"rest_s": 3600.0}, "block 2.rest_s = 3600"),
    ({"rounds": 0}, "block 2.rounds = 0"),
    ({"radius_m": 1.0}, "block 2.radius_m = 1"),
    ({"game": "tetris"}, "block 2.game = 'tetris'"),
    ({"game": "reach", "shape": "d"}, "block 2.shape = 'd'"),
    ({"name": "two\nlines"}, "block 2.name = 'two\\nlines'"),
    ({"speed": 3}, "block 2.speed = 3"),
])
def test_every_bad_value_is_refused_in_one_line_naming_its_block(values, words):
    good = Block().to_dict()
    with pytest.raises(ParameterError) as refused:
        Plan.from_dict({"name": "Today", "blocks": [good, {**good, **values}]})
    text = str(refused.value)
    assert text.startswith(words), text
    assert "\n" not in text


@pytest.mark.parametrize("plan", [
    {"name": "", "blocks": [{}]},
    {"name": "Today", "blocks": []},
    {"name": "Today", "blocks": [{}] * 21},
    {"name": "Today", "blocks": "d"},
    {"name": "Today", "blocks": [{}], "owner": "me"},
    [1, 2],
])
def test_a_plan_without_a_name_or_with_no_or_too_many_blocks_is_refused(plan):
    with pytest.raises(ParameterError):
        Plan.from_dict(plan)


def test_a_block_by_time_runs_whole_laps_that_fill_it():
    block = Block.from_dict({"active_s": 10.0, "duration_s": 4.0})
    assert block.repetitions is None
    assert block.laps == 3
    assert Block(repetitions=None, active_s=8.0, duration_s=4.0).laps == 2
    assert block.parameters(THESIS_SUBJECT).repetitions == 3


def test_a_block_sets_only_the_exercise_on_the_patients_setup():
    base = THESIS_SUBJECT.replace(body_mass_kg=70.0, centre_m=(-0.28, 0.32))
    block = Block(shape="circle", repetitions=2, assist="as-needed", assistance_level=0.6,
                  duration_s=5.0, tolerance_rad=0.3, radius_m=0.08)
    params = block.parameters(base)
    assert params.replace(shape="d", repetitions=base.repetitions, duration_s=4.0,
                          assist="thesis", assistance_level=1.0,
                          tolerance_rad=base.tolerance_rad, radius_m=0.10) == base
    assert (params.shape, params.repetitions, params.assist, params.assistance_level,
            params.duration_s, params.tolerance_rad, params.radius_m) == (
        "circle", 2, "as-needed", 0.6, 5.0, 0.3, 0.08)



@settings(max_examples=40, deadline=None)
@given(blocks)
def test_a_block_says_the_level_its_trials_run_at(block):
    """A transparent block showed (Plan tab) and kept (registry) the level it was given,
    which its trials never ran: the transparent mode acts on no level (core.trial)."""
    params = block.parameters(THESIS_SUBJECT)
    assert block.assistance_level == params.assistance_level
    if block.assist == "transparent":
        assert block.assistance_level == 0.0
    changed = Block.from_dict({**block.to_dict(), "assistance_level": 0.6})
    assert changed.assistance_level == (0.0 if block.assist == "transparent" else 0.6)

@settings(max_examples=40, deadline=None)
@given(blocks, st.sampled_from(sorted(PROTOCOLS)), st.integers(0, 1))
def test_a_task_set_up_in_the_form_is_not_a_block_s_setup(block, task, index):
    """The form after an assessment task's "Set up this trial" is the task's trial: a
    plan's round built on it ran as the task (the strength task's transparent mode
    refused an as-needed block, and the plan ended at its first Build) or with the
    task's holding controller. Its round is the block on the patient's setup alone."""
    patient = THESIS_SUBJECT.replace(body_mass_kg=70.0, centre_m=(-0.28, 0.32),
                                     side="left", shoulder_m=(-0.40, 0.70))
    protocol = PROTOCOLS[task]
    set_up = protocol.parameters(patient, min(index, protocol.trial_count - 1))
    assert set_up.assessment == task
    round_ = block.parameters(set_up)
    assert round_ == block.parameters(patient)
    assert round_.assessment == ""
    assert round_.game == block.game


def test_a_block_without_a_game_is_no_game_whatever_the_form_played():
    played = THESIS_SUBJECT.replace(game="reach", shape="targets")
    block = Block(shape="circle", repetitions=1, duration_s=4.0)
    assert block.parameters(played).game == ""


def reference(params, fraction=1.0, period_s=0.002):
    """The desired positions of a trial's exercise, its first `fraction`."""
    trajectory = params.trajectory()
    t = np.arange(0.0, trajectory.total_duration_s * fraction + 1e-12, period_s)
    return trajectory.sample(t).position_m


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("timing", ["constant_speed", "minimum_jerk"])
def test_a_whole_trial_makes_the_movements_the_plan_counts(shape, timing):
    params = THESIS_SUBJECT.replace(shape=shape, repetitions=3, timing=timing,
                                    duration_s=8.0, n_targets=4)
    desired = reference(params)
    expected = 3 * movements_per_lap(shape, 4)
    assert movements_in_path(params, desired) == expected
    # resting at the end (the hold) counts nothing more
    held = np.vstack([desired, np.repeat(desired[-1:], 500, axis=0)])
    assert movements_in_path(params, held) == expected
    # a trial stopped early in its second lap made only the first lap's movements
    assert movements_in_path(params, reference(params, 1.1 / 3)) == movements_per_lap(shape, 4)


def test_movements_per_lap():
    assert [movements_per_lap(s, 8) for s in SHAPES] == [
        {"d": 1, "circle": 1, "reach": 2, "targets": 16, "figure8": 2}[s] for s in SHAPES]


def test_the_hand_s_last_movement_ends_within_the_turn_s_margin_once_the_reference_arrived():
    """The hand's points (the transparent mode, app.plans.dose) do not settle within the
    reference's 2 mm: the last movement counts once the hand is at its end within the
    turn's margin and the reference has arrived there; a trial stopped on the way (the
    reference short of the end) counts it not, wherever the hand is."""
    params = THESIS_SUBJECT.replace(shape="d", repetitions=2, duration_s=4.0)
    desired = reference(params)
    hand = desired + np.array([0.004, 0.0])  # 4 mm beside the path all the way
    assert movements_in_path(params, hand) == 1  # as the reference's own points: 2 mm
    assert movements_in_path(params, hand, desired) == 2
    # the hand there, the reference 3 cm short of the end: stopped on the way
    short = desired[desired_short_of_end(params, desired, 0.03)]
    assert movements_in_path(params, hand, short) == 1


def desired_short_of_end(params, desired, by_m):
    """The samples of `desired` up to the last one `by_m` or more from the path's end."""
    end = movement_ends(params)[0]
    far = np.flatnonzero(np.hypot(*(desired - end).T) >= by_m)
    return slice(0, far[-1] + 1)
