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


def test_an_invalid_trial_exported_on_request_says_why_it_is_marked(marked, tmp_path, capsys):
    """With --include-invalid the marked trial was exported as any other: nothing in
    trials.csv, its `_trial` table, a .mat or a BIDS scans file said it was invalid."""
    import csv

    import scipy.io

    registry, code, ids = marked
    stem = registry.trial_path(registry.trial(ids[1])).stem
    trials = registry.data_dir.trials_dir
    for what, fmt in ((["--patient", code], "csv"), (["--folder", str(trials)], "csv"),
                      (["--trial", str(ids[1])], "mat"), (["--patient", code], "bids")):
        out = tmp_path / f"{what[0][2:]}-{fmt}"
        extra = [] if what[0] == "--trial" else ["--include-invalid"]
        status, _, err = run(["export", *what, "--format", fmt, "--output", str(out), *extra],
                             capsys)
        assert status == 0, err
        if fmt == "csv":
            with (out / "trials.csv").open(encoding="utf-8", newline="") as stream:
                rows = {int(r["trial"]): r["invalid_reason"] for r in csv.DictReader(stream)}
            assert rows == {1: "", 2: "let go of the handle", 3: ""}
            (table,) = out.rglob(f"{stem}_trial.csv")
            assert "invalid_reason,let go of the handle\n" in table.read_text()
        elif fmt == "mat":
            mat = scipy.io.loadmat(out / f"{stem}.mat", simplify_cells=True)
            assert mat["export"]["invalid_reason"] == "let go of the handle"
        else:
            (scans,) = out.rglob("*_scans.tsv")
            lines = scans.read_text().splitlines()
            assert lines[0].split("\t")[-1] == "invalid_reason"
            assert [line.split("\t")[-1] for line in lines[1:]] == [
                "n/a", "let go of the handle", "n/a"]
