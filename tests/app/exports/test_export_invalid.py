"""A trial marked invalid (schema v8) is left out of study exports, with a note saying so,
unless asked (--include-invalid); its file and its registry row stay as they are."""

import pytest

from app.exports.run import export_patient
from app.records.datadir import DataDir
from app.records.registry import Registry
from tests.app.cli.running import run
from tests.app.exports.test_export import D, read_rows, write


@pytest.fixture
def marked(tmp_path, monkeypatch):
    """A data folder (REHAB_DATA_DIR) with a patient's three trials, the second marked
    invalid."""
    data = tmp_path / "data"
    monkeypatch.setenv("REHAB_DATA_DIR", str(data))
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    registry = Registry(DataDir(data))
    code = registry.create_patient("Ada", "Example").code
    ids = []
    for seed in range(3):
        begun = registry.begin_trial(code, D, backend="simulator", session_number=1)
        write(begun.path, seed=seed, code=code)
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.001})
        ids.append(begun.trial_id)
    registry.mark_trial(ids[1], valid=False, reason="let go of the handle", by="K. Lee")
    return registry, code, ids


def exported_trials(folder):
    return [int(r[2]) for r in read_rows(folder / "trials.csv", ",")[1:]]


def test_a_patient_export_leaves_an_invalid_trial_out_unless_asked(marked, tmp_path):
    registry, code, ids = marked
    left = export_patient(registry, code, tmp_path / "out")
    assert exported_trials(left.folder) == [1, 3]
    assert any("1 trial(s) marked invalid left out" in note for note in left.notes)
    every = export_patient(registry, code, tmp_path / "all", include_invalid=True)
    assert exported_trials(every.folder) == [1, 2, 3]
    assert not any("invalid" in note for note in every.notes)
    assert registry.trial_path(registry.trial(ids[1])).is_file()


def test_the_command_line_export_of_a_patient_or_the_trials_folder_leaves_it_out(
        marked, tmp_path, capsys):
    registry, code, _ = marked
    trials = registry.data_dir.trials_dir
    for what in (["--patient", code], ["--folder", str(trials)]):
        out_folder = tmp_path / f"out{len(what[1])}"
        status, out, _ = run(["export", *what, "--format", "csv", "--output",
                              str(out_folder)], capsys)
        assert status == 0
        assert "exported 2 trial(s)" in out
        assert "1 trial(s) marked invalid left out" in out
        status, out, _ = run(["export", *what, "--format", "csv", "--output",
                              str(out_folder) + "-all", "--include-invalid"], capsys)
        assert status == 0
        assert "exported 3 trial(s)" in out
