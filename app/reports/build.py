"""A trial's post-trial report for the patient and the therapist: one PDF of two A4
pages, the report of the thesis's GUI (Appendix A.4, A.6–A.8; section 3.6).

Why matplotlib's PDF backend: the report is mostly plots (Fig. 3.7, 3.9, 3.11,
3.12) and matplotlib, already a dependency, draws them as vector graphics and
writes the PDF itself; reportlab would add a dependency and still need
matplotlib for the plots, and Qt's QPdfWriter is out of reach because `app` must
not import Qt (docs/architecture.md, Layers). Text is embedded as TrueType (pdf.fonttype 42),
so it can be searched, copied and extracted.

The parts, each with one job:

* app.reports.content — `build_report`: the content as plain data
  (`ReportContent`), which the window's report view draws as well;
* app.reports.figures — the arrays and captions of the report's figures;
* app.reports.plain_language — the patient's sentences, built from the numbers;
* app.reports.compare — the change since earlier trials and the cautions when
  the exercise differed;
* app.reports.pdf — `write_report_pdf`: the pages, laid out on the sheets of
  app.reports.pdf_sheet with the plots of app.reports.pdf_plots.

Names: the report shows the patient's pseudonymous code. A first name appears
only when the caller passes it (`first_name=`, or `include_first_name=True`
here); nothing looks a name up by default, and the last name never appears.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from app.errors import AppError
from app.records.datadir import REPORTS
from app.records.registry import Trial
from app.records.store import RecordStore
from app.records.trialplace import file_to_read
from app.reports.compare import Baseline, Comparison, TableRow, as_baseline
from app.reports.content import HeaderItem, ReportContent, build_report
from app.reports.figures import (
    AnglesFigure,
    ForceFigure,
    PathFigure,
    Run,
    TorquesFigure,
    merge_short_runs,
)
from app.trials.assistance_timeline import CHANNELS_NEEDED
from app.trials.reader import read_trial

__all__ = [
    "AnglesFigure",
    "Baseline",
    "Comparison",
    "ForceFigure",
    "HeaderItem",
    "PathFigure",
    "ReportContent",
    "Run",
    "TableRow",
    "TorquesFigure",
    "build_report",
    "content_for_registry_trial",
    "merge_short_runs",
    "report_for_registry_trial",
    "write_report_pdf",
]


def content_for_registry_trial(
    registry: RecordStore,
    trial_id: int,
    *,
    include_first_name: bool = False,
) -> ReportContent:
    """The report of a registered trial: its file read, compared with the patient's
    previous complete trial and the last complete trial of their previous session
    (from the registry's figures, so a missing earlier file does not matter).

    The file is this station's, else the shared trial store's copy when it is the file
    recorded (app.records.trialplace). Raises TrialNotFound for an unknown id, AppError
    for a file still on the station that recorded it or a store's copy that cannot be
    read, and TrialFileError, naming the file, when the trial's file is missing or
    damaged.
    """
    record = registry.trial(trial_id)
    data = read_trial(file_to_read(registry, record)[0])
    first_name = None
    if include_first_name:
        first_name = registry.patient(record.patient_code).first_name
    last_trial, last_session = earlier_like(registry, record)
    content = build_report(
        data,
        previous_trial=registry_baseline(registry, last_trial),
        previous_session=registry_baseline(registry, last_session),
        first_name=first_name,
        patient_code=record.patient_code,
        session_number=record.session_number,
        trial_number=record.number,
        started_at=record.started_at,
        # The registry holds how the trial ended once it is finished; before that
        # the file's own status says more (e.g. still recording).
        status=record.status if record.finished else None,
        end_reason=record.end_reason,
        least_change=norms_mdc(registry) if record.parameters.get("assessment") else None,
    )
    from app.plans.dose import trial_plan_lines

    if record.parameters.get("assessment") and record.finished:
        content = with_task_page(registry, record, content)
    # a trial of a session plan: its block and the plan's dose, for the therapist
    extra = tuple(HeaderItem(label, value) for label, value in
                  trial_plan_lines(registry, trial_id))
    if not extra:
        return content
    return dataclasses.replace(content, therapist_header=content.therapist_header + extra)


TASK_NOTE = ("its own figures lead the table below, with their Z-scores and the task score "
             "on the last page; nothing is measured against the task's reference")
"""The therapist's header line of an assessment trial, after the task's title: the table
has the task's own figures (app.reports.task_table), not the distance from or direction
along the task's reference (the circle's dot, the targets' schedule, the robot's move),
which the task does not ask the patient to follow."""


def norms_mdc(registry: RecordStore) -> dict[str, float]:
    """The minimal detectable change (MDC95, SI) of each figure the data folder's norms in
    use know one for: a task's change within it is noise (compare.table_rows). Empty when
    there are no norms or they cannot be read (the task page says why)."""
    from app.errors import AppError
    from app.norms.in_use import norms_in_use

    try:
        norms = norms_in_use(registry.data_dir)
    except AppError:
        return {}
    if norms is None:
        return {}
    return {key: mdc for key in norms.figures if (mdc := norms.mdc95(key)) is not None}


def with_task_page(registry: RecordStore, record: Trial, content: ReportContent
                   ) -> ReportContent:
    """An assessment trial's report with its task's page (app.reports.assessment_page.
    trial_page) and a line in the therapist's header saying where the task's figures are
    and what the trial's table measures."""
    from app.reports.assessment_page import trial_page
    from core.assessment import TASK_TITLES

    task = record.parameters["assessment"]
    line = HeaderItem("Task", f"{TASK_TITLES.get(task, task)}: {TASK_NOTE}")
    return dataclasses.replace(content, assessment=trial_page(registry, record),
                               therapist_header=(*content.therapist_header, line))


def earlier_like(registry: RecordStore, record: Trial) -> tuple[Trial | None, Trial | None]:
    """Like with like: the patient's latest complete trial before this one of the same
    shape in the same assistance mode, and the latest such trial of an earlier session
    (content says which shape; the comparison says when the rest of the settings
    differ). A trial of the other mode is another exercise: its success figure is
    another one (app.reports.plain_language.SUCCESS_KEYS). A trial marked invalid is
    never the one compared with (schema v8)."""
    order = (record.session_number, record.number)
    invalid = registry.invalid_trials(record.patient_code)

    def like(other: Trial) -> bool:
        return (other.status == "complete" and other.id not in invalid
                and (other.session_number, other.number) < order
                and other.parameters.get("shape") == record.parameters.get("shape")
                and _mode(other) == _mode(record))

    earlier = sorted((t for t in registry.trials_for_patient(record.patient_code) if like(t)),
                     key=lambda t: (t.session_number, t.number))
    last_trial = earlier[-1] if earlier else None
    sessions = [t for t in earlier if t.session_number < record.session_number]
    return last_trial, sessions[-1] if sessions else None


def _mode(trial: Trial) -> str:
    return trial.parameters.get("assist", "thesis")


def registry_baseline(registry: RecordStore, trial: Trial | None) -> Baseline | None:
    """An earlier registered trial to compare with: its figures, settings and the levels
    it ran at from the registry; a trial registered before the registry kept the levels
    has them read from its file (None, so that it is not compared, when the file cannot
    be read: the level it was built with is not what it ran)."""
    if trial is None:
        return None
    baseline = as_baseline(trial)
    if baseline.levels is not None:
        return baseline
    try:
        data = read_trial(file_to_read(registry, trial)[0], channels=CHANNELS_NEEDED)
    except AppError:
        return baseline
    return dataclasses.replace(baseline, levels=data.assistance_in_effect())


def report_for_registry_trial(
    registry: RecordStore,
    trial_id: int,
    path: str | os.PathLike | None = None,
    *,
    include_first_name: bool = False,
) -> Path:
    """Write a registered trial's report and return its path: by default the data
    folder's reports/<code>/<code>_S…_T…_<time>.pdf (DataDir.report_path), replacing
    an earlier report of the same trial."""
    content = content_for_registry_trial(registry, trial_id,
                                         include_first_name=include_first_name)
    if path is None:
        record = registry.trial(trial_id)
        registry.data_dir.ensure(REPORTS, record.patient_code)
        path = registry.data_dir.report_path(record.patient_code, record.session_number,
                                             record.number, record.started_at)
    return write_report_pdf(content, path)


def write_report_pdf(content: ReportContent, path) -> Path:
    """Write the report's pages (app.reports.pdf). matplotlib is imported here, on first
    use, so the window and the command line start without it."""
    from app.reports.pdf import write_report_pdf as write

    return write(content, path)
