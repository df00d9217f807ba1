"""`rehab export`: registered trials, a patient's trials or a study's folder of trial files
as CSV, TSV, MATLAB .mat or a BIDS-motion dataset (app.exports.run). Exports never
contain names unless --include-names is given."""

from __future__ import annotations

import argparse

from app.cli.common import (
    CommandError,
    absolute,
    data_dir_for,
    input_folder,
    progress_bar,
    record_id,
    registry_for,
    typed_code,
)


def add_export_command(commands) -> None:
    from app.exports.run import FORMATS

    parser = commands.add_parser(
        "export", help="export trials as CSV, TSV, MATLAB .mat or a BIDS-motion folder",
        description="Export trials for analysis. Exports never contain names unless "
                    "--include-names is given.")
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--trial", type=record_id, action="append", dest="trial_ids", metavar="ID",
                      help="a registered trial (repeatable)")
    what.add_argument("--patient", action="append", dest="codes", metavar="CODE",
                      help="every trial of a patient (repeatable)")
    what.add_argument("--folder", help="every trial file below this folder (a study)")
    parser.add_argument("--format", choices=FORMATS, default="csv",
                        help="csv (default) or tsv: one table per trial, its units beside "
                             "it; mat: MATLAB; bids: a BIDS-motion folder")
    parser.add_argument("--output", help="destination folder (default: the data folder's "
                                         "exports/<format>)")
    parser.add_argument("--exercise-only", action="store_true",
                        help="only the exercise phase (not the approach and the hold)")
    parser.add_argument("--digits", type=int, help="significant digits in text exports "
                                                   "(default: exact)")
    parser.add_argument("--include-names", action="store_true",
                        help="include the patients' names (only in a names file)")
    parser.add_argument("--include-invalid", action="store_true",
                        help="also the trials marked invalid (`rehab invalid`; left out of "
                             "--patient and --folder exports by default)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace the files of trials exported there before (without "
                             "it nothing is written when one exists); the folder's tables "
                             "keep the other trials' rows either way")
    parser.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    from app.exports.run import export_folder, export_patients, export_registered

    _check_options(args)
    if args.folder is not None:
        if not args.folder.strip():
            raise CommandError("--folder is empty: give the folder that holds the study's "
                               "trial files")
        source = input_folder(args.folder, "--folder")
    else:
        registry = registry_for(args)  # before anything is made: a typo makes nothing
        for code in args.codes or ():
            typed_code(code, "--patient")
    if args.output is not None:
        if not args.output.strip():
            raise CommandError("--output is empty: give the destination folder")
        output = absolute(args.output)  # checked and made by the export (app.exports.files)
    else:
        output = data_dir_for(args).ensure("exports", args.format)
    bar = progress_bar(f"exporting {args.format}")
    options = {"format": args.format, "overwrite": args.overwrite,
               "progress": bar.update if bar else None}
    if args.format != "bids":
        options.update(exercise_only=args.exercise_only, digits=args.digits)
    if args.folder is not None:
        leave_out, known = _registry_knows(args)
        result = export_folder(source, output, leave_out=leave_out, known=known, **options)
    elif args.codes:
        result = export_patients(registry, args.codes, output,
                                 include_names=args.include_names,
                                 include_invalid=args.include_invalid, **options)
    else:
        result = export_registered(registry, args.trial_ids, output, **options)
    if bar:
        bar.done()
    print(f"exported {result.exported} trial(s) to {result.folder} "
          f"({len(result.files)} files)")
    for note in result.notes:
        print(f"  note: {note}")
    for failure in result.failed:
        print(f"  not exported: {failure.path}: {failure.reason}")
    return 0 if not result.failed else 1


def _check_options(args: argparse.Namespace) -> None:
    """An option that does nothing for what was asked is refused, never dropped silently."""
    if args.format == "bids":
        given = [name for name, value in (("--digits", args.digits is not None),
                                          ("--exercise-only", args.exercise_only)) if value]
        if given:
            many = len(given) > 1
            raise CommandError(f"{' and '.join(given)} {'apply' if many else 'applies'} to "
                               "csv, tsv and mat: a BIDS run is always the whole recording "
                               f"with every value exact; leave {'them' if many else 'it'} "
                               "out, or give another --format")
    if args.include_names and not args.codes:
        raise CommandError("--include-names works with --patient (the names come from the "
                           "registry's patients): export by --patient, or leave it out")
    if args.include_invalid and args.trial_ids:
        raise CommandError("--include-invalid is for --patient and --folder: --trial exports "
                           "the trials named, marked invalid or not; leave it out")


def _registry_knows(args: argparse.Namespace) -> tuple[list, dict]:
    """What the data folder's registry says of a --folder export's files: those of the
    trials marked invalid, to leave out (none with --include-invalid), and what it says of
    every trial it holds (its figures, which the export writes, app.exports.figures, and
    its invalid mark: app.exports.plan.registry_facts). Nothing where the
    data folder has no registry: a study's folder from elsewhere has no marks, and its
    files' figures are theirs."""
    from app.exports.plan import registry_facts
    from app.records.registry import has_registry, open_registry

    data_dir = data_dir_for(args)
    if not has_registry(data_dir):
        return [], {}
    registry = open_registry(data_dir, create=False)
    invalid = [] if args.include_invalid else [
        registry.trial_path(registry.trial(trial_id)) for trial_id in registry.invalid_trials()]
    return invalid, registry_facts(registry)
