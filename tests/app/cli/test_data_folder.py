"""The data folder on the command line (issue 28 #10): a typo never creates a registry
anywhere; a command that reads the registry says what is where it looked and what to do,
in one line, and creates nothing; only `rehab patients add` starts a registry, and only in
a new or empty folder."""

from __future__ import annotations

import pytest

from tests.app.cli.running import run

pytestmark = pytest.mark.usefixtures("data")  # the folders of tests/app/cli/conftest.py

READERS = [["patients"], ["patients", "list"], ["trials", "P0000000"],
           ["progress", "P0000000"], ["report", "1"], ["export", "--patient", "P0000000"],
           ["export", "--trial", "1"], ["emg", "show", "1"], ["pose", "1"],
           ["run", "--code", "P0000000", "--repetitions", "1", "--duration", "3"]]


@pytest.mark.parametrize("argv", READERS, ids=" ".join)
def test_a_typo_creates_nothing_and_says_what_is_there(tmp_path, capsys, argv):
    typo = tmp_path / "clinc-data"
    code, _, err = run(["--data-dir", str(typo), *argv], capsys)
    assert code == 2
    assert err.count("\n") == 1, err
    assert f"no registry in {typo} (that folder does not exist)" in err
    assert "rehab patients add" in err
    assert not typo.exists()


def test_a_folder_of_other_things_never_gets_a_registry(tmp_path, capsys):
    home = tmp_path / "home"
    (home / "Documents").mkdir(parents=True)
    (home / "notes.txt").write_text("mine")
    code, _, err = run(["--data-dir", str(home), "patients"], capsys)
    assert code == 2
    assert "the folder holds 2 entries: Documents, notes.txt" in err
    code, _, err = run(["--data-dir", str(home), "patients", "add", "--first-name", "A"],
                       capsys)
    assert code == 2
    assert err.count("\n") == 1
    assert "start only in a new or empty folder" in err
    assert sorted(p.name for p in home.iterdir()) == ["Documents", "notes.txt"]


def test_the_first_patient_starts_a_registry_in_a_new_folder(tmp_path, capsys):
    new = tmp_path / "clinic" / "data"
    code, out, err = run(["--data-dir", str(new), "patients", "add", "--first-name", "A"],
                         capsys)
    assert code == 0, err
    assert (new / "registry.sqlite3").is_file()
    code, out, _ = run(["--data-dir", str(new), "patients"], capsys)
    assert code == 0
    assert out.startswith("P")


@pytest.mark.parametrize(("typed", "said"), [
    (["--upper-arm", "30"], "--upper-arm (upper_arm_m) = 30 is not allowed; allowed: "
                            "[0.15, 0.5] m"),  # cm typed where m go, as a newcomer may
    (["--shoulder", "5", "0.7"], "--shoulder (shoulder_m[x]) = 5 is not allowed"),
    (["--birth-year", "1800"], "--birth-year (birth_year) = 1800 is not allowed"),
])
def test_a_refused_first_patient_starts_no_registry(tmp_path, capsys, typed, said):
    """A first `patients add` with a value out of range made the data folder and an empty
    registry before the registry refused the patient, and the refusal named the registry's
    field (upper_arm_m) rather than the option typed. The values are checked first."""
    new = tmp_path / "data"
    code, _, err = run(["--data-dir", str(new), "patients", "add", "--first-name", "A",
                        *typed], capsys)
    assert code == 2
    assert err.count("\n") == 1, err
    assert said in err
    assert not new.exists()


def test_a_run_without_a_patient_creates_nothing(tmp_path, capsys):
    """The README's first `rehab run --patient weak`, from a fresh clone: it made the data
    folder and a file in its trials/simulated/ that no command lists, where the README
    says only `patients add` starts a data folder. It prints the figures and keeps nothing
    (its file only with --output, or registered with --code)."""
    new = tmp_path / "data"
    code, out, err = run(["--data-dir", str(new), "run", "--patient", "weak", "--repetitions",
                          "1", "--duration", "3"], capsys)
    assert code == 0, err
    assert "File: not kept (--output FILE keeps it; --code CODE registers it" in out
    assert "Directional performance" in out
    assert not new.exists()
    kept = tmp_path / "kept.h5"
    code, out, err = run(["--data-dir", str(new), "run", "--repetitions", "1", "--duration",
                          "3", "--output", str(kept)], capsys)
    assert code == 0, err
    assert f"File: {kept}" in out
    assert kept.is_file()
    assert not new.exists()


def test_simulated_trials_before_the_first_patient_do_not_block_the_registry(tmp_path,
                                                                             capsys):
    """A data folder where an earlier console's `rehab run --patient weak` (before
    2026-12-06) left its unregistered file in trials/simulated/, then `rehab patients add`.
    The simulated files belong to no registry, so they orphan nothing; they used to be
    counted as a lost registry's trials and every first `patients add` was refused."""
    new = tmp_path / "data"
    simulated = new / "trials" / "simulated"
    simulated.mkdir(parents=True)
    (simulated / "SIM_weak_20260101T000000Z.h5").write_bytes(b"a trial")
    code, _, err = run(["--data-dir", str(new), "patients"], capsys)
    assert code == 2
    assert "only `rehab run`'s unregistered simulated trials" in err
    code, _, err = run(["--data-dir", str(new), "patients", "add", "--first-name", "A"],
                         capsys)
    assert code == 0, err
    assert (new / "registry.sqlite3").is_file()


def test_a_registered_trial_beside_simulated_ones_still_asks_for_the_registry(tmp_path,
                                                                             capsys):
    new = tmp_path / "data"
    (new / "trials" / "simulated").mkdir(parents=True)
    (new / "trials" / "simulated" / "SIM_weak_20260101T000000Z.h5").write_bytes(b"x")
    (new / "trials" / "P0000000").mkdir()
    (new / "trials" / "P0000000" / "P0000000_S001_T001_20260101T000000Z.h5").write_bytes(b"x")
    code, _, err = run(["--data-dir", str(new), "patients", "add", "--first-name", "A"],
                       capsys)
    assert code == 2
    assert "holds 1 trial file(s)" in err
    assert not (new / "registry.sqlite3").exists()
