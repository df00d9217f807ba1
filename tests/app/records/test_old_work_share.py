"""A record analysed before the robot's share of the work counted its help alone (no
robot_help_work_J beside it) shows no share: that one also counted the motors' work on the
robot's own friction and mass (core.work.drop_old_share). Its net works stand."""

import math

from app.exports.loader import load_trial, read_info
from app.records.registry.values import metrics_json, parse_metrics
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from tests.old_analysis import analysed_as_before

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


def test_an_old_trial_file_shows_no_share_to_the_reader_or_the_exports(tmp_path, monkeypatch):
    """A file written as the console did before the help's work was a metric (its share
    the motors' whole work): the reader, the export loader's quick path and its full one
    read the share as NaN and keep the net works."""
    path = tmp_path / "old.h5"
    with monkeypatch.context() as patch:
        analysed_as_before(patch)
        save(simulate(THESIS_SUBJECT.replace(repetitions=1, assist="transparent"),
                      patient="healthy", seed=0), path)
    for metrics in (read_trial(path).metrics, read_info(path).metrics,
                    load_trial(path).metrics):
        assert "robot_help_work_J" not in metrics
        assert math.isnan(metrics["robot_work_share"])
        assert metrics["robot_work_J"] > 0.0
