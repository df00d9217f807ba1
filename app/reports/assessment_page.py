"""An assessment task's report page: its figures as the trial's metrics hold them, each with
its label, unit and better direction from the catalogue (core.assessment.FIGURES), its
Z-score and the task score against the normative model in use when there is one
(app.norms), and the norms' source printed under them (their label says "simulated — for
demonstration and tests only" when they are the simulated ones).

`assessment_page` gathers the page's content (what the window's tab and the PDF show);
`write_assessment_pdf` draws it on one page. A figure the norms cannot score (not held,
undefined, the patient's covariates unknown) has no Z-score and the page says why once.
The isometric strength page also carries its polar plot's data (`AssessmentPage.polar`:
core.assessment.strength.strength_polar), drawn under the table (app.reports.strength_polar)
and beside the tab's text (ui.tabs.strength_polar).
"""

from __future__ import annotations

import datetime
import math
import os
import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from app.norms.model import score_text, z_text
from app.records.typed import FIELD_NAMES
from app.reports.metrics_table import number_text, unit_places
from app.units import shown, with_unit
from core.assessment import TASK_TITLES, task_figures
from core.assessment.protocol import protocol
from core.assessment.strength import StrengthPolar, strength_polar

NO_NORMS = "No normative model in use: no Z-scores (rehab norms use FILE sets one)"
TEXT_CHARS = 100
"""The page's lines under the table, in characters: 9-point type from 0.08 of the A4
page's width ends within the table's right edge (0.94)."""


@dataclass(frozen=True, slots=True)
class FigureLine:
    """One figure on the page."""

    key: str
    label: str
    value: str
    """The value with its unit as read (figure_value), or 'not defined'."""
    better: str
    z: float | None
    """Its Z-score (positive = above healthy people like the patient), None without one."""
    worse_z: float | None
    """The Z-score signed so that positive is worse (the norms' worse side)."""
    extrapolated: bool = False
    """Its Z-score is of an age beyond the norms' controls' (app.norms.FigureZ)."""


@dataclass(frozen=True, slots=True)
class AssessmentPage:
    task: str
    title: str
    heading: str
    """Who, when, which trial(s)."""
    lines: tuple[FigureLine, ...]
    task_score: str
    """'Task score 0.8 (0 is best; 1.96 is the controls' 95th percentile)' or why none."""
    norms: str
    """The norms' label (their source, simulated or not) or NO_NORMS."""
    notes: tuple[str, ...]
    polar: StrengthPolar | None = None
    """The strength task's polar plot (peak and mean force per direction), None for
    the other tasks and for a strength trial without a direction measured."""


def unnormed_notes(norms, figures: Sequence[tuple[str, str]]) -> list[str]:
    """Why the norms score none of `figures` ((key, label) each) that they left out, one
    note per reason, not one per figure, and without the norms' source (printed once
    above the table: the session report repeated it, 300 characters, for each such
    figure): 'no Z-score for Initial speed ratio, No reaction: every control has the same
    value: no spread to norm'."""
    unnormed: dict[str, list[str]] = {}  # why the norms left a figure out → its labels
    for key, label in figures:
        why = norms.left_out(key) if key not in norms.figures else ""
        if why:
            unnormed.setdefault(why, []).append(label)
    return [f"no Z-score for {', '.join(labels[:2])}"
            f"{f' and {len(labels) - 2} more' if len(labels) > 2 else ''}: {why}"
            for why, labels in unnormed.items()]


def assessment_page(task: str, metrics: Mapping[str, float], *, heading: str = "",
                    norms=None, person=None,
                    lines_n: Mapping[int, float] | None = None,
                    missing: Sequence[str] = ()) -> AssessmentPage:
    """The page of `task` for a trial's `metrics` (its file's or the registry's), with
    Z-scores and the task score when `norms` (app.norms.NormativeModel) and `person`
    (app.norms.Covariates) are given; a strength page's polar plot with the line each
    direction was shown (`lines_n`, app.assessments.strength.lines_N) when given.
    `missing`: the patient's fields the norms need and the registry lacks
    (missing_covariates), named in the note that says why no Z-scores."""
    from app.norms import NormsError, TaskNotPerformed

    spec = protocol(task)
    notes: list[str] = []
    scores: dict = {}
    if norms is not None and person is None:
        # where the therapist reading the page records them (a registered patient's
        # fields are corrected there), not a command line to register them anew
        notes.append(f"the patient's {missing_words(missing)} not recorded: no Z-scores "
                     "(record them on the Registration tab: Clinical record, Correct)")
    unscorable = ""  # a person the norms hold no one like: said once, in the task score
    if norms is not None and person is not None:
        try:
            norms.check_person(person)
        except NormsError as exc:
            unscorable, person = str(exc), None
    lines = []
    given = [figure for figure in task_figures(task) if metrics.get(figure.key) is not None]
    for figure in given:
        value = metrics[figure.key]
        z = worse = None
        extrapolated = False
        if norms is not None and person is not None and figure.key in norms.figures:
            try:
                scored = norms.z(figure.key, value, person)
            except NormsError as exc:
                notes.append(str(exc))
            else:
                scores[figure.key] = scored
                z, worse, extrapolated = scored.z, scored.worse_z, scored.extrapolated
        lines.append(FigureLine(figure.key, figure.label,
                                figure_value(value, figure.unit, figure.key),
                                figure.better, z, worse, extrapolated))
    if norms is not None:
        notes.extend(unnormed_notes(norms, [(f.key, f.label) for f in given]))
    task_score = "No task score without norms" if norms is None else "No task score"
    if unscorable:
        task_score = f"No task score: {unscorable}"
    if norms is not None and person is not None:
        try:
            score = norms.task_score(task, metrics, person)
        except TaskNotPerformed as exc:
            task_score = not_performed_text(exc)
        except NormsError as exc:
            task_score = f"No task score: {exc}"
        else:
            task_score = (f"Task score {score_text(score.score)} (0 is best; 1.96 is the healthy "
                          f"controls' 95th percentile)")
    if not lines:
        notes.append(f"the trial holds no {spec.name} figures")
    return AssessmentPage(task, TASK_TITLES[task], heading, tuple(lines), task_score,
                          NO_NORMS if norms is None else norms.label, tuple(notes),
                          _polar(task, metrics, lines_n))


def _polar(task: str, metrics: Mapping[str, float],
           lines_n: Mapping[int, float] | None) -> StrengthPolar | None:
    """The strength task's polar plot when a direction has a force to draw."""
    if task != "strength":
        return None
    polar = strength_polar(metrics, lines_n)
    return None if len(polar.not_measured) == len(polar.directions_deg) else polar


def not_performed_text(exc) -> str:
    """The task score's line of a task the patient did not perform (reports and pages)."""
    return exc.line


COVARIATE_FIELDS = tuple((field, FIELD_NAMES[field].lower())
                         for field in ("birth_year", "sex", "handedness", "side"))
"""The registered patient's fields the norms' covariates come from, with their names as
the Registration tab gives them (its form, its Correct row), where they are recorded."""


def missing_covariates(patient, *, side_known: bool = False) -> tuple[str, ...]:
    """The names of the fields of a registered patient (app.records.registry.Patient) the
    norms need and the registry lacks, in COVARIATE_FIELDS' order ((): none missing); the
    side not among them when `side_known` (the trial's file says which arm was tested)."""
    return tuple(name for field, name in COVARIATE_FIELDS
                 if getattr(patient, field) in (None, "")
                 and not (side_known and field == "side"))


def missing_words(missing: Sequence[str]) -> str:
    """'sex and handedness are', 'year of birth is' (missing_covariates' names); without
    names, every field it may be: "the patient's year of birth, sex or handedness is not
    recorded" sent the therapist who had typed the year looking for a fault."""
    if not missing:
        return "year of birth, sex or handedness is"
    names = (f"{', '.join(missing[:-1])} and {missing[-1]}" if len(missing) > 1
             else missing[0])
    return f"{names} {'are' if len(missing) > 1 else 'is'}"


def covariates(patient, session_date: datetime.date, backend: str, summary: Mapping,
               tested_side: str = ""):
    """The norms' covariates of a registered patient (app.records.registry.Patient) at a
    session on the trial's robot (its backend and its file's summary: app.norms.controls)
    with the arm the trial tested (its file's subject side; the registry's without it), or
    None when the registry lacks one of them (missing_covariates: birth year, sex,
    handedness, the tested side)."""
    from app.norms.controls import Person, covariates_at, robot_kind

    if missing_covariates(patient, side_known=bool(tested_side)):
        return None
    return covariates_at(Person(patient.birth_year, patient.sex, patient.handedness),
                         session_date.year, tested_side or patient.side,
                         robot_kind(backend, summary))


def trial_covariates(registry, patient, trial) -> tuple[object, list[str]]:
    """The norms' covariates of a registered `patient` at their registered `trial` (its
    session's date, its robot from its file's summary, the tested side its file's subject's,
    as `rehab norms score` takes it: the record of what ran, which a later correction of the
    registry's side does not change; None as `covariates` says), and notes: the trial's
    file unreadable (its robot then unknown to the norms, its side the registry's)."""
    from app.errors import AppError
    from app.trials.reader import read_trial

    notes = []
    try:
        data = read_trial(registry.trial_path(trial), ())
    except AppError as exc:
        summary, side = {}, ""
        notes = [f"the trial's file cannot be read: {exc}"]
    else:
        summary, side = data.summary, data.subject.side if data.subject is not None else ""
    return covariates(patient, trial.session_date, trial.backend or "", summary, side), notes


def patient_page(registry, code: str, task: str) -> AssessmentPage | None:
    """The page of the patient's latest finished trial of `task` (a trial marked invalid
    left out) from the registry's metrics, scored against the data folder's norms in use
    (app.norms.in_use) when there are some; None when the patient has no such trial. A
    damaged norms file is said on the page, never scored with."""
    trials = _finished_of_task(registry, code, task)
    return trial_page(registry, trials[-1], trials) if trials else None


def _finished_of_task(registry, code: str, task: str) -> list:
    invalid = registry.invalid_trials(code)
    return [t for t in registry.trials_for_patient(code)
            if t.parameters.get("assessment") == task and t.finished and t.id not in invalid]


def trial_page(registry, trial, trials=None) -> AssessmentPage:
    """The page of one registered assessment trial (its task's figures as the registry
    holds them, scored as `patient_page` scores them): the post-trial report's page for a
    task (app.reports.pdf). `trials`: the patient's finished trials of the task up to this
    one, where the circle's other way is looked for (default: read from the registry)."""
    from app.errors import AppError
    from app.norms.in_use import norms_in_use

    code, task = trial.patient_code, trial.parameters["assessment"]
    if trials is None:
        order = (trial.session_number, trial.number)
        trials = [t for t in _finished_of_task(registry, code, task)
                  if (t.session_number, t.number) <= order]
        if not trials or trials[-1].id != trial.id:
            trials = [*trials, trial]
    heading = (f"Patient {code}, session {trial.session_number} ({trial.session_date}), "
               f"trial {trial.number}, {trial.status.replace('_', ' ')}, "
               f"{trial.backend or 'robot not recorded'}")
    metrics = dict(trial.metrics)
    if task == "circle":
        metrics, heading = _both_circles(trials, metrics, heading)
    notes: list[str] = []
    try:
        norms = norms_in_use(registry.data_dir)
    except AppError as exc:
        norms, notes = None, [f"the norms in use cannot be read: {exc}"]
    person, missing = None, ()
    if norms is not None:
        patient = registry.patient(code)
        person, read = trial_covariates(registry, patient, trial)
        notes += read
        missing = missing_covariates(patient) if person is None else ()
    page = assessment_page(task, metrics, heading=heading, norms=norms, person=person,
                           lines_n=_lines_shown(trial) if task == "strength" else None,
                           missing=missing)
    return replace(page, notes=(*page.notes, *notes))


def _lines_shown(trial) -> dict[int, float] | None:
    """The line each direction of a registered strength trial was shown, N, from its
    parameters (app.assessments.strength.lines_N), or None when they no longer make a
    trial (a field this console has since renamed): the plot then goes without them."""
    from app.assessments.strength import lines_N
    from core.errors import CoreError
    from core.trial import TrialParameters

    try:
        return lines_N(TrialParameters.from_dict(dict(trial.parameters)))
    except (CoreError, TypeError, ValueError):
        return None


def _both_circles(trials, metrics: dict, heading: str) -> tuple[dict, str]:
    """The circle task's figures from the latest clockwise and counter-clockwise trials
    (app.assessments.figures.circle_task) when the latest trial lacks them (trials run one
    at a time in the window), with both trials named."""
    from app.assessments.figures import circle_task

    if "circle_ratio" in metrics:
        return metrics, heading
    latest = {}
    for trial in trials:
        latest[bool(trial.parameters.get("clockwise", True))] = trial
    if len(latest) < 2:
        return metrics, heading + " (one way round only: no task figures yet)"
    try:
        both = circle_task(latest[True].metrics, latest[False].metrics)
    except KeyError:  # a trial without its figures (a fault before its circle)
        return metrics, heading
    return ({**metrics, **both}, heading + f"; the task's figures with trial "
            f"{latest[not trials[-1].parameters.get('clockwise', True)].number}")


def page_text(page: AssessmentPage) -> list[str]:
    """The page as lines of text (the window's tab and the PDF draw these)."""
    out = [page.title] + ([page.heading] if page.heading else [])
    out += [figure_text(line) for line in page.lines]
    out += [page.task_score, page.norms, *(f"note: {note}" for note in page.notes)]
    return out


def figure_text(line: FigureLine) -> str:
    """A figure's line of text: its label, value and, when it has one, its Z-score, said
    when it is of an age beyond the controls' (as `rehab norms score` says it)."""
    from app.norms.model import EXTRAPOLATED

    z = "" if line.z is None else f"   Z {z_text(line.z)}"
    beyond = f" {EXTRAPOLATED}" if line.z is not None and line.extrapolated else ""
    return f"  {line.label}: {line.value}{z}{beyond}"


def write_assessment_pdf(path: str | os.PathLike, pages: Sequence[AssessmentPage], *,
                         overwrite: bool = True) -> Path:
    """One PDF page per task page: its figures as a table (value, Z-score, which way is
    better), the task score and the norms' source under them."""
    from app.reports.pdf_file import write_pdf

    return write_pdf(path, lambda: [page_figure(page) for page in pages],
                     {"Title": "Assessment: " + ", ".join(p.title for p in pages)},
                     "the assessment report", overwrite=overwrite)


def page_figure(page: AssessmentPage):
    """The page drawn as one A4 matplotlib figure (the PDF's page)."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(8.27, 11.69))  # A4
    figure.text(0.08, 0.95, page.title, fontsize=18, weight="bold")
    figure.text(0.08, 0.925, page.heading, fontsize=10)
    from app.norms.model import EXTRAPOLATED

    # the Z column is too narrow for the words: a mark, and the words once under the table
    marked = [line.z is not None and line.extrapolated for line in page.lines]
    rows = [[line.label, line.value,
             "" if line.z is None else z_text(line.z) + (" †" if mark else ""),
             {"lower": "lower", "higher": "higher", "none": "—"}[line.better]]
            for line, mark in zip(page.lines, marked, strict=True)]
    text_top = 0.2
    if page.polar is not None:
        from app.reports.strength_polar import draw_strength_polar

        # under the table (its 19 rows end near 0.49) and over the score's lines
        draw_strength_polar(figure, (0.18, 0.18, 0.52, 0.25), page.polar)
        text_top = 0.135
    axes = figure.add_axes((0.06, 0.25, 0.88, 0.65))
    axes.axis("off")
    if rows:
        table = axes.table(cellText=rows, colLabels=["Figure", "Value", "Z", "Better"],
                           colWidths=[0.5, 0.22, 0.12, 0.12], loc="upper center",
                           cellLoc="left")
        table.auto_set_font_size(False)
        table.set_fontsize(9)
        table.scale(1.0, 1.4)
    # one block, hung from its top: a long line (the simulated norms' label) wraps onto
    # lines of its own instead of over the next one's, within the table's right edge
    # (matplotlib's own wrap runs to the paper's edge)
    paragraphs = (page.task_score, page.norms, *page.notes,
                  *([f"† {EXTRAPOLATED.strip('()')}: the Z-score extrapolates the norms"]
                    if any(marked) else []))
    figure.text(0.08, text_top, "\n\n".join(textwrap.fill(p, TEXT_CHARS) for p in paragraphs),
                fontsize=9, va="top")
    return figure


FIGURE_DECIMALS = {"vgr_posture_speed_m_s": 1}
"""A figure whose decimals are not its unit's (as MetricRow.decimals for the report's
rows): a hand held still drifts at about 1 mm/s, which its unit's whole mm/s would write
as 1 or 0 (the posture speed is read to a tenth, 0.8 mm/s)."""


def figure_value(value: float, unit: str, key: str = "") -> str:
    """A figure's SI value (its catalogue's `unit`) as reports print it: in the unit a
    person reads (app.units.shown: mm, mm/s, °, cm²; SI read in 0.0008121 m/s and 0.04029
    rad beside the trial's page in mm/s and °) with that unit's decimals, the report's
    rows' rule (unit_places, or the figure's own FIGURE_DECIMALS for `key`: four
    significant digits wrote "Circle ratio 0.9171", "116.7 mm/s" where the report wrote
    0.92 and 117), a count whole, a ratio bare."""
    if not math.isfinite(value):
        return "not defined"
    if unit == "count":  # a count, or a mean of counts over the reaches
        return f"{value:.0f}" if float(value).is_integer() else f"{value:.3g}"
    value, unit = shown(value, unit)
    return with_unit(number_text(value, FIGURE_DECIMALS.get(key, unit_places(unit))), unit)
