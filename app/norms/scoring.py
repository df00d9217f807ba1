"""A trial's figures scored against norms: the rows a report or `rehab norms score`
prints (every Z-score of the figures the norms hold, the task score), with who the person
was taken to be and the norms' label.

The person's covariates come from the registry (the patient with the trial's subject code:
birth year, sex, handedness) or are given; the tested side is the trial file's, the robot
its (app.norms.controls.robot_kind); the age is the one the person turns in the trial's
year (the registry keeps the birth year).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from app.norms.controls import Person, covariates_at, robot_kind
from app.norms.model import (
    EXTRAPOLATED,
    WORST,
    FigureZ,
    NormativeModel,
    NormsError,
    TaskNotPerformed,
    TaskScore,
    score_text,
    z_text,
)
from core.errors import CoreError
from core.norms.regression import Covariates


@dataclass(frozen=True)
class TrialScores:
    """A trial's Z-scores and task score against `norms`."""

    path: Path
    task: str
    person: Covariates
    figures: dict[str, FigureZ]
    task_score: TaskScore | None
    why_no_task_score: str
    label: str
    unscored: dict[str, str]
    """Figures the norms hold that could not be scored, with why."""
    not_performed: str = ""
    """Why the patient did not perform the task ("" when they did): worse than any score."""


def score_trial(path: str | Path, norms: NormativeModel, person: Person) -> TrialScores:
    """Read an assessment trial file and score its figures; NormsError when it is not an
    assessment or the norms cannot score this person."""
    from app.trials.reader import read_trial

    path = Path(path)
    data = read_trial(path, channels=())
    task = getattr(data.parameters, "assessment", "") if data.parameters else ""
    if not task:
        raise NormsError(f"{path} is not an assessment trial (its parameters name no task): "
                         "norms score assessments only")
    if data.subject is None:
        raise NormsError(f"{path} holds no subject: the tested side is unknown")
    try:
        when = datetime.fromisoformat(data.created_utc)
        who = covariates_at(person, when, data.subject.side, robot_kind(data.backend,
                                                                         data.summary))
    except (TypeError, ValueError, CoreError) as exc:
        raise NormsError(f"{path}: the person's covariates: {exc}") from None
    norms.check_person(who)  # a person the norms hold no one like: one refusal, not one a figure
    metrics = {k: float(v) for k, v in data.metrics.items()
               if isinstance(v, int | float) and math.isfinite(v)}
    figures, unscored = {}, {}
    for key, value in metrics.items():
        if key in norms.figures:
            try:
                figures[key] = norms.z(key, value, who)
            except NormsError as exc:  # this figure only: the others are still scored
                unscored[key] = str(exc)
    score, why, undone = None, "", ""
    try:
        score = norms.task_score(task, metrics, who)
    except TaskNotPerformed as exc:
        why, undone = str(exc), exc.reason
    except NormsError as exc:
        why = str(exc)
    return TrialScores(path, task, who, figures, score, why, norms.label, unscored, undone)


def lines(scores: TrialScores) -> list[str]:
    """The scores as a table for the terminal, the norms' label last."""
    from core.assessment import FIGURES

    p = scores.person
    out = [f"{scores.path.name}: {scores.task}; scored as age {p.age_years:g}, {p.sex}, "
           f"{p.handedness}-handed, {p.tested_side} arm, robot {p.robot}",
           f"{'figure':<36} {'value':>11} {'unit':<6} {'Z':>7} {'worse Z':>8}"]
    for key, z in scores.figures.items():
        unit = FIGURES[key].unit if key in FIGURES else ""
        out.append(f"{key:<36} {z.value:>11.4g} {unit:<6} {z_text(z.z):>7} "
                   f"{z_text(z.worse_z):>8}"
                   + (f" {EXTRAPOLATED}" if z.extrapolated else ""))
    for key, why in scores.unscored.items():
        out.append(f"{key:<36} no Z-score: {why}")
    if scores.task_score is not None:
        t = scores.task_score
        out.append(f"task score {scores.task}: {score_text(t.score)} (0 best; 1.96 = the controls' "
                   f"95th percentile), Z-Task Score {t.z_task:.2f}")
    elif scores.not_performed:
        out.append(f"task {scores.task}: not performed — {scores.not_performed} {WORST}")
    else:
        out.append(f"no task score: {scores.why_no_task_score}")
    out.append(scores.label)
    return out
