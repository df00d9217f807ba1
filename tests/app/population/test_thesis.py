"""The virtual population on the thesis's experiment (app.population.thesis): the cause of
the old gap (the console's stiff SMC, not the subject) and the held-out figures of
section 3.6 inside the population's spread; the worker pool keeps the subjects' order."""

from __future__ import annotations

import functools

import pytest

from app.population.pool import check_workers, map_subjects
from app.population.thesis import THESIS_FIGURES, against_thesis, thesis_figures
from app.trials.analysis import analyse
from app.trials.headless import simulate
from core.errors import ParameterError
from core.trial import THESIS_SUBJECT, thesis_experiment
from device.sim.population import draw_population, draw_subject

HELD_OUT = [f for f in THESIS_FIGURES if f.role == "held out"]


@pytest.fixture(scope="module")
def population():
    return against_thesis(12, 0, workers=1)


def test_the_held_out_thesis_figures_lie_inside_the_population_spread(population):
    rows, spreads = population
    assert sum(not r["refused"] for r in rows) >= 10
    assert all(r.get("status") == "complete" for r in rows if not r["refused"])
    inside = {s.figure.key: s.contains_thesis for s in spreads}
    # the thesis's x force range (0.835 N: its subject never pushed towards +x) is the one
    # held-out figure the model misses; docs/validation.md says so
    for f in HELD_OUT:
        if f.key != "force_range_x_N":
            assert inside[f.key], f.label
    for key in ("rmse_x_m", "rmse_y_m"):
        assert inside[key], key


def test_the_console_smc_not_the_subject_made_the_old_gap():
    """With the console's stiff SMC the calibrated subject still tracks within 2 mm and
    the corners' transients set a force range several times the thesis's; with the thesis's
    identified SMC the same subject is at the thesis's millimetres and newtons."""
    subject = draw_subject(0, 2)

    def run(params):
        trial = simulate(params, patient="healthy", seed=0,
                         patient_options=subject.patient_options(side="right", guided=True))
        channels = {n: trial.records[n] for n in trial.records.dtype.names}
        return analyse(channels, params).metrics

    stiff = run(THESIS_SUBJECT.replace(repetitions=3))
    soft = run(thesis_experiment(repetitions=3))
    assert max(stiff.rmse_x_m, stiff.rmse_y_m) < 2e-3
    assert stiff.force_range_y_N > 2 * 2.528
    assert min(soft.rmse_x_m, soft.rmse_y_m) > 4e-3
    assert soft.force_range_y_N < 1.5 * 2.528


def test_a_subject_out_of_the_ds_reach_is_left_out_with_the_reason():
    subject = draw_subject(0, 0)
    short = type(subject)(**{**{f: getattr(subject, f) for f in subject.__slots__},
                             "upper_arm_m": 0.2, "forearm_m": 0.2})
    row = thesis_figures(short, repetitions=1)
    assert "reach" in row["refused"].lower()
    assert all(row[f.key] != row[f.key] for f in THESIS_FIGURES)  # NaN


def test_the_pool_returns_results_in_the_subjects_order_whatever_the_workers():
    work = functools.partial(draw_subject, 5)
    assert map_subjects(work, range(9), workers=2) == map_subjects(work, range(9), workers=1)
    assert map_subjects(work, range(9), workers=1) == list(draw_population(9, 5))


@pytest.mark.parametrize("workers", [0, -1, True, 1.5, 65, "2"])
def test_a_bad_worker_count_is_refused_by_name(workers):
    with pytest.raises(ParameterError, match="workers"):
        check_workers(workers)
