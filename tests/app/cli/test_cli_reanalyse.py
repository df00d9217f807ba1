"""`rehab reanalyse` as a researcher runs it (app.trials.reanalyse; the registry's side on
both engines is tests/app/records/test_reanalysis.py): what it lists, what it stores, a
file it skips. A bad input's one line: tests/app/cli/test_cli.py."""

from __future__ import annotations

import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from tests.app.cli.running import run
from tests.old_analysis import analysed_as_before


@pytest.fixture
def old_trial(data, patient, capsys, monkeypatch):
    """A trial `rehab run` registered before the help's work was a metric."""
    with monkeypatch.context() as patch:
        analysed_as_before(patch)
        code, _, err = run(["run", "--code", patient, "--assist", "transparent",
                            "--repetitions", "1"], capsys)
    assert code == 0, err
    (trial,) = Registry(DataDir(data)).trials_for_patient(patient)
    return trial


def test_a_dry_run_lists_then_a_run_stores_then_nothing_is_left(data, patient, old_trial,
                                                                  capsys):
    code, out, err = run(["reanalyse", "--patient", patient, "--dry-run"], capsys)
    assert code == 0, err
    head = f"trial {old_trial.id} ({patient} session 1 trial 1): would change 2 figure(s): "
    assert out.splitlines()[0].startswith(head)
    assert "robot_work_share none → " in out
    assert out.splitlines()[-1] == ("1 trial(s): 1 would change, 0 unchanged, 0 skipped "
                                    "(dry run: nothing was stored)")
    registry = Registry(DataDir(data))
    assert "robot_help_work_J" not in registry.trial(old_trial.id).metrics
    code, out, err = run(["reanalyse", "--all", "--by", "R. Searcher"], capsys)
    assert code == 0, err
    assert "changed 2 figure(s)" in out
    assert "robot_help_work_J" in registry.trial(old_trial.id).metrics
    code, out, _ = run(["reanalyse", "--patient", patient, "--session", "1", "--by", "R."],
                       capsys)
    assert out.splitlines() == [f"trial {old_trial.id} ({patient} session 1 trial 1): "
                                "unchanged", "1 trial(s): 0 changed, 1 unchanged, 0 skipped"]


def test_a_missing_file_is_listed_and_skipped_with_exit_1(data, patient, old_trial, capsys):
    Registry(DataDir(data)).trial_path(old_trial).unlink()
    code, out, err = run(["reanalyse", "--patient", patient, "--by", "R. Searcher"], capsys)
    assert code == 1, err
    assert f"trial {old_trial.id} ({patient} session 1 trial 1): skipped: " in out
    assert "is missing" in out
    assert out.splitlines()[-1] == "1 trial(s): 0 changed, 0 unchanged, 1 skipped"
