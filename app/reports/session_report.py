"""A session's report (PDF) a therapist can hand over or file (issue 31): the session's
trials (each trial marked invalid saying why), its clinical scales with who rated them,
its notes, and each assessment task's figures with their Z-scores and the task's score
when norms are in use (the norms' source printed, "simulated — for demonstration and
tests only" when they are); and the clinical-scales pages of the progress PDF.

`session_content` gathers everything from the registry (and, for an assessment trial, the
robot kind from its file's summary); `session_pages` draws it; `write_session_report`
writes it like every report (app.reports.pdf_file: private, whole or not at all).
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

from matplotlib.figure import Figure

from app.games.names import game_title
from app.records.scales import (
    ARAT,
    ASHWORTH,
    FUGL_MEYER,
    FUGL_MEYER_PART_LABELS,
    SCALE_LABELS,
    SCALE_MAXIMA,
    SCALES,
)
from app.records.store import RecordStore
from app.reports.assessment_page import figure_value, unnormed_notes
from app.reports.pdf_file import write_pdf
from app.reports.pdf_sheet import BOTTOM_IN, GREY, LEFT_IN, PAGE_IN, VERMILLION, Sheet, fit
from app.reports.plain_language import SHAPE_NAMES

log = logging.getLogger(__name__)

ROW_IN = 0.19


@dataclass(frozen=True)
class AssessmentRow:
    """One figure of an assessment trial: its label, value with unit, Z-score text."""

    label: str
    value: str
    z: str


@dataclass(frozen=True)
class Assessment:
    trial_numbers: tuple[int, ...]
    """The trials that hold these figures: one, or a task's trials that all hold the
    task's figures (the circle's two ways: app.assessments.figures.circle_task)."""
    task_title: str
    rows: tuple[AssessmentRow, ...]
    task_score: str
    notes: tuple[str, ...] = ()

    @property
    def trials_text(self) -> str:
        numbers = [str(n) for n in self.trial_numbers]
        if len(numbers) == 1:
            return f"Trial {numbers[0]}"
        return f"Trials {', '.join(numbers[:-1])} and {numbers[-1]}"


def one_per_task_result(assessments) -> tuple[Assessment, ...]:
    """A task whose trials each hold the same figures (the circle's pair) shown once,
    naming its trials, instead of the same table once per trial."""
    out: list[Assessment] = []
    for a in assessments:
        last = out[-1] if out else None
        if last is not None and (last.task_title, last.rows, last.task_score, last.notes) == (
                a.task_title, a.rows, a.task_score, a.notes):
            out[-1] = replace(last, trial_numbers=last.trial_numbers + a.trial_numbers)
        else:
            out.append(a)
    return tuple(out)


@dataclass(frozen=True)
class SessionContent:
    code: str
    number: int
    date: str
    therapist: str
    location: str
    trials: tuple[tuple[str, ...], ...]
    scales: tuple[str, ...]
    notes: tuple[str, ...]
    assessments: tuple[Assessment, ...]
    norms_label: str
    problems: tuple[str, ...] = field(default=())


TRIAL_COLUMNS = (("Trial", 0.45), ("Started (UTC)", 1.25), ("Status", 0.95),
                 ("Exercise or task", 1.9), ("Validity", 2.5))


def scale_text(entry) -> str:
    """One scale entry in words: its total over the maximum and its parts, or the grades."""
    label = SCALE_LABELS[entry.scale]
    if entry.scale == ASHWORTH:
        grades = entry.detail["grades"]
        return f"{label}: " + ", ".join(f"{g.replace('_', ' ')} {v}" for g, v in grades.items())
    text = f"{label}: {entry.total}/{SCALE_MAXIMA[entry.scale]}"
    parts = entry.detail.get("parts")
    if parts and entry.scale == FUGL_MEYER:
        text += " (" + ", ".join(f"{k} {FUGL_MEYER_PART_LABELS[k]} {v}" for k, v in
                                 parts.items()) + ")"
    elif parts and entry.scale == ARAT:
        text += " (" + ", ".join(f"{k} {v}" for k, v in parts.items()) + ")"
    return text


def session_content(registry: RecordStore, code: str, number: int, *, norms=None
                    ) -> SessionContent:
    """Everything the session's report says, from the registry (and the norms given, an
    app.norms.NormativeModel, or None: then no Z-score is printed and the report says so)."""
    from core.assessment import TASK_TITLES

    session = registry.session(code, number)
    patient = registry.patient(code)
    invalid = registry.invalid_trials(code)
    trials = [t for t in registry.trials_for_patient(code) if t.session_number == number]
    rows = []
    for t in trials:
        p = t.parameters
        task = p.get("assessment") or ""
        what = (f"assessment: {TASK_TITLES.get(task, task)}" if task else
                f"{SHAPE_NAMES.get(p.get('shape'), p.get('shape', '?'))}, "
                f"{p.get('assist', 'thesis')}")
        if p.get("game") and not task:
            # a session of games read as plain exercises: the game and its score
            score = t.metrics.get("game_score", math.nan)
            scored = f", score {score:.0f}" if math.isfinite(score) else ""
            what = f"{game_title(p['game'])}{scored}: {what}"
        mark = invalid.get(t.id)
        validity = f"INVALID: {mark.reason} ({mark.marked_by})" if mark else "valid"
        rows.append((str(t.number), t.started_at.strftime("%Y-%m-%d %H:%M"),
                     t.status.replace("_", " "), what, validity))
    scales = registry.session_scales(code).get(number, {})
    scale_lines = tuple(f"{scale_text(scales[s])} — {scales[s].rater}, "
                        f"{scales[s].recorded_at:%Y-%m-%d %H:%M} UTC"
                        for s in SCALES if s in scales)
    notes = tuple(
        f"{'trial ' + str(_number_of(trials, n.trial_id)) if n.trial_id else 'session'}: "
        f"{n.text} — {n.author}, {n.written_at:%Y-%m-%d %H:%M} UTC"
        for n in registry.notes(code, number))
    assessments = one_per_task_result(_assessment(registry, patient, t, norms)
                                      for t in trials if t.parameters.get("assessment")
                                      and t.id not in invalid)
    label = norms.label if norms is not None else "No norms in use: no Z-scores."
    return SessionContent(code, number, session.date.isoformat(), session.therapist,
                          session.location, tuple(rows), scale_lines, notes, assessments,
                          label)


def _number_of(trials, trial_id: int) -> int | str:
    return next((t.number for t in trials if t.id == trial_id), trial_id)


def _covariates(patient, trial, registry):
    """The norms' covariates of the patient at the trial (assessment_page.trial_covariates:
    the session's date, the trial file's robot and tested side), and what the report says
    of them (None and why when the registry lacks a field the norms need)."""
    from app.reports.assessment_page import missing_covariates, missing_words, trial_covariates

    who, notes = trial_covariates(registry, patient, trial)
    if who is None:
        missing = missing_words(missing_covariates(patient))
        return None, "; ".join([f"no Z-scores: the patient's {missing} not recorded "
                                "(`rehab correct`)", *notes])
    return who, "; ".join(notes)


def _assessment(registry, patient, trial, norms) -> Assessment:
    from core.assessment import FIGURES, TASK_TITLES, task_figures

    task = trial.parameters["assessment"]
    keys = [spec.key for spec in task_figures(task) if spec.key in trial.metrics]
    who, problem = (None, "") if norms is None else _covariates(patient, trial, registry)
    notes = [problem] if problem else []
    unscorable = ""  # a person the norms hold no one like: said once, in the task score
    if who is not None:
        from app.norms import NormsError

        try:
            norms.check_person(who)
        except NormsError as exc:
            who, unscorable = None, f"no task score: {exc}"
    rows = []
    for key in keys:
        spec, value = FIGURES[key], trial.metrics[key]
        shown = "–" if not math.isfinite(value) else figure_value(value, spec.unit, spec.key)
        z = ""
        if who is not None and math.isfinite(value):
            z, why = _z_text(norms, key, value, who) if key in norms.figures else ("–", "")
            if why and why not in notes:
                notes.append(why)
        rows.append(AssessmentRow(spec.label, shown, z))
    if who is not None:  # the figures the norms left out: why, once per reason
        notes.extend(unnormed_notes(norms, [(key, FIGURES[key].label) for key in keys]))
    score = unscorable
    if who is not None:
        from app.norms import NormsError, TaskNotPerformed
        from app.norms.model import score_text
        from app.reports.assessment_page import not_performed_text

        try:
            result = norms.task_score(task, trial.metrics, who)
            score = (f"task score {score_text(result.score)} (0 best; 1.96 = the 95th "
                     "percentile of the norms)"
                     + (" — extrapolated" if result.extrapolated else ""))
        except TaskNotPerformed as exc:
            score = not_performed_text(exc)
        except NormsError as exc:
            score = f"no task score: {exc}"
    return Assessment((trial.number,), TASK_TITLES.get(task, task), tuple(rows), score,
                      tuple(notes))


def _z_text(norms, key, value, who) -> tuple[str, str]:
    """The Z-score's text, and why there is none (the norms' one line) when there is not."""
    from app.norms import NormsError

    try:
        z = norms.z(key, value, who)
    except NormsError as exc:
        return "–", str(exc)
    from app.norms.model import z_text

    return f"Z {z_text(z.z)}" + (" (extrapolated)" if z.extrapolated else ""), ""


class _Flow:
    """Sheets filled from the top, a new one when a line does not fit."""

    def __init__(self, title: str) -> None:
        self.title = title
        self.sheets: list[Sheet] = []
        self.new()

    @property
    def sheet(self) -> Sheet:
        return self.sheets[-1]

    def new(self) -> None:
        self.sheets.append(Sheet())
        if len(self.sheets) > 1:
            self.sheet.text(f"{self.title} (continued)", 12, weight="bold", color=GREY)
            self.sheet.gap(0.1)

    def room(self, inches: float) -> None:
        if self.sheet.y_in + inches > PAGE_IN[1] - BOTTOM_IN - 0.3:
            self.new()

    def text(self, text: str, size: float = 9.5, **style) -> None:
        self.room(size * 1.3 / 72 * 2)
        self.sheet.text(text, size, **style)

    def heading(self, text: str) -> None:
        self.room(0.6)
        self.sheet.gap(0.12)
        self.sheet.text(text, 13, weight="bold")
        self.sheet.gap(0.04)

    def row(self, cells, columns, **style) -> None:
        self.room(ROW_IN)
        x = LEFT_IN
        for text, (_, width) in zip(cells, columns, strict=True):
            self.sheet.fig.text(self.sheet.fx(x), self.sheet.fy(self.sheet.y_in),
                                fit(str(text), 8, width - 0.05), fontsize=8, va="top",
                                **style)
            x += width
        self.sheet.y_in += ROW_IN


def session_pages(content: SessionContent) -> tuple[Figure, ...]:
    title = f"Session {content.number} of {content.code}"
    flow = _flow_with_heading(title, content)
    flow.heading("Trials")
    if content.trials:
        flow.row([c for c, _ in TRIAL_COLUMNS], TRIAL_COLUMNS, color=GREY, weight="bold")
        for cells in content.trials:
            flow.row(cells, TRIAL_COLUMNS,
                     color=VERMILLION if cells[-1].startswith("INVALID") else "#1A1A1A")
    else:
        flow.text("No trials in this session.")
    flow.heading("Clinical scales")
    for line in content.scales or ("None recorded in this session.",):
        flow.text(line)
    flow.heading("Notes")
    for line in content.notes or ("No notes.",):
        flow.text(line)
    flow.heading("Assessments")
    flow.text(content.norms_label, 8.5, color=GREY)
    if not content.assessments:
        flow.text("No assessment task was run in this session (or its trials are marked "
                  "invalid).")
    columns = (("Figure", 3.3), ("Value", 1.6), ("Against the norms", 2.3))
    for a in content.assessments:
        # the task's table kept on one sheet with its heading and its score, if it fits one
        flow.room(min(0.8 + ROW_IN * (len(a.rows) + 1) + 0.3 * len(a.notes), 6.0))
        flow.text(f"{a.trials_text}: {a.task_title}", 10.5, weight="bold")
        for note in a.notes:
            flow.text(note, 8.5, color=GREY)
        flow.row([c for c, _ in columns], columns, color=GREY, weight="bold")
        for r in a.rows:
            flow.row((r.label, r.value, r.z), columns, color="#1A1A1A")
        if a.task_score:
            flow.text(a.task_score, 9)
        flow.sheet.gap(0.1)
    return tuple(s.fig for s in flow.sheets)


def _flow_with_heading(title: str, content: SessionContent) -> _Flow:
    flow = _Flow(title)
    flow.sheet.text(title, 18, weight="bold")
    where = ", ".join(filter(None, (content.date, content.therapist and
                                    f"therapist {content.therapist}", content.location)))
    flow.sheet.text(where, 11, color=GREY)
    return flow


def write_session_report(registry: RecordStore, code: str, number: int,
                         path: str | os.PathLike, *, overwrite: bool = False,
                         norms=None) -> Path:
    """Write the session's report to `path` (app.reports.pdf_file: private, whole or not
    at all; an existing file replaced only with `overwrite`)."""
    content = session_content(registry, code, number, norms=norms)
    metadata = {"Title": f"Session {number} of {code}",
                "Subject": "A session of a planar upper-limb rehabilitation robot: trials, "
                           "clinical scales, notes, assessments"}
    path = write_pdf(path, lambda: session_pages(content), metadata, "the session report",
                     overwrite=overwrite)
    log.info("session report written: %s", path)
    return path


def scales_pages(code: str, per_session: dict, series: tuple = ()) -> list[Figure]:
    """The progress PDF's clinical scales: each session's scales, then each figure
    against a scale with its correlation (app.reports.scales_progress.ScaleSeries)."""
    if not per_session:
        return []
    flow = _Flow(f"Clinical scales of {code}")
    flow.sheet.text(f"Clinical scales of {code}", 18, weight="bold")
    for number in sorted(per_session):
        flow.heading(f"Session {number}")
        for scale in SCALES:
            if scale in per_session[number]:
                entry = per_session[number][scale]
                flow.text(f"{scale_text(entry)} — {entry.rater}")
    for s in series:
        if not s.points:
            continue
        if len(s.points) < 2:
            # a plot of one point says nothing (a one-session patient had 8 pages of
            # them, each "n = 1"): the point in a line, and when a plot will come
            p = s.points[0]
            value = p.figure * s.figure_row.scale
            flow.text(f"{s.figure_label} against {s.scale_label}: session {p.session_number} "
                      f"only ({s.scale_label} {p.scale:g}; {s.figure_label} {value:.3g}); "
                      "plotted from a "
                      "second session with both.", 9)
            continue
        flow.room(3.9)
        flow.heading(f"{s.figure_label} against {s.scale_label}")
        axes = flow.sheet.axes(2.4, x_in=LEFT_IN + 0.7, width_in=4.5)
        factor = s.figure_row.scale
        xs = [p.scale for p in s.points]
        ys = [p.figure * factor for p in s.points]
        axes.plot(xs, ys, linestyle="none", marker="o", color="#0072B2")
        real = [(x, y) for p, x, y in zip(s.points, xs, ys, strict=True) if p.real_change]
        if real:  # a ring round a session changed beyond the MDC95, as the window draws
            axes.plot(*zip(*real, strict=True), linestyle="none", marker="o", markersize=13,
                      markerfacecolor="none", markeredgecolor="#D55E00", markeredgewidth=1.5)
        for p, x, y in zip(s.points, xs, ys, strict=True):
            axes.annotate(f"S{p.session_number}", (x, y), fontsize=7, xytext=(3, 3),
                          textcoords="offset points")
        axes.set_xlabel(s.scale_label)
        axes.set_ylabel(s.figure_label, fontsize=8)
        axes.grid(True, color="#E6E6E6", linewidth=0.5)
        flow.sheet.y_in += 2.4 + 0.45
        flow.text(s.correlation.text(), 9)
        if s.marks:
            flow.text(s.marks, 8.5, color=GREY)
    return [sheet.fig for sheet in flow.sheets]
