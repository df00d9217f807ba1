"""The assessment protocols (core.assessment.protocol) and a trial's `assessment` field:
every task has one, its trials are valid trials of that task, its cues fall on the
reference's segments, and every bad value is refused in one line."""

import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from core.assessment import TASKS
from core.assessment.protocol import HOLD_GAINS, PROTOCOLS, cues, protocol, reach_directions_rad
from core.control.gains import canonical_gains
from core.errors import ParameterError
from core.trial import ASSIST_MODES, TrialParameters
from core.trial_check import check_trial


def test_every_task_has_one_protocol_with_words_for_both_people():
    assert tuple(PROTOCOLS) == TASKS
    for task, p in PROTOCOLS.items():
        assert p.task == task
        assert len(p.therapist) > 80
        assert len(p.patient) > 40
        assert p.trial_count >= 1
        assert "doi" in p.reference or "console" in p.reference


@pytest.mark.parametrize("task", [t for t in TASKS if PROTOCOLS[t].robot_mode in ASSIST_MODES])
def test_a_tasks_trials_are_reachable_trials_of_that_task(task):
    p = protocol(task)
    for index in range(p.trial_count):
        trial = p.parameters(TrialParameters(), index)
        assert trial.assessment == task
        assert trial.assist == p.robot_mode
        assert trial.game == ""
        assert trial.assistance_level == 0.0
        assert trial.duration_s == p.duration_s
        assert trial.repetitions == p.repetitions
        assert check_trial(trial).ok, check_trial(trial).problems
        # the file's round trip keeps the task
        assert TrialParameters.from_dict(trial.to_dict()) == trial


def test_the_circle_runs_once_each_way():
    p = protocol("circle")
    assert [p.parameters(TrialParameters(), i).clockwise for i in range(2)] == [True, False]


def test_the_robot_led_tasks_run_the_hold_gains_and_a_reaching_task_keeps_the_base():
    base = TrialParameters(controller="smc")
    for task in ("strength", "position"):
        trial = protocol(task).parameters(base)
        assert trial.controller == "ctpid"
        assert trial.gains == canonical_gains(HOLD_GAINS)
    assert protocol("reaching").parameters(base).controller == "smc"


def test_a_task_keeps_the_patients_body_and_table():
    base = TrialParameters(centre_m=(-0.25, 0.32), body_mass_kg=70.0, side="right")
    trial = protocol("reaching").parameters(base)
    assert trial.centre_m == base.centre_m
    assert trial.body_mass_kg == 70.0
    assert trial.shoulder_m == base.shoulder_m


@pytest.mark.parametrize(("call", "field"), [
    (lambda: protocol("walking"), "task"),
    (lambda: protocol(["reaching"]), "task"),
    (lambda: protocol("circle").parameters(TrialParameters(), 2), "trial"),
    (lambda: protocol("reaching").parameters(TrialParameters(), -1), "trial"),
    (lambda: cues(TrialParameters()), "assessment"),
    (lambda: cues(protocol("strength").parameters(TrialParameters())), "assessment"),
])
def test_a_bad_request_is_refused_in_one_line(call, field):
    with pytest.raises(ParameterError) as refused:
        call()
    assert refused.value.field == field
    assert "\n" not in str(refused.value)


def test_reaching_cues_are_each_targets_appearance_on_the_clock():
    trial = protocol("reaching").parameters(TrialParameters())
    shown = cues(trial)
    assert len(shown) == 2 * 8 * 2
    targets = [c for c in shown if c.kind == "target"]
    assert len(targets) == 16
    # 3 s a slot: target k of repetition r shows at r·48 + 6k s, the centre 3 s later
    assert [c.time_s for c in targets[:3]] == pytest.approx([0.0, 6.0, 12.0])
    assert targets[8].time_s == pytest.approx(48.0)
    assert targets[8].repetition == 1
    sample = trial.trajectory().sample([c.time_s for c in targets])
    # each target's reach starts at the centre, the reference resting there
    assert np.abs(sample.position_m - np.asarray(trial.centre_m)).max() < 1e-12
    for c in targets:
        assert math.dist(c.point_m, trial.centre_m) == pytest.approx(0.10)
        assert c.start_m == pytest.approx(trial.centre_m)
    directions = reach_directions_rad(trial)
    assert directions[0] == pytest.approx(-math.pi / 2)  # the first straight ahead
    assert len(directions) == 8


def test_the_circle_has_no_cues():
    assert cues(protocol("circle").parameters(TrialParameters())) == ()


@pytest.mark.parametrize(("value", "says"), [
    ("walking", "'' (an exercise) or one of reaching, circle, range, strength, position"),
    (None, "one of reaching"),
    (3, "one of reaching"),
    (["circle"], "one of reaching"),
])
def test_a_bad_assessment_is_refused_in_one_line(value, says):
    with pytest.raises(ParameterError) as refused:
        TrialParameters(assessment=value)
    assert refused.value.field == "assessment"
    assert says in str(refused.value)
    assert "\n" not in str(refused.value)


def test_an_assessment_is_never_a_game():
    with pytest.raises(ParameterError) as refused:
        TrialParameters(assessment="reaching", game="reach", shape="targets", duration_s=8.0)
    assert refused.value.field == "game"
    assert "not played as a game" in str(refused.value)


def test_a_file_from_before_the_assessments_reads_as_an_exercise():
    old = TrialParameters().to_dict()
    del old["assessment"]
    assert TrialParameters.from_dict(old).assessment == ""


@given(st.sampled_from(TASKS))
def test_any_task_round_trips_through_the_dict(task):
    p = TrialParameters(assessment=task)
    assert TrialParameters.from_dict(p.to_dict()).assessment == task
