"""The console's shipped simulated norms (resources/norms/simulated.json, built by
scripts/build_simulated_norms.py from 500 virtual healthy subjects): verified on load,
labelled simulated, a task score and an MDC95 for every task, what a data folder without
norms of its own uses, and on the virtual patients they do what norms are for: the weak
patient scores worse than the healthy one on every task (seed 3, a 60-year-old
right-handed woman's norms: 5.73 against 1.65 in reaching, 8.30/0.37 circle, 6.73/0.12
range, 6.86/1.05 strength, 6.48/1.40 position sense on 2026-12-05, the norms refitted with
λ bounded), and the passive one worst of all (reaching, circle and position not performed,
range 12.66, strength 10.52)."""

from __future__ import annotations

import math
import re

import pytest

from app.assessments.runner import run_battery
from app.norms import SIMULATED_LABEL, Covariates, TaskNotPerformed, load_norms
from app.norms.in_use import SHIPPED, norms_in_use
from app.records.datadir import DataDir
from core.assessment import TASKS
from core.trial import TrialParameters

PERSON = Covariates(60.0, "female", "right", "right", "simulator-realistic")
NORMED = TASKS
"""The tasks the shipped norms score (strength by its mean forces: its peaks are capped by
the robot, below)."""


@pytest.fixture(scope="module")
def shipped():
    return load_norms(SHIPPED)


def _controls(shipped) -> int:
    """The controls the norms were fitted on: the subjects less those refused, as the
    source says ('500 virtual healthy adults … (random seed 0; 12 of them left out …')."""
    found = re.search(r"(\d+) virtual healthy adults .*\(random seed \d+; (\d+) of them "
                      r"left out", shipped.source)
    assert found, shipped.source
    return int(found[1]) - int(found[2])


def test_the_shipped_norms_are_verified_and_labelled_simulated(shipped):
    assert shipped.simulated
    assert SIMULATED_LABEL in shipped.label
    assert shipped.source.startswith("500 virtual healthy adults")
    assert set(shipped.tasks) == set(NORMED)
    assert all(t.mdc95 is not None and t.mdc95 > 0 for t in shipped.tasks.values())
    assert all(f.mdc95 is not None and f.mdc95 > 0 for f in shipped.figures.values())


def test_the_shipped_norms_say_where_they_come_from_in_words_a_clinician_reads(shipped):
    """The Assessments tab and the PDF reports printed "simulated: 500 virtual healthy
    subjects of device.sim.population (seed 0; 12 refused) … ; app.population.norms": a
    Python module's name. They say it in words, with how many, the seed and the day; the
    file's text rewritten by the norms' own writer, its checksum verified on load."""
    assert shipped.label == (
        "Norms: 500 virtual healthy adults made by the console's simulator, not measured "
        "people (random seed 0; 12 of them left out, whom the battery could not test), "
        "each tested twice in visually guided reaching, circle drawing, active range, "
        "isometric strength and position sense on a simulated robot; fitted 5 Dec 2026 "
        f"({SIMULATED_LABEL})")
    assert not re.search(r"[a-z]\.[a-z]", shipped.label)  # no module, no file name
    assert SHIPPED.read_text(encoding="utf-8").count(shipped.content_sha256) == 1


def test_every_held_out_control_is_scored_and_calibrated(shipped):
    """5-fold calibration over every control: each scored by its fold (97 were not, when
    one fold could not fit a rare count), held-out Z-scores with SD near 1."""
    held = shipped.calibration["held_out"]
    assert shipped.calibration["method"] == (
        f"5-fold cross-validation over {_controls(shipped)} controls")
    assert all(c["not_scored"] == 0 for c in held.values())
    for key, c in held.items():
        if not key.startswith("task:"):
            assert 0.9 < c["sd"] < 1.1, key


def test_the_robot_capped_strength_peaks_are_not_normed_and_the_page_says_why(shipped):
    """Every simulated control reached the robot's force limit (6-8 N) in every direction:
    no norms for the peaks, and the report says so once instead of Z-scores in the
    millions; the strength task score combines the mean forces."""
    from app.reports.assessment_page import assessment_page

    assert not any(key.startswith("strength_peak") for key in shipped.figures)
    assert "strength_mean_force_n" in shipped.figures
    assert shipped.tasks["strength"].figures == ("strength_mean_force_n",)
    n = _controls(shipped)
    assert f"{n} of {n} controls reached the robot's limit" in shipped.left_out(
        "strength_peak_force_n")
    metrics = {key: 5.0 for key in ("strength_peak_force_n", "strength_mean_force_n",
                                    "strength_peak_force_n_000")}
    page = assessment_page("strength", metrics, norms=shipped, person=PERSON)
    z = {line.key: line.z for line in page.lines}
    assert z["strength_peak_force_n"] is None
    assert z["strength_peak_force_n_000"] is None
    assert z["strength_mean_force_n"] is not None
    assert [n for n in page.notes if "reached the robot's limit" in n] == [
        f"no Z-score for Peak force 0°, Peak force (mean of directions): {n} of {n} "
        "controls reached the robot's limit, so their values are lower bounds, not theirs: "
        "a robot that holds more is needed to norm it"]
    assert page.task_score.startswith("Task score ")


def test_a_data_folder_without_norms_of_its_own_uses_the_shipped_ones(tmp_path, shipped):
    data = DataDir(tmp_path / "data")
    assert norms_in_use(data).source == shipped.source


@pytest.fixture(scope="module")
def scored(shipped):
    """Each virtual patient's battery, in memory, and its task scores (0 is best)."""
    out = {}
    for patient in ("healthy", "weak", "passive"):
        results = run_battery(patient, TrialParameters(), 3, in_memory=True)
        figures = {k: v for trials in results.values() for t in trials
                   for k, v in t.figures.items()}
        out[patient] = {task: _rank(shipped, task, figures) for task in NORMED}
    return out


def _rank(norms, task, figures) -> float:
    """The task score, or infinity for a task not performed (worse than any score)."""
    try:
        return norms.task_score(task, figures, PERSON).score
    except TaskNotPerformed:
        return math.inf


@pytest.mark.parametrize("task", NORMED)
def test_the_weak_patient_scores_worse_than_the_healthy(scored, task):
    healthy, weak = scored["healthy"][task], scored["weak"][task]
    assert math.isfinite(healthy)
    assert weak > healthy


@pytest.mark.parametrize("task", NORMED)
def test_the_passive_patient_scores_worst(scored, task):
    """The passive patient does not move: reaching, the circle and position sense are not
    performed (named, not a gap), and range scores worse than the weak one's."""
    assert scored["passive"][task] > scored["weak"][task]
    assert math.isinf(scored["passive"][task]) == (task in ("reaching", "circle", "position"))
