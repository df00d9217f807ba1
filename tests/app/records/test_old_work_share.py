"""A record analysed before the robot's share of the work counted its help alone (no
robot_help_work_J beside it) shows no share: that one also counted the motors' work on the
robot's own friction and mass (core.metrics.drop_old_share). Its net works stand."""

import math

from app.records.registry.values import metrics_json, parse_metrics
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT

OLD = {"robot_work_J": 0.67, "patient_work_J": 1.0, "robot_work_share": 0.40}


def test_an_old_registry_record_shows_no_share_and_keeps_its_works():
    old, new = parse_metrics([metrics_json(OLD),
                              metrics_json({**OLD, "robot_help_work_J": 0.0,
                                            "robot_work_share": 0.0})])
    assert math.isnan(old["robot_work_share"])
    assert old["robot_work_J"] == 0.67
    assert new["robot_work_share"] == 0.0


def test_a_new_trial_file_keeps_its_share(tmp_path):
    path = tmp_path / "trial.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), patient="passive", seed=0), path)
    metrics = read_trial(path).metrics
    assert "robot_help_work_J" in metrics
    assert metrics["robot_work_share"] > 0.9
