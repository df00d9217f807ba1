"""What the command line writes for patients and therapists: `rehab report` (a trial's
PDF, app.reports.build) and `rehab progress` (a patient's figures across sessions,
app.reports.progress), each from the data folder's registry."""

from __future__ import annotations

import argparse
import sys

from app.cli.common import (
    CommandError,
    counted,
    finite,
    num,
    output_path,
    record_id,
    registry_for,
    typed_code,
)
from app.records.outcomes import OUTCOME_COLUMNS, patient_outcomes
from app.reports.metrics_table import ROW_BY_KEY, MetricRow
from app.reports.progress import file_note, progress
from app.reports.progress_figure import figure_rows, shown_row


def _cell(value):
    """A CSV cell: '' for a value not known."""
    return "" if value is None else value


# ------------------------------------------------------------------ progress
def add_progress_command(commands) -> None:
    prog = commands.add_parser("progress", help="a patient's metrics across sessions",
                               description="Every metric of every trial of a patient, with "
                                           "the exercise it was done at.")
    prog.add_argument("code", help="the patient's code")
    prog.add_argument("--metric", action="append", dest="metrics",
                      help="metric to show (repeatable; default: the thesis's figures)")
    prog.add_argument("--csv", action="store_true",
                      help="all columns as CSV, with what each trial ran and what followed "
                           "it (the assistance mode, the levels in effect, the proposal and "
                           "its decision, why it ended, the robot)")
    prog.add_argument("--include-invalid", action="store_true",
                      help="also the trials marked invalid (`rehab invalid`), each saying why")
    prog.add_argument("--pdf", metavar="FILE",
                      help="also write the progress as a PDF, a page an exercise (an "
                           "existing file is kept unless --overwrite)")
    prog.add_argument("--overwrite", "--force", action="store_true", dest="overwrite",
                      help="replace the --pdf file if it exists (never one of the console's "
                           "own files)")
    prog.set_defaults(func=cmd_progress)


def cmd_progress(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    typed_code(args.code)
    pdf = None
    if args.pdf is not None:
        # checked before any work; inside the data folder only below its reports/ or
        # exports/ (app.records.safewrite)
        pdf = output_path(args, args.pdf, overwrite=args.overwrite, suffixes=(".pdf",),
                          what="--pdf")
    prog = progress(registry, args.code, include_invalid=args.include_invalid)
    header, rows = prog.table()
    if pdf is not None:
        from app.norms.in_use import norms_in_use
        from app.plans.dose import patient_doses
        from app.reports.progress_pdf import write_progress_pdf
        from app.reports.scales_progress import report_series

        # a change is real against the norms in use (their MDC95), as the window marks it
        series = report_series(registry, prog, include_invalid=args.include_invalid,
                               norms=norms_in_use(registry.data_dir))
        print(write_progress_pdf(prog, pdf, overwrite=args.overwrite,
                                 doses=patient_doses(registry, args.code),
                                 scales=registry.session_scales(args.code), series=series),
              file=sys.stderr if args.csv else sys.stdout)
    if args.csv:
        import csv

        outcomes = patient_outcomes(registry, args.code)
        backends = {t.id: t.backend for t in registry.trials_for_patient(args.code)}
        writer = csv.writer(sys.stdout)
        writer.writerow((*header, *OUTCOME_COLUMNS, "backend"))
        for row in rows:
            ran = outcomes.get(row[0], {})
            writer.writerow((*row, *(_cell(ran.get(name)) for name in OUTCOME_COLUMNS),
                             backends.get(row[0]) or ""))
        return 0
    if not rows:
        print(f"patient {args.code} has no trials yet")
        return 0
    unknown = [m for m in args.metrics or () if m not in header]
    if unknown:
        raise CommandError(f"unknown metric {unknown[0]!r}; known: "
                           + ", ".join(prog.metric_names))
    print(f"Progress of {args.code}: {counted(len(rows), 'trial')}, "
          f"{counted(len(prog.exercises), 'exercise')}")
    for index, exercise in enumerate(prog.exercises):
        members = prog.members(index).tolist()
        print(f"\nexercise {index + 1}: {exercise.label()} ({counted(len(members), 'trial')})")
        figures = [shown_row(key) for key in args.metrics] if args.metrics else [
            row for row in figure_rows(prog, index)
            if exercise.assessment or row.key in (exercise.success_key, *EXERCISE_FIGURES)]
        status = [_status(rows[i], header) for i in members]
        if exercise.assessment:
            _print_task(prog, rows, header, members, status, figures)
        else:
            _print_exercise(prog, rows, header, members, status, figures)
    reason = header.index("invalid_reason")
    for row in rows:
        if row[reason]:
            print(f"  session {row[1]} trial {row[2]} (id {row[0]}) marked invalid: "
                  f"{row[reason]}")
    # a file this station cannot read: lost, or still on the station that recorded it
    for trial, state, usable in zip(prog.trials, prog.file_states, prog.file_ok.tolist(),
                                    strict=True):
        if not usable:
            print(f"  session {trial.session_number} trial {trial.number} (id {trial.id}): "
                  f"{file_note(state, trial.station)}")
    return 0


EXERCISE_FIGURES = ("game_score", "rmse_x_m", "rmse_y_m", "directional_performance_pct",
                    "shoulder_rom_rad", "elbow_rom_rad")
"""An exercise's columns by default after its mode's success figure: a game's score and the
thesis's figures (the others with --metric, every one with --csv). An assessment task's
series shows its task's own figures (app.reports.progress_figure.figure_rows)."""


def _print_exercise(prog, rows, header, members, status, figures) -> None:
    """An exercise's trials, a line each: its status, the help it ran with, its figures."""
    labels = [row.heading for row in figures]
    # a column as wide as its heading: two assessment keys ran together in 18 characters
    widths = [max(18, len(label) + 2) for label in labels]
    station = header.index("station")
    at = max(9, *(len(rows[i][station]) + 2 for i in members))
    print(f"{'session':>7} {'trial':>5}  {'station':<{at}}{'status':<15}{'help':<24}"
          + "".join(f"{label:>{w}}" for label, w in zip(labels, widths, strict=True)))
    for i, said in zip(members, status, strict=True):
        row = rows[i]
        cells = [_progress_cell(f, row[header.index(f.key)]) for f in figures]
        levels = prog.levels[i]
        help_text = levels.summary() if prog.levels_recorded[i] else \
            f"{levels.summary()} (built)"
        print(f"{row[1]:>7} {row[2]:>5}  {row[station]:<{at}}{said:<15}{help_text:<24}"
              + "".join(f"{c:>{w}}" for c, w in zip(cells, widths, strict=True)))


def _print_task(prog, rows, header, members, status, figures) -> None:
    """An assessment task's runs, a column each (session and trial), and its figures, a
    line each: a task has more figures than a line holds (strength: 19), and few runs."""
    names = [f"S{rows[i][1]} T{rows[i][2]}" for i in members]
    station = header.index("station")
    lines = [("station", [rows[i][station] for i in members]), ("status", status)] + [
        (f.label,  # each cell says its unit
         [_progress_cell(f, rows[i][header.index(f.key)]) for i in members])
        for f in figures]
    first = max(len(label) for label, _ in lines) + 2
    widths = [max(12, len(name) + 2, *(len(cells[k]) + 2 for _, cells in lines))
              for k, name in enumerate(names)]
    print(f"{'figure':<{first}}" + "".join(f"{n:>{w}}" for n, w in zip(names, widths,
                                                                           strict=True)))
    for label, cells in lines:
        print(f"{label:<{first}}" + "".join(f"{c:>{w}}" for c, w in zip(cells, widths,
                                                                          strict=True)))


def _status(row, header) -> str:
    """A trial's status; --include-invalid: INVALID, and why below the tables."""
    return "INVALID" if row[header.index("invalid_reason")] else row[5]


def _progress_cell(row: MetricRow, value) -> str:
    """A progress cell in the row's display unit: a metrics table's figure with one
    decimal; an assessment figure (core.assessment.FIGURES, catalogue_row: mm, °, cm²) to
    4 significant digits: one decimal printed a ratio of 0.93 as 0.9."""
    if row.key in ROW_BY_KEY:
        return f"{num(value * row.scale if finite(value) else None)} {row.unit}".rstrip()
    if not finite(value):
        return "–"
    return f"{value * row.scale:.4g} {row.unit}".rstrip()




# ------------------------------------------------------------------ report
def add_report_command(commands) -> None:
    parser = commands.add_parser(
        "report", help="write a trial's post-trial report (PDF)",
        description="Write the post-trial report of a registered trial: the patient's page "
                    "in plain words (the path drawn as seen from the patient's seat) and the "
                    "therapist's figures.")
    parser.add_argument("trial_id", type=record_id,
                        help="the trial's id (see `rehab trials CODE`)")
    parser.add_argument("--output", help="PDF to write (default: the data folder's reports/); "
                                          "an existing file is kept unless --overwrite")
    parser.add_argument("--overwrite", "--force", action="store_true", dest="overwrite",
                        help="replace the report if it exists (never another of the "
                             "console's own files)")
    parser.add_argument("--first-name", action="store_true",
                        help="greet the patient by first name in the report")
    parser.set_defaults(func=cmd_report)


def cmd_report(args: argparse.Namespace) -> int:
    from app.reports.build import report_for_registry_trial

    registry = registry_for(args)
    if args.output is not None:
        # inside the data folder only below its reports/ or exports/ (app.records.safewrite)
        output = output_path(args, args.output, overwrite=args.overwrite, suffixes=(".pdf",))
    else:
        trial = registry.trial(args.trial_id)
        output = registry.data_dir.report_path(trial.patient_code, trial.session_number,
                                               trial.number, trial.started_at)
        if output.exists() and not args.overwrite:
            # the report the window's Save data wrote, perhaps printed: written again only
            # when asked
            raise CommandError(f"the report {output} already exists and is kept: give "
                               "--overwrite to write it again, or --output for another file")
        registry.data_dir.ensure(output.parent.parent.name, output.parent.name)
    path = report_for_registry_trial(registry, args.trial_id, output,
                                     include_first_name=args.first_name)
    print(path)
    return 0


# ------------------------------------------------------------------ session report
def add_session_report_command(commands) -> None:
    parser = commands.add_parser(
        "session-report", help="write a session's report (PDF): trials, scales, notes, "
                               "assessments",
        description="Write a session's report: its trials (those marked invalid saying why), "
                    "its clinical scales, its notes, and each assessment's figures with "
                    "their Z-scores against the norms in use (`rehab norms use`; their "
                    "source is printed).")
    parser.add_argument("code", help="the patient's code")
    parser.add_argument("session", type=int, help="the session's number")
    parser.add_argument("--output", help="PDF to write (default: the data folder's "
                                         "reports/CODE/CODE_S###_session.pdf); an existing "
                                         "file is kept unless --overwrite")
    parser.add_argument("--overwrite", "--force", action="store_true", dest="overwrite",
                        help="replace the report if it exists")
    parser.set_defaults(func=cmd_session_report)


def cmd_session_report(args: argparse.Namespace) -> int:
    from app.norms.in_use import norms_in_use
    from app.records.datadir import REPORTS
    from app.reports.session_report import write_session_report

    registry = registry_for(args)
    typed_code(args.code)
    if not 1 <= args.session <= 999_999:
        raise CommandError(f"session {args.session}: give a session number from 1")
    registry.session(args.code, args.session)  # refuses a session that does not exist
    if args.output is not None:
        output = output_path(args, args.output, overwrite=args.overwrite, suffixes=(".pdf",))
    else:
        folder = registry.data_dir.ensure(REPORTS, args.code)
        output = folder / f"{args.code}_S{args.session:03d}_session.pdf"
        if output.exists() and not args.overwrite:
            raise CommandError(f"the report {output} already exists and is kept: give "
                               "--overwrite to write it again, or --output for another file")
    print(write_session_report(registry, args.code, args.session, output,
                               overwrite=args.overwrite,
                               norms=norms_in_use(registry.data_dir)))
    return 0
