"""A task run in memory (app.assessments.runner, `in_memory`: a virtual population's visits)
writes no file and gives the figures the same trial's file gives, to the bit: the same
function computes them, from whole arrays instead of a block at a time."""

from __future__ import annotations

import math

import pytest

from app.assessments.runner import run_task
from app.errors import AppError
from core.assessment import TASKS


@pytest.mark.parametrize("task", TASKS)
def test_a_task_in_memory_gives_its_files_figures_and_writes_nothing(task, tmp_path,
                                                                      monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "files").mkdir()
    on_file = run_task(task, "weak", seed=4, folder=tmp_path / "files")
    before = sorted(tmp_path.rglob("*"))
    in_memory = run_task(task, "weak", seed=4, in_memory=True)
    assert sorted(tmp_path.rglob("*")) == before  # nothing written anywhere
    assert len(in_memory) == len(on_file)
    for memory, file in zip(in_memory, on_file, strict=True):
        assert memory.path is None
        assert file.path is not None
        assert memory.status == file.status
        assert memory.figures.keys() == file.figures.keys()
        assert memory.figures
        for key, value in file.figures.items():
            if math.isnan(value):
                assert math.isnan(memory.figures[key]), key
            else:
                assert memory.figures[key] == value, key


def test_in_memory_takes_no_folder_nor_registry(tmp_path):
    with pytest.raises(AppError, match="writes no file"):
        run_task("circle", "weak", in_memory=True, folder=tmp_path)


def test_a_trial_too_short_in_memory_says_what_its_file_says(tmp_path, monkeypatch):
    """A trial with too little exercise for its figures (a fault in the approach) is noted
    in memory with the very sentence its file's analysis refuses it with."""
    monkeypatch.setattr("app.trials.analysis.MIN_EXERCISE", 10 ** 9)  # no trial is enough
    (tmp_path / "files").mkdir()
    on_file = run_task("position", "weak", seed=4, folder=tmp_path / "files")
    in_memory = run_task("position", "weak", seed=4, in_memory=True)
    for memory, file in zip(in_memory, on_file, strict=True):
        assert not memory.figures
        assert not file.figures
        assert memory.notes == file.notes
        assert "at least 1000000000" in memory.notes[0]
