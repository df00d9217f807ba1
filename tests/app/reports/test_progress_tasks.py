"""An assessment's or a game's trials are their own series in Progress, named by the task
or the game: the battery's circle (transparent, r 7 cm) was one series with the circle
exercise done transparent at r 7 cm, named "Transparent · circle, r 7.0 cm", so a
patient's exercise and their assessment read as one trend. Through the commands a
therapist or a researcher runs."""

from __future__ import annotations

import csv
import io

import pytest

from app.cli.main import main
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.progress import Exercise, progress


@pytest.fixture
def course(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("REHAB_DATA_DIR", str(tmp_path / "data"))
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Example", side="right").code
    exercise = ["run", "--code", code, "--patient", "healthy", "--trajectory", "circle",
                "--radius", "0.07", "--assist", "transparent", "--repetitions", "1",
                "--seed", "1"]
    assert main(exercise) == 0
    assert main(["assess", "run", code, "--task", "circle", "--seed", "2"]) == 0
    assert main([*exercise, "--seed", "3"]) == 0
    assert main(["run", "--code", code, "--patient", "healthy", "--trajectory", "circle",
                 "--radius", "0.07", "--game", "path", "--repetitions", "1", "--seed",
                 "4"]) == 0
    capsys.readouterr()
    return registry, code


def test_an_assessment_and_a_game_are_their_own_series_named_by_what_they_were(course,
                                                                             capsys):
    registry, code = course
    result = progress(registry, code)
    tasks = [(e.assessment, e.game) for e in result.exercises]
    assert tasks == [("", ""), ("circle", ""), ("", "path")]
    plain, assessed, game = result.exercises
    assert plain == Exercise("transparent", "circle", 0.07, "smc")
    # the battery's circle: both ways, in one series of its own; the exercise's two
    # trials in theirs, around it
    assert result.exercise_index.tolist() == [0, 1, 1, 0, 2]
    assert assessed.label().startswith("Assessment: Circle drawing · Transparent · circle")
    assert game.label().startswith("Path game · ")
    assert not plain.label().startswith(("Assessment", "Path game"))
    assert main(["progress", code]) == 0
    out = capsys.readouterr().out
    assert "exercise 2: Assessment: Circle drawing · Transparent · circle, r 7.0 cm" in out
    assert main(["progress", code, "--csv"]) == 0
    rows = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
    assert [(r["assessment"], r["game"]) for r in rows] == [
        ("", ""), ("circle", ""), ("circle", ""), ("", ""), ("", "path")]


def test_a_trial_stored_before_the_tasks_stays_in_its_exercise_s_series(course):
    """A trial registered before a parameter existed ran without it: its exercise series
    and its comparisons are the same as those of the trials after."""
    registry, code = course
    (first, *_) = registry.trials_for_patient(code)
    stored = dict(first.parameters)
    for name in ("assessment", "game"):
        stored.pop(name)
    from app.records.registry import key_values

    assert key_values(stored) == key_values(first.parameters)
    later = registry.trials_for_patient(code)[3]
    assert registry.previous_trial(later.id, same_parameters=True).id == first.id


def test_a_report_names_the_task_or_the_game_it_was(course):
    """The report's Exercise line said only the shape: the battery's circle read as the
    circle exercise (brief hI, in the window)."""
    from app.reports.build import content_for_registry_trial

    registry, code = course
    trials = registry.trials_for_patient(code)
    lines = [{item.label: item.value for item in
              content_for_registry_trial(registry, t.id).header}["Exercise"] for t in trials]
    assert lines[1].startswith("Circle drawing (assessment): circle, radius 7 cm")
    assert lines[4].startswith("Path game: circle, radius 7 cm")
    assert lines[0].startswith("circle, radius 7 cm")


def test_an_assessment_s_series_shows_its_task_s_figures_not_the_tracking_ones(course,
                                                                               capsys):
    """`rehab progress` printed RMSE and directional performance for the battery's circle,
    whose reference moves at the task's pace: its own figures (circle ratio, joint
    independence, …) were not shown. The tab, its PDF and the command choose the figures
    in one place (figure_rows)."""
    from app.reports.progress_figure import figure_rows, progress_figure
    from core.assessment.figures import task_figures

    registry, code = course
    result = progress(registry, code)
    rows = figure_rows(result, 1)
    assert [r.key for r in rows] == [s.key for s in task_figures("circle")]
    assert progress_figure(result, 1).row.key == "circle_ratio"
    assert figure_rows(result, 0)[0].key == "rmse_x_m"  # transparent: no "rmse" stored
    assert "circle_ratio" not in [r.key for r in figure_rows(result, 0)]
    assert main(["progress", code]) == 0
    out = capsys.readouterr().out
    blocks = out.split("\nexercise ")
    assert len(blocks) == 4
    task = blocks[2]
    assert task.startswith("2: Assessment: Circle drawing · ")
    lines = task.splitlines()
    assert lines[1].split() == ["figure", "S1", "T2", "S1", "T3"]
    assert lines[2].split()[0] == "station"  # this console's, each run's
    assert lines[3].split() == ["status", "complete", "complete"]
    trials = registry.trials_for_patient(code)[1:3]
    ratio = next(line for line in lines if line.startswith("Circle ratio  "))
    assert ratio.split()[2:] == [f"{t.metrics['circle_ratio']:.4g}" for t in trials]
    assert "RMSE" not in task
    assert "Direction" not in task
    assert "RMSE x" in blocks[1]
    assert "Circle ratio" not in blocks[1]


def test_an_assessment_series_writes_no_lap_or_tolerance_over_its_trials(course):
    """The strength test's Progress read '3 s a lap · ±20°' over its first trial: a push,
    not a lap, and a tolerance its protocol fixes. An exercise keeps its marks."""
    from app.reports.progress_figure import progress_figure

    registry, code = course
    result = progress(registry, code)
    for index, exercise in enumerate(result.exercises):
        marks = progress_figure(result, index).marks
        assert (marks == ()) == bool(exercise.assessment), exercise.label()
