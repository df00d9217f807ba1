"""A trial's analysis uses the robot model the trial ran, as its file records it (`robot`,
core.robot_record), not the default one: the robot's own torque (core.control.own) of a
trial run on a robot with more friction was recomputed on the default model, so its help
read as the friction the controller compensated."""

import dataclasses
import json

import pytest

from app.trials.analysis import analyse_data
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.errors import ParameterError
from core.robot import Friction, RobotModel
from core.robot_record import robot_from_record
from core.trial import THESIS_SUBJECT

STICKY = RobotModel(friction=Friction((0.30, 0.25), (0.08, 0.06)))
"""A robot with six times the default joint friction."""


@pytest.fixture(scope="module")
def sticky_trial(tmp_path_factory):
    path = tmp_path_factory.mktemp("robot") / "sticky.h5"
    params = THESIS_SUBJECT.replace(repetitions=1, assist="transparent")
    save(simulate(params, patient="healthy", seed=0, robot=STICKY), path)
    return path


def test_a_transparent_trial_on_its_own_robot_gives_no_help(sticky_trial):
    """The transparent mode only carries the robot's own friction: recomputed on the model
    the trial ran, the help is none, in the file as written and in the analysis of it read
    back; on the default model it was the friction's difference (about 0.1 J)."""
    data = read_trial(sticky_trial)
    assert robot_from_record(data.robot) == STICKY
    for metrics in (data.metrics, analyse_data(data).to_metrics()):
        assert abs(metrics["robot_help_work_J"]) <= 0.01 * metrics["patient_work_J"]
        assert metrics["robot_work_share"] <= 0.01
    on_default = analyse_data(dataclasses.replace(data, robot={})).metrics
    assert on_default.robot_help_work_J > 0.05 * on_default.patient_work_J


def test_a_description_that_is_not_a_robot_model_is_noted_and_the_default_used(
        sticky_trial):
    data = read_trial(sticky_trial)
    odd = dataclasses.replace(data, robot={**data.robot, "wheels": 3})
    analysis = analyse_data(odd)
    assert "robot description is not a robot model this console reads" in analysis.notes[0]
    assert "wheels" in analysis.notes[0]


def test_the_record_is_the_model_and_nothing_else():
    stored = json.loads(json.dumps(dataclasses.asdict(STICKY)))
    assert robot_from_record(stored) == STICKY
    assert robot_from_record(json.loads(json.dumps(dataclasses.asdict(RobotModel())))) \
        == RobotModel()
    missing = {k: v for k, v in stored.items() if k != "branch"}
    with pytest.raises(ParameterError, match=r"robot\.branch"):
        robot_from_record(missing)
    with pytest.raises(ParameterError, match=r"robot\.links\[0\]"):
        robot_from_record({**stored, "links": [{"mass_kg": 1.0}, *stored["links"][1:]]})
    with pytest.raises(ParameterError, match=r"robot\.constants"):
        robot_from_record({**stored, "constants": [0.0] * len(stored["constants"])})
    with pytest.raises(ParameterError, match="mass_kg"):
        robot_from_record({**stored, "links": [{**stored["links"][0], "mass_kg": -1.0},
                                               *stored["links"][1:]]})
