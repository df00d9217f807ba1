"""The clinic's records on the command line: patients, trials, progress.

Each command opens the registry of the data folder (REHAB_DATA_DIR, the setting, or the
default; `--data-dir` overrides) and prints plain columns. Names are shown only by
`patients`, which is the clinic's own view; `--no-names` hides them there too.
"""

from __future__ import annotations

import argparse
import math

from app.records.datadir import DataDir, locate_data_dir
from app.records.registry import Registry
from app.reports.metrics_table import ROWS
from app.reports.progress import progress
from core.trial import SIDES


def registry_for(args: argparse.Namespace) -> Registry:
    if getattr(args, "data_dir", None):
        return Registry(DataDir(_absolute(args.data_dir), "command line"))
    return Registry(locate_data_dir())


def _absolute(text: str):
    from pathlib import Path

    return Path(text).expanduser().resolve()


# ------------------------------------------------------------------ patients
def add_patient_commands(commands) -> None:
    parser = commands.add_parser("patients", help="list, find or register patients",
                                 description="List, find or register patients.")
    parser.add_argument("--search", help="part of a name, or the start of a code")
    parser.add_argument("--no-names", action="store_true", help="show codes only")
    parser.set_defaults(func=cmd_patients)
    sub = parser.add_subparsers(dest="action", metavar="action", parser_class=type(parser))
    add = sub.add_parser("add", help="register a new patient (prints the new code)",
                         description="Register a new patient. SI units: kg and m.")
    add.add_argument("--first-name")
    add.add_argument("--last-name")
    add.add_argument("--birth-year", type=int)
    add.add_argument("--side", choices=SIDES, help="arm trained (affected side)")
    add.add_argument("--body-mass", type=float, help="kg")
    add.add_argument("--upper-arm", type=float, help="shoulder to elbow, m")
    add.add_argument("--forearm", type=float, help="elbow to wrist, m")
    add.add_argument("--shoulder", nargs=2, type=float, metavar=("X", "Y"),
                     help="shoulder position in the robot's frame, m")
    add.add_argument("--notes", default="")
    add.set_defaults(func=cmd_patients_add)


def cmd_patients(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    patients = (registry.search_patients(args.search) if args.search
                else registry.patients())
    if not patients:
        print("no patients" + (f" match {args.search!r}" if args.search else " yet"))
        return 0
    for p in patients:
        name = "" if args.no_names else f"  {p.last_name or ''}, {p.first_name or ''}".rstrip(", ")
        side = p.side or "-"
        mass = f"{p.body_mass_kg:g} kg" if p.body_mass_kg else "-"
        print(f"{p.code}{name:<32}  side {side:<5}  {mass}")
    return 0


def cmd_patients_add(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    patient = registry.create_patient(
        args.first_name, args.last_name, birth_year=args.birth_year, side=args.side,
        body_mass_kg=args.body_mass, upper_arm_m=args.upper_arm, forearm_m=args.forearm,
        shoulder_m=tuple(args.shoulder) if args.shoulder else None, notes=args.notes,
    )
    print(patient.code)
    return 0


# ------------------------------------------------------------------ trials
def add_trial_commands(commands) -> None:
    parser = commands.add_parser("trials", help="a patient's trials with their key figures",
                                 description="List a patient's trials: session, trial, "
                                             "status, exercise and key figures.")
    parser.add_argument("code", help="the patient's code (see `rehab patients`)")
    parser.set_defaults(func=cmd_trials)

    prog = commands.add_parser("progress", help="a patient's metrics across sessions",
                               description="Every metric of every trial of a patient, with "
                                           "the exercise it was done at.")
    prog.add_argument("code", help="the patient's code")
    prog.add_argument("--metric", action="append", dest="metrics",
                      help="metric to show (repeatable; default: the thesis's figures)")
    prog.add_argument("--csv", action="store_true", help="all columns as CSV")
    prog.set_defaults(func=cmd_progress)


def cmd_trials(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    trials = registry.trials_for_patient(args.code)
    if not trials:
        print(f"patient {args.code} has no trials yet")
        return 0
    print(f"{'id':>5} {'session':>7} {'trial':>5}  {'started (UTC)':<20}{'status':<15}"
          f"{'exercise':<26}{'RMSE x/y mm':>13}{'direction %':>12}")
    for t in trials:
        p = t.parameters
        exercise = f"{p.get('shape', '?')} r {1000 * p.get('radius_m', math.nan):.0f} mm, " \
                   f"{p.get('duration_s', math.nan):g} s"
        rmse = f"{_mm(t.metrics.get('rmse_x_m'))}/{_mm(t.metrics.get('rmse_y_m'))}"
        direction = t.metrics.get("directional_performance_pct")
        started = t.started_at.strftime("%Y-%m-%d %H:%M") if t.started_at else "-"
        print(f"{t.id:>5} {t.session_number:>7} {t.number:>5}  {started:<20}{t.status:<15}"
              f"{exercise:<26}{rmse:>13}{_num(direction):>12}")
    return 0


def cmd_progress(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    prog = progress(registry, args.code)
    header, rows = prog.table()
    if args.csv:
        import csv
        import sys

        writer = csv.writer(sys.stdout)
        writer.writerow(header)
        writer.writerows(rows)
        return 0
    if not rows:
        print(f"patient {args.code} has no trials yet")
        return 0
    wanted = args.metrics or ["rmse_x_m", "rmse_y_m", "directional_performance_pct",
                              "shoulder_rom_rad", "elbow_rom_rad"]
    unknown = [m for m in wanted if m not in header]
    if unknown:
        from app.cli.main import CommandError

        raise CommandError(f"unknown metric {unknown[0]!r}; known: "
                           + ", ".join(prog.metric_names))
    rows_by_key = {r.key: r for r in ROWS}
    labels = [rows_by_key[m].heading if m in rows_by_key else m for m in wanted]
    print(f"Progress of {args.code}: {len(rows)} trials, "
          f"{len(prog.parameter_sets)} exercise settings")
    for i, parameter_set in enumerate(prog.parameter_sets):
        print(f"  set {i + 1}: {parameter_set.label()}")
    print(f"{'session':>7} {'trial':>5} {'set':>3}  {'status':<15}"
          + "".join(f"{label:>18}" for label in labels))
    index = {name: header.index(name) for name in wanted}
    for row, set_index in zip(rows, prog.parameter_set_index.tolist(), strict=True):
        cells = []
        for m in wanted:
            value = row[index[m]]
            scale = rows_by_key[m].scale if m in rows_by_key else 1.0
            unit = rows_by_key[m].unit if m in rows_by_key else ""
            cells.append(f"{_num(value * scale if _finite(value) else None)} {unit}".rstrip())
        print(f"{row[1]:>7} {row[2]:>5} {set_index + 1:>3}  {row[5]:<15}"
              + "".join(f"{c:>18}" for c in cells))
    return 0


def _finite(value) -> bool:
    return isinstance(value, int | float) and math.isfinite(value)


def _mm(value) -> str:
    return f"{1000 * value:.1f}" if _finite(value) else "–"


def _num(value) -> str:
    return f"{value:.1f}" if _finite(value) else "–"


# ------------------------------------------------------------------ exports
def add_export_command(commands) -> None:
    from app.exports.run import FORMATS

    parser = commands.add_parser(
        "export", help="export trials as CSV, TSV, MATLAB .mat or a BIDS-motion folder",
        description="Export trials for analysis. Exports never contain names unless "
                    "--include-names is given.")
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--trial", type=int, action="append", dest="trial_ids", metavar="ID",
                      help="a registered trial (repeatable)")
    what.add_argument("--patient", action="append", dest="codes", metavar="CODE",
                      help="every trial of a patient (repeatable)")
    what.add_argument("--folder", help="every trial file below this folder (a study)")
    parser.add_argument("--format", choices=FORMATS, default="csv")
    parser.add_argument("--output", help="destination folder (default: the data folder's "
                                         "exports/<format>)")
    parser.add_argument("--exercise-only", action="store_true",
                        help="only the exercise phase (not the approach and the hold)")
    parser.add_argument("--digits", type=int, help="significant digits in text exports "
                                                   "(default: exact)")
    parser.add_argument("--include-names", action="store_true",
                        help="include the patients' names (only in a names file)")
    parser.add_argument("--overwrite", action="store_true")
    parser.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    import sys

    from app.cli.main import ProgressBar
    from app.exports.run import export_folder, export_patients, export_trials

    registry = registry_for(args)
    output = _absolute(args.output) if args.output else \
        registry.data_dir.ensure("exports", args.format)
    bar = ProgressBar(f"exporting {args.format}") if sys.stderr.isatty() else None
    options = {"format": args.format, "overwrite": args.overwrite,
               "progress": bar.update if bar else None}
    if args.format != "bids":
        options.update(exercise_only=args.exercise_only, digits=args.digits)
    if args.folder:
        result = export_folder(_absolute(args.folder), output, **options)
    elif args.codes:
        result = export_patients(registry, args.codes, output,
                                 include_names=args.include_names, **options)
    else:
        paths = [registry.trial_path(registry.trial(i)) for i in args.trial_ids]
        result = export_trials(paths, output, **options)
    if bar:
        bar.done()
    print(f"exported {result.exported} trial(s) to {result.folder} "
          f"({len(result.files)} files)")
    for failure in result.failed:
        print(f"  not exported: {failure.path}: {failure.reason}")
    return 0 if not result.failed else 1


# ------------------------------------------------------------------ reports
def add_report_command(commands) -> None:
    parser = commands.add_parser(
        "report", help="write a trial's post-trial report (PDF)",
        description="Write the post-trial report of a registered trial: the patient's page "
                    "in plain words and the therapist's figures.")
    parser.add_argument("trial_id", type=int, help="the trial's id (see `rehab trials CODE`)")
    parser.add_argument("--output", help="PDF to write (default: the data folder's reports/)")
    parser.add_argument("--flip", action="store_true",
                        help="draw the path as seen from the patient's chair (thesis Fig. 3.7)")
    parser.add_argument("--first-name", action="store_true",
                        help="greet the patient by first name in the report")
    parser.set_defaults(func=cmd_report)


def cmd_report(args: argparse.Namespace) -> int:
    from app.reports.build import report_for_registry_trial

    registry = registry_for(args)
    path = report_for_registry_trial(
        registry, args.trial_id, _absolute(args.output) if args.output else None,
        include_first_name=args.first_name, flip_axes=args.flip)
    print(path)
    return 0
