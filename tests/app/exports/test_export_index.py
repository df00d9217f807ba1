"""An earlier export's index merged into: a damaged one is refused in one line, a row
whose file is gone is dropped with a note, never silently."""

from __future__ import annotations

import csv
import os
import re
from pathlib import Path

import pytest

from app.exports.files import OutputExistsError
from app.exports.index import IndexDamaged, write_index

HEAD = "participant,session,trial,export_file,rmse_x_m\n"


def _folder(tmp_path: Path, earlier: bytes) -> Path:
    folder = tmp_path / "out"
    (folder / "P1").mkdir(parents=True)
    for name in ("P1/a.csv", "P1/b.csv"):
        (folder / name).write_text("t,x\n0,0\n")
    (folder / "trials.csv").write_bytes(earlier)
    return folder


def _new_row() -> dict:
    return {"participant": "P2", "session": 1, "trial": 1, "export_file": "P2/c.csv",
            "rmse_x_m": 0.002}


def _rows(path: Path) -> list[list[str]]:
    with path.open(newline="") as stream:
        return list(csv.reader(stream))


def test_an_earlier_row_whose_file_is_gone_is_dropped_with_a_note(tmp_path):
    """A flipped byte in an export_file cell (P1/a.csv read P1/q.csv) dropped the row
    without a word: the trial's file stayed, unlisted."""
    folder = _folder(tmp_path, (HEAD + "P1,1,1,P1/q.csv,0.001\nP1,1,2,P1/b.csv,0.003\n")
                     .encode())
    notes: list[str] = []
    write_index(folder / "trials.csv", [_new_row()], ".csv", False, notes)
    assert [r[3] for r in _rows(folder / "trials.csv")[1:]] == ["P1/b.csv", "P2/c.csv"]
    assert notes == [f"1 earlier row(s) of trials.csv dropped: their files are no longer "
                     f"in {folder} (first: P1/q.csv)"]


@pytest.mark.parametrize(("cell", "problem"), [
    ("/etc/hostname", "line 2 names the absolute path '/etc/hostname', outside the export "
                      "folder"),
    ("../elsewhere.csv", "line 2 names '../elsewhere.csv', outside the export folder"),
    ("P1/../../x.csv", "line 2 names 'P1/../../x.csv', outside the export folder"),
    ("C:\\\\trials\\\\a.csv", "line 2 names the absolute path"),
    ("", "line 2 names no export_file"),
])
@pytest.mark.parametrize("overwrite", [False, True])
def test_an_earlier_row_naming_a_file_outside_the_folder_is_refused(tmp_path, cell, problem,
                                                                    overwrite):
    """An absolute path in export_file was kept (the index then listed a file elsewhere as
    this export's); with overwrite too, since replacing the index drops its rows."""
    earlier = (HEAD + f"P1,1,1,{cell},0.001\nP1,1,2,P1/b.csv,0.003\n").encode()
    folder = _folder(tmp_path, earlier)
    (tmp_path / "elsewhere.csv").write_text("t,x\n")
    with pytest.raises(IndexDamaged) as caught:
        write_index(folder / "trials.csv", [_new_row()], ".csv", overwrite, [])
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"{folder / 'trials.csv'} is an index of the console's exports "
                              f"but {problem}")
    assert (folder / "trials.csv").read_bytes() == earlier


@pytest.mark.parametrize(("earlier", "problem"), [
    (HEAD + "P1,1,1,P1/a.csv\n", "line 2 has 4 cell(s) where the header has 5"),
    (HEAD + "P1,1,1,P1/a.csv,0.001,extra\n", "line 2 has 6 cell(s) where the header has 5"),
    (HEAD + "P1,1,1,P1/a.csv,0.001\nP\xe91,1,2,P1/b.csv,0.003\n", "line 3 is not UTF-8 text"),
    (HEAD + 'P1,1,1,"P1/a.csv\x00,0.001\n', "line 2 is not CSV"),
])
def test_an_earlier_index_that_does_not_parse_is_refused_in_one_line(tmp_path, earlier,
                                                                     problem):
    """A short row made a TypeError; a byte that is not UTF-8 made the index 'not the
    console's', replaced with overwrite, its rows lost."""
    data = earlier.encode("latin-1")
    folder = _folder(tmp_path, data)
    for overwrite in (False, True):
        with pytest.raises(IndexDamaged, match=re.escape(problem)):
            write_index(folder / "trials.csv", [_new_row()], ".csv", overwrite, [])
    assert (folder / "trials.csv").read_bytes() == data


def test_a_pipe_named_like_the_index_is_refused_not_waited_on(tmp_path):
    folder = tmp_path / "out"
    folder.mkdir()
    os.mkfifo(folder / "trials.csv")
    with pytest.raises(OutputExistsError, match="is not an index of the console's exports"):
        write_index(folder / "trials.csv", [_new_row()], ".csv", False, [])
