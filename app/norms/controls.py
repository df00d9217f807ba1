"""Healthy controls from their assessment trial files: one row per person for the fitter
(app.norms.fitting.Controls), and a person's norm covariates at a trial.

A folder of trial files (a study's controls, any layout, searched recursively) is read
with the console's own reader (every file verified: a damaged one is listed as skipped
with its reason, never used). An assessment trial is one whose parameters name a task
(`TrialParameters.assessment`); its figures are its metrics. Per person and task, the
figures are those of the person's first session with that task (the mean over that
session's trials of the task where there are several; later sessions are retests,
`rehab norms mdc`) **(ours)**. The covariates come from the registry of a data folder (the
patient with the file's subject code: birth year, sex, handedness) or from a people table
(CSV `subject,birth_year,sex,handedness`); the tested side is the side the trial file
records, and the robot is the file's (`robot_kind`).
"""

from __future__ import annotations

import math
import os
import re
from collections import defaultdict
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import numpy as np

from app.norms.fitting import MAX_TABLE_BYTES, Controls, csv_rows
from app.norms.model import NormsError
from core.errors import CoreError
from core.norms.regression import Covariates

TRIAL_SUFFIX = ".h5"
SESSION_IN_NAME = re.compile(r"_S(\d{3,})_T\d{3,}_")


@dataclass(frozen=True)
class Person:
    """What the norms need of a person beyond the trial file."""

    birth_year: int
    sex: str
    handedness: str


def robot_kind(backend: str, summary: Mapping) -> str:
    """The norm covariate `robot` of a trial: `simulator-<plant>` on the simulator
    (`simulator-realistic`, `simulator-ideal`), `hardware` on the robot."""
    if backend.startswith("simulator"):
        plant = summary.get("plant")
        return f"simulator-{plant}" if isinstance(plant, str) and plant else "simulator"
    return "hardware"


def covariates_at(person: Person, when: datetime | int, tested_side: str, robot: str
                  ) -> Covariates:
    """The person's covariates at a session: age from the birth year (the registry keeps
    no birth date: the age a person turns in the session's year, up to a year over)."""
    year = when if isinstance(when, int) else when.year
    return Covariates(float(year - person.birth_year), person.sex, person.handedness,
                      tested_side, robot)


def people_from_registry(registry) -> dict[str, Person]:
    """Every patient of a registry with a birth year, sex and handedness (schema v8)."""
    people = {}
    for patient in registry.patients():
        if patient.birth_year is not None and patient.sex and patient.handedness:
            people[patient.code] = Person(patient.birth_year, patient.sex, patient.handedness)
    return people


def people_from_table(path: str | Path) -> dict[str, Person]:
    """A people table: CSV `subject,birth_year,sex,handedness`, one row per person."""
    from device.safeinput import check_file

    path = check_file(path, what="people table", max_bytes=MAX_TABLE_BYTES)
    rows = csv_rows(path, "people table", "a header and one row per person")
    header = [h.strip() for h in rows[0]]
    if header != ["subject", "birth_year", "sex", "handedness"]:
        raise NormsError(f"people table {path}: the header must be exactly "
                         "subject,birth_year,sex,handedness")
    people = {}
    for line, row in enumerate(rows[1:], start=2):
        if not any(c.strip() for c in row):
            continue
        if len(row) != 4:
            raise NormsError(f"people table {path}, line {line}: {len(row)} cells for 4")
        subject, year, sex, hand = (c.strip() for c in row)
        if not subject or subject in people:
            raise NormsError(f"people table {path}, line {line}: subject {subject!r} is "
                             "empty or appears twice")
        if not (year.isascii() and year.isdigit() and 1880 <= int(year) <= 2200):
            raise NormsError(f"people table {path}, line {line}: birth_year {year[:10]!r} "
                             "is not a year")
        try:
            Covariates(0.0, sex, hand, "right", "x")
        except CoreError as exc:
            raise NormsError(f"people table {path}, line {line}: {exc}") from None
        people[subject] = Person(int(year), sex, hand)
    return people


@dataclass(frozen=True)
class AssessmentTrial:
    path: Path
    subject: str
    task: str
    session_key: str
    when: datetime
    tested_side: str
    robot: str
    metrics: Mapping[str, float]


def trial_files(folder: str | Path) -> list[Path]:
    """Every trial file under `folder` (links to folders not followed), sorted."""
    from device.safeinput import check_folder

    folder = check_folder(folder, what="trials folder")
    found = []
    for root, dirs, files in os.walk(folder, followlinks=False):
        dirs.sort()
        found.extend(Path(root) / f for f in sorted(files) if f.endswith(TRIAL_SUFFIX))
    return found


def read_assessments(paths: Iterable[Path], invalid: Mapping[Path, str] | None = None
                     ) -> tuple[list[AssessmentTrial], dict[str, str]]:
    """The assessment trials among `paths`, and the others with why each was not used
    (`invalid`: files a registry marks invalid, by resolved path, with the reason)."""
    from app.errors import AppError
    from app.trials.reader import read_trial

    trials, skipped = [], {}
    for path in paths:
        reason = (invalid or {}).get(Path(path).resolve())
        if reason is not None:
            skipped[str(path)] = f"marked invalid: {reason}"
            continue
        try:
            data = read_trial(path, channels=())
        except (AppError, CoreError, OSError) as exc:
            skipped[str(path)] = f"not read: {exc}"
            continue
        task = getattr(data.parameters, "assessment", "") if data.parameters else ""
        if not task:
            skipped[str(path)] = "not an assessment trial"
            continue
        kind = simulated_patient(data.backend)
        if kind not in (None, "healthy"):
            # one data folder holds the controls and the patients: the weak virtual
            # patient's battery was fitted as a 26th healthy control
            skipped[str(path)] = (f"a simulated {kind} patient ({data.backend}), not a "
                                  "healthy control")
            continue
        if data.subject is None or data.status != "complete":
            skipped[str(path)] = (f"its status is {data.status!r}" if data.subject else
                                  "it holds no subject")
            continue
        try:
            when = datetime.fromisoformat(data.created_utc)
        except (TypeError, ValueError):
            skipped[str(path)] = f"its created_utc {str(data.created_utc)[:30]!r} is not a date"
            continue
        metrics = {k: float(v) for k, v in data.metrics.items()
                   if isinstance(v, int | float) and math.isfinite(v)}
        # the session from the console's file name (app.records.datadir.trial_stem), else
        # the day: trials of one day are one session
        named = SESSION_IN_NAME.search(path.name)
        session = f"S{named.group(1)}" if named else when.date().isoformat()
        trials.append(AssessmentTrial(path, data.subject.code, task, session, when,
                                      data.subject.side, robot_kind(data.backend,
                                                                    data.summary), metrics))
    return trials, skipped


SIMULATED = re.compile(r"simulator \((\w+)[,)]")


def simulated_patient(backend: str) -> str | None:
    """The virtual patient of a simulated trial's backend (`simulator (weak, seed 5)`:
    `weak`), or None for a trial on the robot or one that names none."""
    from device.sim.patient_parameters import PATIENT_KINDS

    found = SIMULATED.match(backend or "")
    return found.group(1) if found and found.group(1) in PATIENT_KINDS else None


def invalid_files(registry) -> dict[Path, str]:
    """The trial files a registry marks invalid, with the reason (records, schema v8):
    left out of the norms as they are left out of Progress."""
    marks = registry.invalid_trials()
    return {registry.trial_path(trial_id).resolve(): mark.reason
            for trial_id, mark in marks.items()}


def controls_from_trials(trials: Iterable[AssessmentTrial], people: Mapping[str, Person],
                         figure_keys: Iterable[str], session: int = 0
                         ) -> tuple[Controls, dict[str, str]]:
    """One row per person: the figures of each task from the person's `session`-th
    session with that task (0 the first: the norms; 1 the second: the retest), with their
    covariates at their first assessment; people the covariates lack are skipped (said)."""
    keys = list(figure_keys)
    by_subject: dict[str, list[AssessmentTrial]] = defaultdict(list)
    for trial in trials:
        by_subject[trial.subject].append(trial)
    subjects, rows, covariates, skipped = [], [], [], {}
    for subject in sorted(by_subject):
        own = sorted(by_subject[subject], key=lambda t: t.when)
        person = people.get(subject)
        if person is None:
            skipped[subject] = ("no birth year, sex and handedness for this subject (registry "
                                "or people table)")
            continue
        if len({t.tested_side for t in own}) > 1 or len({t.robot for t in own}) > 1:
            skipped[subject] = "measured on more than one arm or robot: one row cannot hold both"
            continue
        row = {}
        for task in {t.task for t in own}:
            sessions = list(dict.fromkeys(t.session_key for t in own if t.task == task))
            if len(sessions) <= session:
                continue
            for key in keys:
                values = [t.metrics[key] for t in own if t.task == task
                          and t.session_key == sessions[session] and key in t.metrics]
                if values:
                    row[key] = float(np.mean(values))
        if not row:
            skipped[subject] = f"no assessment of session {session + 1}"
            continue
        try:
            covariates.append(covariates_at(person, own[0].when, own[0].tested_side,
                                            own[0].robot))
        except CoreError as exc:
            skipped[subject] = str(exc)
            continue
        subjects.append(subject)
        rows.append(row)
    if not subjects:
        raise NormsError("no control has both assessment trials and covariates: "
                         + ("; ".join(f"{k}: {v}" for k, v in list(skipped.items())[:3])
                            or "no assessment trials found"))
    figures = {k: np.array([r.get(k, math.nan) for r in rows]) for k in keys
               if any(k in r for r in rows)}
    return Controls(tuple(subjects), tuple(covariates), figures), skipped


def retest_from_trials(trials: list[AssessmentTrial], people: Mapping[str, Person],
                       figure_keys: Iterable[str]) -> tuple[Controls, dict[str, str]]:
    """Test-retest data: each person's first and second session of each task, as the
    rows `<subject>#1` and `<subject>#2` (app.norms.retest.sessions_of)."""
    keys = list(figure_keys)
    first, skipped = controls_from_trials(trials, people, keys, 0)
    try:
        second, later = controls_from_trials(trials, people, keys, 1)
    except NormsError:
        raise NormsError("no control has a second session of an assessment: no test-retest "
                         "pairs") from None
    skipped.update(later)
    names = [f"{s}#1" for s in first.subjects] + [f"{s}#2" for s in second.subjects]
    figures = {}
    for key in set(first.figures) | set(second.figures):
        figures[key] = np.concatenate([
            first.figures.get(key, np.full(len(first.subjects), math.nan)),
            second.figures.get(key, np.full(len(second.subjects), math.nan))])
    return Controls(tuple(names), first.people + second.people, figures), skipped
