"""`rehab export` refuses in one line, exit 2 and nothing written, what would otherwise
make an empty export or drop an option without a word: a --folder with no trial file to
export (it wrote an empty trials.csv and said 'exported 0 trial(s)', exit 0), --digits or
--exercise-only with BIDS, --include-names or --include-invalid where they do nothing, and
a --patient that is no code (never echoed: it may be a name)."""

from __future__ import annotations

import pytest

from tests.app.cli.running import run
from tests.app.exports.test_export_invalid import marked  # noqa: F401  (a fixture)


def refused(args, capsys) -> str:
    code, out, err = run(["export", *args], capsys)
    assert code == 2, err
    assert out == ""
    assert err.startswith("rehab export: error: "), err
    assert err.count("\n") == 1, err
    return err


def test_a_folder_without_trial_files_is_refused_and_nothing_written(tmp_path, capsys,
                                                                      marked):  # noqa: F811
    empty = tmp_path / "notes"
    empty.mkdir()
    (empty / "readme.txt").write_text("no trials here\n")
    out = tmp_path / "out"
    err = refused(["--folder", str(empty), "--output", str(out)], capsys)
    assert "holds no trial files (*.h5) below it" in err
    assert not out.exists()


def test_a_folder_of_only_invalid_trials_says_so(tmp_path, capsys, marked):  # noqa: F811
    registry, _, ids = marked
    only = tmp_path / "only"
    only.mkdir()
    (only / "t.h5").symlink_to(registry.trial_path(registry.trial(ids[1])))
    err = refused(["--folder", str(only), "--output", str(tmp_path / "out")], capsys)
    assert "holds only 1 trial(s) marked invalid (--include-invalid exports them)" in err


@pytest.mark.parametrize(("args", "said"), [
    (["--format", "bids", "--digits", "3"], "--digits applies to csv, tsv and mat"),
    (["--format", "bids", "--exercise-only"], "--exercise-only applies to csv, tsv and mat"),
    (["--include-invalid"], "--include-invalid is for --patient and --folder"),
    (["--include-names"], "--include-names works with --patient"),
])
def test_an_option_that_would_do_nothing_is_refused(args, said, tmp_path, capsys,
                                                    marked):  # noqa: F811
    err = refused(["--trial", "1", *args, "--output", str(tmp_path / "out")], capsys)
    assert said in err
    assert not (tmp_path / "out").exists()


def test_a_patient_that_is_no_code_is_not_echoed(tmp_path, capsys, marked):  # noqa: F811
    err = refused(["--patient", "Ada Example", "--output", str(tmp_path / "out")], capsys)
    assert "--patient is not a patient code" in err
    assert "Ada" not in err
