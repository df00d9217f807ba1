"""The simulated normative model: the virtual healthy population (device.sim.population)
through the assessment battery (app.assessments.runner), fitted by the norms' own fitter
(app.norms.fitting), with test-retest MDC95 from a second session, labelled simulated.

Each subject is tested on one arm, the dominant or the other with equal chance (drawn from
the subject's own stream: a population tested on the dominant arm alone would make tested
side and handedness the same covariate, which the fitter refuses), on the realistic plant,
in two sessions: session 1 is the subject's first go at the battery (learning left to do,
device.sim.population's LEARNING_*), session 2 the retest (the next trial of the subject's
learning, new seeds). The norms are fitted on session 1, as a study's controls are assessed
once; the retest gives each figure's and task score's ICC, SEM and MDC95
(app.norms.retest). Everything is drawn from the population's seed, the fit's folds from
seed 0: the same seed and size give the same model (every number; only the file's
created_utc and the day its source says it was fitted differ), whatever the number of
workers.

A visit's trials run in memory (app.assessments.runner, `in_memory`): no trial file is
written, the task figures are computed from the trials' whole arrays by the function a
trial file's figures come from. The figures are what the model keeps.
"""

from __future__ import annotations

import datetime
import math
from dataclasses import dataclass

import numpy as np

from app.errors import AppError
from app.norms import Covariates, NormsError
from app.norms.controls import robot_kind
from app.norms.fitting import Controls, FitReport, fit_norms
from app.norms.modelfile import norms_document, parse_norms
from app.norms.retest import retest_reliability, with_mdc
from app.population.pool import map_subjects
from core.assessment import FIGURES, TASK_TITLES, TASKS
from core.errors import CoreError
from core.trial import TrialParameters
from device.sim.population import HANDEDNESS, Subject, draw_population

PLANT = "realistic"
ROBOT = robot_kind("simulator", {"plant": PLANT})
SESSIONS = (1, 2)
"""The test and the retest."""


def arm_tested(subject: Subject) -> str:
    """The arm the subject is tested on: dominant or not with equal chance, from the
    subject's own stream."""
    stream = np.random.SeedSequence(subject.population_seed, spawn_key=(subject.index, 2))
    other = HANDEDNESS[1 - HANDEDNESS.index(subject.handedness)]
    return subject.handedness if np.random.default_rng(stream).random() < 0.5 else other


@dataclass(frozen=True, slots=True)
class Visit:
    """One subject's session of the battery."""

    subject: Subject
    session: int
    tasks: tuple[str, ...] = TASKS


def battery_figures(visit: Visit) -> dict:
    """The figures of `visit` (core.assessment.FIGURES keys; NaN where a trial gave none),
    with "subject", "session", "side" and "refused" ("" or why the battery was refused)."""
    from app.assessments.runner import run_battery

    subject, session = visit.subject, visit.session
    side = arm_tested(subject)
    trial = session - 1  # the subject's learning: the first session is trial 0
    base = subject.trial_parameters(TrialParameters(), side)
    out = {"subject": subject.index, "session": session, "side": side, "refused": ""}
    figures: dict[str, float] = {}
    try:
        results = run_battery("healthy", base, subject.trial_seed(trial) % 2**31,
                              tasks=visit.tasks, in_memory=True,
                              patient_options=subject.patient_options(trial, side, guided=False),
                              plant=PLANT)
        for trials in results.values():
            for task_trial in trials:
                figures.update(task_trial.figures)
    except (AppError, CoreError) as error:  # refused (out of reach, ...): kept with why
        out["refused"] = f"{type(error).__name__}: {error}"
    for key in FIGURES:
        value = figures.get(key, math.nan)
        out[key] = float(value) if value is not None else math.nan
    return out


def controls_of(rows: list[dict], subjects: dict[int, Subject], *, retest: bool) -> Controls:
    """The norms' Controls from battery rows: one row per subject (session 1), or with
    `retest` both sessions as '<code>#1' / '<code>#2'."""
    chosen = [r for r in rows if not r["refused"] and (retest or r["session"] == 1)]
    names, people = [], []
    for r in chosen:
        s = subjects[r["subject"]]
        names.append(f"{s.code}#{r['session']}" if retest else s.code)
        people.append(Covariates(s.age_years, s.sex, s.handedness, r["side"], ROBOT))
    figures = {key: np.array([r[key] for r in chosen], dtype=float) for key in FIGURES}
    figures = {k: v for k, v in figures.items() if np.isfinite(v).any()}
    return Controls(tuple(names), tuple(people), figures)


@dataclass(frozen=True)
class SimulatedNorms:
    document: dict
    """The norms document, with MDC95 where the retest gave one (write it with
    app.norms.write_norms)."""
    fit: FitReport
    rows: list[dict]
    """Every visit's figures, subject by subject, session 1 then 2."""
    skipped_mdc: dict[str, str]
    """Figure or task → why it has no MDC95."""
    left_out_mdc: dict[str, str]
    """Figure or task → who its test-retest table left out, and why (one line)."""


def source_text(n: int, seed: int, tasks, refused: int, day: datetime.date,
                retest: bool = True) -> str:
    """Where simulated norms come from, in words a clinician reads (their label adds
    "simulated — for demonstration and tests only", app.norms.SIMULATED_LABEL): how many
    virtual people, the seed that drew them, how many the battery could not test (a task
    out of the arm's reach), the tasks by their titles, how often, and the day they were
    fitted. It named the Python module that draws them ("… of device.sim.population")."""
    titles = [TASK_TITLES[task].lower() for task in tasks]
    listed = titles[0] if len(titles) == 1 else f"{', '.join(titles[:-1])} and {titles[-1]}"
    left_out = f"{refused} of them left out, whom the battery could not test" if refused \
        else "none left out"
    return (f"{n} virtual healthy adults made by the console's simulator, not measured "
            f"people (random seed {seed}; {left_out}), each tested "
            f"{'twice' if retest else 'once'} in {listed} on a simulated robot; fitted "
            f"{day.day} {day:%b %Y}")


def build_simulated_norms(n: int, seed: int, *, workers: int = 2, tasks=TASKS,
                          retest: bool = True) -> SimulatedNorms:
    """The simulated normative model of the population of `seed`'s first `n` subjects."""
    tasks = tuple(tasks)
    subjects = draw_population(n, seed)
    sessions = SESSIONS if retest else SESSIONS[:1]
    visits = [Visit(s, k, tasks) for k in sessions for s in subjects]
    rows = map_subjects(battery_figures, visits, workers)
    return fit_simulated_norms(rows, n, seed, tasks=tasks, retest=retest)


def fit_simulated_norms(rows: list[dict], n: int, seed: int, *, tasks=TASKS,
                        retest: bool = True) -> SimulatedNorms:
    """The simulated normative model from the battery rows `build_simulated_norms` ran
    (its `rows`, kept with `scripts/build_simulated_norms.py --save-rows`): a refit after a
    change to the fitter takes seconds, not the population's minutes. The rows must be the
    population of `seed`'s first `n` subjects (their covariates are drawn again)."""
    tasks = tuple(tasks)
    by_index = {s.index: s for s in draw_population(n, seed)}
    unknown = {r["subject"] for r in rows} - set(by_index)
    if unknown:
        raise NormsError(f"the rows hold subjects {sorted(unknown)[:3]} that the population "
                         f"of seed {seed} with {n} subjects does not have")
    refused = sum(1 for r in rows if r["refused"] and r["session"] == 1)
    fit = fit_norms(controls_of(rows, by_index, retest=False),
                    source_text(n, seed, tasks, refused, datetime.datetime.now(datetime.UTC)
                                .date(), retest), simulated=True)
    document, skipped, left_out = fit.document, {}, {}
    if retest:
        model = parse_norms(norms_document(document))
        try:
            result = retest_reliability(model, controls_of(rows, by_index, retest=True))
            found, skipped, left_out = result.found, result.skipped, result.left_out
        except NormsError as error:
            found, skipped = {}, {"retest": str(error)}
        document = with_mdc(document, found)
    return SimulatedNorms(document, fit, rows, skipped, left_out)
