"""A registered trial's file that the console writes into after the trial (the circle task's
figures, imported EMG, the session's MVCs) keeps being the trial's file: the registry records
its new checksum, so `rehab export --patient` and `rehab study analyse` still read it. They
refused it before ('not the file recorded ... restore the file from a backup'). A file
changed by anything else before the console's write stays refused."""

from __future__ import annotations

from pathlib import Path

import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from tests.app.cli.running import run

EMG = Path(__file__).parents[2] / "data" / "emg" / "trigno_export.csv"
MUSCLES = "biceps,triceps,anterior_deltoid"


def _registered_trial(patient, capsys) -> int:
    code, out, err = run(["run", "--code", patient, "--repetitions", "1", "--duration", "3",
                          "--seed", "1"], capsys)
    assert code == 0, err
    return int(out.split("(id ")[1].split(")")[0])


def _exported(patient, tmp_path, capsys, name, expected=0) -> str:
    """What the export printed; exit 1 when a trial was not exported."""
    code, out, err = run(["export", "--patient", patient, "--output", str(tmp_path / name)],
                         capsys)
    assert code == expected, (out, err)
    return out


def test_emg_import_and_mvc_keep_a_registered_trial_exportable(data, patient, tmp_path,
                                                               capsys):
    trial_id = _registered_trial(patient, capsys)
    registry = Registry(DataDir(data))
    before = registry.trial(trial_id).checksum
    code, _, err = run(["emg", "import", str(trial_id), str(EMG), "--muscles", MUSCLES],
                       capsys)
    assert code == 0, err
    # the MVC given by the file's path, as the README's demo does
    path = registry.trial_path(trial_id)
    code, _, err = run(["emg", "mvc", str(path), "--contraction", f"biceps={EMG}:EMG1"],
                       capsys)
    assert code == 0, err
    assert registry.trial(trial_id).checksum != before
    assert registry.verify_trial_file(trial_id) is None
    out = _exported(patient, tmp_path, capsys, "export")
    assert "exported 1 trial(s)" in out
    assert "not exported" not in out


@pytest.mark.changes_recorded_files  # on purpose (tests/recorded_files.py)
def test_a_file_changed_before_the_console_wrote_stays_refused(data, patient, tmp_path,
                                                               capsys):
    trial_id = _registered_trial(patient, capsys)
    registry = Registry(DataDir(data))
    with registry.trial_path(trial_id).open("ab") as f:
        f.write(b"\0" * 16)  # bytes the trial file's own seal does not cover: not the console's
    code, _, err = run(["emg", "import", str(trial_id), str(EMG), "--muscles", MUSCLES],
                       capsys)
    assert code == 0, err
    assert registry.verify_trial_file(trial_id) is not None  # not passed off as the trial's
    out = _exported(patient, tmp_path, capsys, "export", expected=1)
    assert "not exported" in out


def test_the_circle_task_s_trials_stay_exportable(data, patient, tmp_path, capsys):
    code, _, err = run(["assess", "run", patient, "--task", "circle", "--seed", "1"], capsys)
    assert code == 0, err
    registry = Registry(DataDir(data))
    trials = registry.trials_for_patient(patient)
    assert len(trials) == 2
    assert all(registry.verify_trial_file(t) is None for t in trials)
    out = _exported(patient, tmp_path, capsys, "export")
    assert "exported 2 trial(s)" in out
    assert "not exported" not in out


@pytest.mark.changes_recorded_files  # on purpose (tests/recorded_files.py)
def test_record_rewritten_leaves_a_trial_without_checksum_and_forgets_the_store(data,
                                                                                 patient,
                                                                                 capsys):
    from core.trial import THESIS_SUBJECT

    registry = Registry(DataDir(data))
    begun = registry.begin_trial(patient, THESIS_SUBJECT, backend="simulator")
    registry.finish_trial(begun.trial_id, "complete", {})  # no checksum kept
    assert registry.record_rewritten(begun.trial_id, "a" * 64).checksum is None
    trial_id = _registered_trial(patient, capsys)
    registry.record_stored(trial_id, "/mnt/store")
    after = registry.record_rewritten(trial_id, "b" * 64)
    assert after.checksum == "b" * 64
    assert after.stored_in is None  # the store's copy is of the file before
