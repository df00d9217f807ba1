"""The virtual patient's own movement in the assessment tasks (device.sim.tasks): it moves
after its reaction time, on its own minimum-jerk profile, to the targets the task shows, and
in the range task out to its share of what the robot and its arm allow."""

import math

import numpy as np
import pytest

from core.assessment.protocol import cues, protocol
from core.assessment.workspace import extent_m, range_box
from core.robot import RobotModel
from core.trial import TrialParameters
from device.sim.tasks import (
    Move,
    OwnMovement,
    movement_time_s,
    own_movement,
    range_fraction,
    reaction_time_s,
)

ROBOT = RobotModel()


def plan(task, kind="healthy", seed=0, **options):
    trial = protocol(task).parameters(TrialParameters())
    return trial, own_movement(trial, kind, options, seed, ROBOT)


def test_an_exercise_follows_the_reference_and_the_circle_its_own_pace():
    assert own_movement(TrialParameters(), "healthy", {}, 0, ROBOT) is None
    trial = protocol("circle").parameters(TrialParameters())
    healthy = own_movement(trial, "healthy", {}, 0, ROBOT)
    weak = own_movement(trial, "weak", {}, 0, ROBOT)
    assert healthy.lap_s == trial.duration_s  # the dot's pace
    assert healthy.path == trial.path()
    assert weak.path == trial.path()
    assert weak.lap_s == pytest.approx(trial.duration_s / 0.7)
    assert weak.total_duration_s >= trial.duration_s * trial.repetitions


def test_each_reach_starts_after_its_target_and_ends_on_it():
    trial, own = plan("reaching")
    targets = [c for c in cues(trial)]
    assert len(own.moves) == len(targets)
    for move, cue in zip(own.moves, targets, strict=True):
        assert move.t0_s > cue.time_s
        assert move.end_m == pytest.approx(cue.point_m)
    delays = np.array([m.t0_s - c.time_s for m, c in zip(own.moves, targets, strict=True)])
    # the model's 0.30 s, varying by 15 % from reach to reach
    assert delays.mean() == pytest.approx(0.30, rel=0.1)
    assert 0.05 < delays.std() / delays.mean() < 0.3


def test_a_weaker_patient_reacts_later_moves_slower_and_reaches_less_far():
    assert reaction_time_s(0.4) > reaction_time_s(1.0) == pytest.approx(0.30)
    assert movement_time_s(0.1, 0.4) > movement_time_s(0.1, 1.0) == pytest.approx(0.6)
    assert range_fraction(0.4) < range_fraction(1.0) == pytest.approx(0.95)
    trial, healthy = plan("range")
    _, weak = plan("range", "weak")
    box = range_box(trial)
    for h, w in zip(healthy.moves[::2], weak.moves[::2], strict=True):
        direction = math.atan2(h.end_m[1] - trial.centre_m[1], h.end_m[0] - trial.centre_m[0])
        allowed = extent_m(trial, ROBOT, direction, box)
        assert math.dist(h.end_m, trial.centre_m) == pytest.approx(0.95 * allowed)
        assert math.dist(w.end_m, trial.centre_m) == pytest.approx(0.68 * allowed)


def test_the_plan_is_a_minimum_jerk_movement_at_rest_between():
    own = OwnMovement((0.0, 0.0), [Move(1.0, 2.0, (0.0, 0.0), (0.1, 0.0))], 5.0)
    s = own.sample([0.5, 1.5, 3.0])
    assert s.position_m[:, 0] == pytest.approx([0.0, 0.05, 0.1])
    assert s.velocity_m_s[1, 0] == pytest.approx(0.1 * 1.875)  # the profile's peak
    assert s.direction.tolist() == [[0.0, 0.0], [1.0, 0.0], [0.0, 0.0]]
    assert own.at(1.5)[0] == pytest.approx(0.05)


def test_the_same_seed_plans_the_same_and_another_varies():
    _, a = plan("reaching", seed=4)
    _, b = plan("reaching", seed=4)
    _, c = plan("reaching", seed=5)
    assert a.moves == b.moves
    assert a.moves != c.moves


def test_a_bad_effort_is_refused_by_name():
    from core.errors import ParameterError

    with pytest.raises(ParameterError) as refused:
        plan("reaching", effort="a lot")
    assert refused.value.field == "effort"


def test_a_subjects_own_reaction_and_speed_set_its_plan():
    trial, usual = plan("reaching", seed=3)
    _, slow = plan("reaching", seed=3, reaction_time_s=0.5, speed_scale=0.5)
    shown = [c.time_s for c in cues(trial)]
    for a, b, cue in zip(usual.moves, slow.moves, shown, strict=True):
        # the same draws: the reaction scaled from 0.30 to 0.50 s, the movement twice as long
        assert (b.t0_s - cue) == pytest.approx((a.t0_s - cue) * 0.5 / 0.3)
        assert (b.t1_s - b.t0_s) == pytest.approx(2.0 * (a.t1_s - a.t0_s))


def test_the_own_movements_options_are_taken_from_the_patients_and_refused_elsewhere():
    from core.errors import ParameterError
    from device.sim.simulator import SimulatorBackend
    from device.sim.tasks import split_options

    trial = protocol("range").parameters(TrialParameters())
    body, own = split_options(trial, {"drive_N": 1.0, "reaction_time_s": 0.4})
    assert (body, own) == ({"drive_N": 1.0}, {"reaction_time_s": 0.4})
    backend = SimulatorBackend.from_trial(trial, "healthy", patient_options={
        "reaction_time_s": 0.4, "speed_scale": 1.2, "drive_N": 1.0}, compiled=False)
    assert backend.patient.parameters.drive_N > 0.0
    with pytest.raises(ParameterError) as refused:
        SimulatorBackend.from_trial(TrialParameters(), "healthy",
                                    patient_options={"speed_scale": 1.2}, compiled=False)
    assert refused.value.field == "speed_scale"
    with pytest.raises(ParameterError) as refused:
        plan("reaching", reaction_time_s=5.0)
    assert refused.value.field == "reaction_time_s"
