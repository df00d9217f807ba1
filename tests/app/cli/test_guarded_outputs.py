"""Every file a command writes by a name goes through one guarded write (issue 28 #1):
never over an existing file unless `--overwrite`, never over the registry, a trial file, a
model or anything else the data folder keeps (`--overwrite` or not), whole or not at all,
0600 whatever the umask. `rehab learn pendulum|robot-data|train --output PATH` once
replaced the registry, a trial file and an approved EMG model, exit 0."""

from __future__ import annotations

import hashlib
import os
import stat
from pathlib import Path

import pytest

from tests.app.cli.running import run

pytestmark = pytest.mark.usefixtures("data")  # the folders of tests/app/cli/conftest.py


def digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def kept(data, capsys):
    """A data folder with what it keeps: the registry, a trial file, an approved EMG model
    and a learned model (their content does not matter: where they are does)."""
    code, out, err = run(["patients", "add", "--first-name", "Ada", "--last-name", "Test"],
                         capsys)
    assert code == 0, err
    patient = out.strip()
    code, _, err = run(["run", "--code", patient, "--repetitions", "1", "--duration", "3"],
                       capsys)
    assert code == 0, err
    (data / "models" / "emg").mkdir(parents=True)
    (data / "models" / "emg" / "s1.json").write_text('{"approved": true}')
    (data / "models" / "m.json").write_text('{"model": true}')
    trial = next((data / "trials" / patient).glob("*.h5"))
    return {"registry": data / "registry.sqlite3", "trial file": trial,
            "EMG model": data / "models" / "emg" / "s1.json",
            "learned model": data / "models" / "m.json"}


def writers(target, trial, pendulum):
    """(name, argv) of every command that writes a file named by --output."""
    return [
        ("pendulum", ["learn", "pendulum", "--speeds", "1", "2", "--output", str(target)]),
        ("robot-data", ["learn", "robot-data", "--trials", str(trial), "--output", str(target)]),
        ("train", ["learn", "train", "--model", "fnn", "--data", str(pendulum), "--output",
                   str(target), "--epochs", "1", "--folds", "1", "--hidden", "2"]),
        ("components", ["learn", "components", "--model", str(target), "--data",
                        str(pendulum), "--output", str(target)]),
        ("report", ["report", "1", "--output", str(target)]),
    ]


@pytest.mark.parametrize("overwrite", [False, True])
def test_nothing_the_data_folder_keeps_is_ever_written_over(kept, tmp_path, capsys, overwrite):
    pendulum = tmp_path / "p.h5"
    assert run(["learn", "pendulum", "--speeds", "1", "2", "--output", str(pendulum)],
               capsys)[0] == 0
    before = {name: digest(path) for name, path in kept.items()}
    for what, path in kept.items():
        for name, argv in writers(path, kept["trial file"], pendulum):
            argv = [*argv, "--overwrite"] if overwrite else argv
            code, _, err = run(argv, capsys)
            assert code == 2, (what, name, err)
            assert err.count("\n") == 1, (what, name, err)
            assert {n: digest(p) for n, p in kept.items()} == before, (what, name)
    code, out, err = run(["patients"], capsys)
    assert code == 0, err  # the registry is still the registry
    assert "Test" in out


def test_a_new_file_in_the_data_folder_is_refused_but_in_its_exports_and_reports(
        kept, data, tmp_path, capsys):
    for inside in (data / "trials" / "x.h5", data / "x.h5", data / "models" / "new.h5",
                   data / "logs" / "x.h5"):
        code, _, err = run(["learn", "pendulum", "--speeds", "1", "2", "--output",
                            str(inside)], capsys)
        assert code == 2, inside
        assert "inside the data folder" in err
        assert not inside.exists()
    (data / "exports").mkdir(exist_ok=True)
    code, _, err = run(["learn", "pendulum", "--speeds", "1", "2", "--output",
                        str(data / "exports" / "p.h5")], capsys)
    assert code == 0, err


def test_an_existing_file_is_kept_unless_overwrite_and_then_replaced_whole(tmp_path, capsys,
                                                                            monkeypatch):
    old = os.umask(0o022)  # the library's own modes, whatever the shell's
    try:
        from app.learning.dataset import write_dataset
        from app.learning.workflow import make_pendulum_file

        target = tmp_path / "p.h5"
        make_pendulum_file(target, [1.0, 2.0], None)
        assert stat.S_IMODE(target.stat().st_mode) == 0o600
        first = digest(target)
        code, _, err = run(["learn", "pendulum", "--speeds", "3", "4", "--output",
                            str(target)], capsys)
        assert code == 2
        assert "already exists and is kept" in err
        assert "--overwrite" in err
        assert digest(target) == first
        # a write that fails half-way leaves the old file and no half of the new one
        import h5py

        from app.learning import dataset

        data = dataset.read_dataset(target)

        def broken(*args, **kwargs):
            raise OSError(28, "No space left on device")

        create_dataset = h5py.Group.create_dataset
        monkeypatch.setattr(h5py.Group, "create_dataset", broken)
        with pytest.raises(Exception, match="No space left on device"):
            write_dataset(target, data, overwrite=True)
        monkeypatch.setattr(h5py.Group, "create_dataset", create_dataset)
        assert digest(target) == first
        assert sorted(p.name for p in tmp_path.iterdir()) == ["p.h5"]
        code, _, err = run(["learn", "pendulum", "--speeds", "3", "4", "--output",
                            str(target), "--overwrite"], capsys)
        assert code == 0, err
        assert digest(target) != first
        assert stat.S_IMODE(target.stat().st_mode) == 0o600
    finally:
        os.umask(old)


def test_an_output_that_is_one_of_the_inputs_is_refused(kept, tmp_path, capsys):
    trial = tmp_path / "copy.h5"
    trial.write_bytes(kept["trial file"].read_bytes())
    code, _, err = run(["learn", "robot-data", "--trials", str(trial), "--output", str(trial),
                        "--overwrite"], capsys)
    assert code == 2
    assert "also one of the command's inputs" in err
    assert trial.read_bytes() == kept["trial file"].read_bytes()


def test_a_sqlite_database_anywhere_is_never_written_over(kept, tmp_path, capsys):
    copy = tmp_path / "backup.db"
    copy.write_bytes(kept["registry"].read_bytes())
    code, _, err = run(["learn", "pendulum", "--speeds", "1", "2", "--output", str(copy),
                        "--overwrite"], capsys)
    assert code == 2
    assert "SQLite database" in err
    assert copy.read_bytes() == kept["registry"].read_bytes()


def test_emg_record_and_demo_keep_existing_files(tmp_path, capsys):
    existing = tmp_path / "mvc.csv"
    existing.write_text("keep me")
    code, _, err = run(["emg", "record", "lsl:nothing", "--output", str(existing)], capsys)
    assert code == 2
    assert "already exists" in err
    assert existing.read_text() == "keep me"
    (tmp_path / "demo").mkdir()
    kept_csv = tmp_path / "demo" / "S2_session1_mvc_biceps.csv"
    kept_csv.write_text("keep me too")
    code, _, err = run(["emg", "demo", str(tmp_path / "demo")], capsys)
    assert code == 2
    assert "already exists" in err
    assert kept_csv.read_text() == "keep me too"
    assert sorted(p.name for p in (tmp_path / "demo").iterdir()) == [kept_csv.name]


def test_the_report_the_data_folder_holds_is_written_again_only_when_asked(kept, capsys):
    code, out, err = run(["report", "1"], capsys)
    assert code == 0, err
    report = Path(out.strip())
    first = digest(report)
    code, _, err = run(["report", "1"], capsys)
    assert code == 2
    assert "already exists and is kept" in err
    assert digest(report) == first
    code, _, err = run(["report", "1", "--overwrite"], capsys)
    assert code == 0, err


@pytest.mark.parametrize("command", [["export", "--format", "csv", "--folder", "{data}",
                                      "--output", "{out}"],
                                     ["study", "analyse", "{data}/trials", "--output", "{out}"]])
def test_a_refused_output_folder_is_named_as_given(kept, data, capsys, command):
    """The refusal names the folder the user gave: it said '…/trials/_', a probe's name
    inside it the user never typed."""
    inside = data / "trials"
    args = [a.format(data=data, out=inside) for a in command]
    code, _, err = run(args, capsys)
    assert code == 2, err
    assert f" {inside} is inside the data folder" in err, err
    assert f"{inside}/_" not in err
