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


# -- a write into the file that the registry did not get to record --------------------------


def test_a_write_the_registry_could_not_record_is_recorded_at_the_next_start(
        data, patient, capsys, monkeypatch):
    """A full disk under the registry after the EMG reached the file: the trial was refused
    for good ('restore the file from a backup', which would lose the EMG), and the command
    said 'nothing was saved'."""
    from app.errors import RegistryError
    from app.trials.finalize import finish_interrupted
    from app.trials.rewrite import mark_of

    trial_id = _registered_trial(patient, capsys)
    registry = Registry(DataDir(data))

    def full(self, *args, **kwargs):
        raise RegistryError("the registry cannot be written: disk I/O error; the disk "
                            "holding it is probably full. Free space on it, then try again; "
                            "nothing was saved")

    with monkeypatch.context() as patched:
        patched.setattr(Registry, "record_rewritten", full)
        code, _, err = run(["emg", "import", str(trial_id), str(EMG), "--muscles", MUSCLES],
                           capsys)
    assert code == 2
    assert "now holds imported EMG" in err
    assert "nothing was saved" not in err
    path = registry.trial_path(trial_id)
    assert mark_of(path).exists()
    lines = finish_interrupted(registry)  # the window's start
    assert any(f"trial {trial_id}: imported EMG written into its file" in line
               and "its new checksum is recorded" in line for line in lines), lines
    assert registry.verify_trial_file(trial_id) is None
    assert not mark_of(path).exists()


def test_a_write_that_failed_half_way_leaves_the_trial_readable_and_recorded(
        data, patient, capsys, monkeypatch):
    from device.recording import emgfile

    trial_id = _registered_trial(patient, capsys)
    registry = Registry(DataDir(data))

    def fails():
        raise OSError("No space left on device")

    monkeypatch.setattr(emgfile, "utc_now_iso", fails)  # after the room was marked
    code, _, err = run(["emg", "import", str(trial_id), str(EMG), "--muscles", MUSCLES],
                       capsys)
    assert code == 2, err
    assert registry.verify_trial_file(trial_id) is None  # what it left is the console's


def test_a_console_killed_while_writing_leaves_a_trial_the_export_settles(
        data, patient, tmp_path, capsys):
    """kill -9 in the middle of the EMG's write: the file was left flagged 'open for
    writing' (no reader opened it) and not the one recorded (every export refused it)."""
    import os
    import subprocess
    import sys

    from app.trials.reader import read_trial

    trial_id = _registered_trial(patient, capsys)
    registry = Registry(DataDir(data))
    killed = ("import os, signal, sys\n"
              "from device.recording import emgfile\n"
              "emgfile.utc_now_iso = lambda: os.kill(os.getpid(), signal.SIGKILL)\n"
              "from app.cli.main import main\n"
              "sys.exit(main(sys.argv[1:]))\n")
    root = Path(__file__).parents[3]
    done = subprocess.run([sys.executable, "-c", killed, "emg", "import", str(trial_id),
                           str(EMG), "--muscles", MUSCLES], cwd=root, capture_output=True,
                          env={**os.environ, "PYTHONPATH": str(root)}, check=False)
    assert done.returncode == -9, done.stderr
    out = _exported(patient, tmp_path, capsys, "export")
    assert "exported 1 trial(s)" in out
    assert "not exported" not in out
    assert "/emg, which the write left unfinished" in out
    assert registry.verify_trial_file(trial_id) is None
    trial = read_trial(registry.trial_path(trial_id))
    assert any("/emg" in note and "interrupted" in note for note in trial.notes)


@pytest.mark.changes_recorded_files  # a write at work, its checksum not yet recorded
def test_a_mark_whose_writer_is_at_work_is_left_alone(data, patient, capsys):
    import fcntl
    import os

    from app.trials.rewrite import mark_of, settle

    trial_id = _registered_trial(patient, capsys)
    registry = Registry(DataDir(data))
    path = registry.trial_path(trial_id)
    before = registry.trial(trial_id).checksum
    fd = os.open(mark_of(path), os.O_RDWR | os.O_CREAT, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        with path.open("ab") as f:
            f.write(b"\0" * 16)  # as if being written now
        assert settle(registry, registry.trial(trial_id)) is None
        assert mark_of(path).exists()
        assert registry.trial(trial_id).checksum == before
    finally:
        os.close(fd)


def test_a_study_of_the_registry_says_the_trial_it_settled(data, patient, tmp_path, capsys,
                                                          monkeypatch):
    """The export said a trial it settled (its notes); `rehab study analyse CODE` settled
    it in its log only, so a researcher did not hear that a trial's file had been written
    into without the registry knowing."""
    from app.errors import RegistryError
    from app.trials.rewrite import mark_of

    trial_id = _registered_trial(patient, capsys)
    registry = Registry(DataDir(data))

    def full(self, *args, **kwargs):
        raise RegistryError("the registry cannot be written: disk I/O error")

    with monkeypatch.context() as patched:
        patched.setattr(Registry, "record_rewritten", full)
        code, _, _ = run(["emg", "import", str(trial_id), str(EMG), "--muscles", MUSCLES],
                         capsys)
    assert code == 2
    assert mark_of(registry.trial_path(trial_id)).exists()
    code, out, err = run(["study", "analyse", patient, "--workers", "1",
                          "--output", str(tmp_path / "study")], capsys)
    assert code == 0, err
    assert f"note: trial {trial_id}: imported EMG written into its file" in out
    assert registry.verify_trial_file(trial_id) is None
