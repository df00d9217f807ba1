"""The circle task's two trials (one each way round) hold the task's figures (both ways'
mean) in both their files and registry rows: `rehab assess run` and `rehab assess show`
print each trial's own way once and the task's figures, with its task score, once for the
pair, naming the trials they come from."""

from __future__ import annotations

import re

import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from tests.app.cli.running import run

MEAN = "  Circle ratio: "  # the task's figure: the mean of the two ways


@pytest.fixture
def scored(data, capsys) -> str:
    """A patient the norms can score: their birth year, sex and handedness recorded."""
    code, out, _ = run(["patients", "add", "--first-name", "Ada", "--last-name", "Circle",
                        "--body-mass", "80", "--upper-arm", "0.30", "--forearm", "0.29",
                        "--side", "right", "--shoulder", "-0.12", "0.73", "--birth-year",
                        "1960", "--sex", "female", "--handedness", "right"], capsys)
    assert code == 0
    return out.strip()


def _once_each(out: str, first: int, second: int) -> None:
    assert out.count(MEAN) == 1, out
    assert out.count("  Circle ratio (cw): ") == 1, out
    assert out.count("  Circle ratio (ccw): ") == 1, out
    assert out.count(f"Circle drawing — both ways, from trial ids {first} and {second}") == 1, (
        out)
    lines = out.splitlines()
    # each way's figures under its own trial, the pair's under both
    assert lines.index(f"Circle drawing — both ways, from trial ids {first} and {second}") > max(
        i for i, line in enumerate(lines) if "(ccw): " in line or "(cw): " in line)
    heads = [line for line in lines if line.startswith("Circle drawing — trial")]
    assert [h.endswith("clockwise") for h in heads] == [True, True]
    # the registry's id named as such, the patient's own numbering beside it (the run
    # printed "trial 3" for a new patient's first trial: the data folder's third)
    assert heads[0].startswith(f"Circle drawing — trial id {first}, complete, session 1, "
                               "trial 1,"), heads
    assert heads[1].startswith(f"Circle drawing — trial id {second}, complete, session 1, "
                               "trial 2,"), heads
    assert "counter-clockwise" in heads[1]
    assert "counter-clockwise" not in heads[0]


def test_the_pair_s_figures_are_shown_once(data, scored, capsys):
    code, out, err = run(["assess", "run", scored, "--task", "circle", "--patient", "weak"],
                         capsys)
    assert code == 0, err
    first, second = (t.id for t in Registry(DataDir(data)).trials_for_patient(scored))
    _once_each(out, first, second)
    code, out, err = run(["assess", "show", scored], capsys)
    assert code == 0, err
    _once_each(out, first, second)
    assert out.count("Task score") == 1, out  # the pair's, against the shipped norms
    (pair,) = re.findall(r"both ways, from trial ids.*?(?=\n\S|\Z)", out, re.S)
    assert "Task score" in pair
    assert "   Z " in pair
    # the record stays as written: both rows hold the pair's figures
    registry = Registry(DataDir(data))
    for trial in registry.trials_for_patient(scored):
        assert "circle_ratio" in trial.metrics
