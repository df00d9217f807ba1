"""The simulated normative model (app.population.norms): the population through the
battery, fitted by the norms' fitter, MDC95 from the retest, labelled simulated on load,
the same whatever the number of workers."""

from __future__ import annotations

import datetime
import math

import pytest

from app.norms import SIMULATED_LABEL, load_norms, write_norms
from app.population.norms import (
    ROBOT,
    Visit,
    arm_tested,
    battery_figures,
    build_simulated_norms,
    source_text,
)
from device.sim.population import draw_population

N = 24  # the fitter needs 20 controls with a figure


@pytest.fixture(scope="module")
def built():
    return build_simulated_norms(N, 1, workers=2, tasks=("circle",))


@pytest.mark.slow
def test_the_simulated_norms_are_fitted_labelled_and_carry_mdc(built, tmp_path):
    doc = built.document
    assert doc["simulated"] is True
    assert doc["source"].startswith(f"{N} virtual healthy adults made by the console's "
                                    "simulator")
    assert "each tested twice in circle drawing" in doc["source"]
    assert set(doc["tasks"]) == {"circle"}
    ratio = doc["figures"]["circle_ratio"]
    # a covariate level with fewer than 5 controls is left out, and said so (the fitter,
    # app.norms.fitting): this seed draws 2 left-handers of 24
    left = sum(s.handedness == "left" for s in draw_population(N, 1))
    assert 0 < left < 5
    assert ratio["n"] == N - left
    assert "handedness=left" in built.fit.left_out
    assert ratio["mdc95"] > 0.0
    assert 0.0 < ratio["icc"] <= 1.0
    assert "mdc95" in doc["tasks"]["circle"]
    path = write_norms(tmp_path / "simulated.json", doc)
    model = load_norms(path)
    assert model.simulated
    assert SIMULATED_LABEL in model.label
    assert "robot" in doc["covariates"] or ROBOT in str(doc["covariates"])


@pytest.mark.slow
def test_the_rows_are_the_subjects_own_whatever_the_workers(built):
    """Visits rerun here in this process give the figures the two workers gave."""
    subjects = draw_population(N, 1)
    rows = {(r["subject"], r["session"]): r for r in built.rows}
    assert len(rows) == 2 * N
    for subject, session in ((subjects[0], 1), (subjects[5], 2)):
        again = battery_figures(Visit(subject, session, ("circle",)))
        first = rows[(subject.index, session)]
        assert again["side"] == first["side"] == arm_tested(subject)
        for key, value in first.items():
            if isinstance(value, float) and math.isnan(value):
                assert math.isnan(again[key]), key
            else:
                assert again[key] == value, key


def test_the_tested_arm_is_both_sides_and_the_subjects_own():
    subjects = draw_population(200, 0)
    sides = [arm_tested(s) for s in subjects]
    assert 70 <= sum(s == "left" for s in sides) <= 130
    dominant = sum(arm_tested(s) == s.handedness for s in subjects)
    assert 70 <= dominant <= 130
    assert sides == [arm_tested(s) for s in draw_population(200, 0)]


def test_the_source_says_who_how_many_how_often_and_when_in_words():
    """It named the module that draws the people (device.sim.population) and the one that
    fits them; now what a clinician reads under a Z-score."""
    day = datetime.date(2026, 3, 9)
    assert source_text(40, 7, ("circle", "position"), 0, day, retest=False) == (
        "40 virtual healthy adults made by the console's simulator, not measured people "
        "(random seed 7; none left out), each tested once in circle drawing and position "
        "sense on a simulated robot; fitted 9 Mar 2026")
    assert "(random seed 0; 3 of them left out, whom the battery could not test), each " \
           "tested twice in visually guided reaching, circle drawing and active range" in \
           source_text(500, 0, ("reaching", "circle", "range"), 3, day)
