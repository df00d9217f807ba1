"""`rehab reanalyse`: stored trials' figures re-computed from their files by today's analysis
(app.trials.reanalyse), for a patient, one of their sessions, or every patient; --dry-run
lists what would change and stores nothing."""

from __future__ import annotations

import argparse
import sys

from app.cli.common import CommandError, registry_for, typed_code
from app.records.registry.values import NAME_MAX_CHARS
from app.trials.reanalyse import CHANGED, SKIPPED, UNCHANGED, reanalyse, trials_of


def add_reanalyse_command(commands) -> None:
    parser = commands.add_parser(
        "reanalyse", help="re-compute stored trials' figures from their files",
        description="Re-compute the figures of stored trials from their files with this "
                    "console's analysis (run it after an update that changed the analysis: "
                    "README, Researchers). Each file is verified against the registry's "
                    "checksum and its own seal first and is never written; a trial whose "
                    "file is missing or damaged is listed and skipped. The new figures "
                    "replace the registry's, with a note on the trial saying which "
                    "analysis made them, when and who ran it, and each figure's old and "
                    "new value. Running it again changes nothing. Exit 1 when a trial was "
                    "skipped.")
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--patient", metavar="CODE", help="one patient's trials")
    which.add_argument("--all", action="store_true", help="every patient's trials")
    parser.add_argument("--session", type=int, metavar="N",
                        help="only this session of --patient's")
    parser.add_argument("--dry-run", action="store_true",
                        help="list what would change (old → new, per figure); store nothing")
    parser.add_argument("--by", metavar="NAME",
                        help="who runs it, kept in each changed trial's note (required "
                             "unless --dry-run)")
    parser.set_defaults(func=cmd_reanalyse)


def cmd_reanalyse(args: argparse.Namespace) -> int:
    if args.patient is not None:
        typed_code(args.patient, "--patient")
    if args.session is not None and args.patient is None:
        raise CommandError("--session needs --patient: give the patient whose session it is")
    if args.session is not None and not 1 <= args.session <= 999_999:
        raise CommandError(f"--session {args.session}: give a session number from 1")
    by = (args.by or "").strip()
    if not args.dry_run and not by:
        raise CommandError("--by is missing: say who runs it (kept in each changed trial's "
                           "note), or give --dry-run to only list what would change")
    if len(by) > NAME_MAX_CHARS:
        raise CommandError(f"--by has {len(by)} characters; keep it to {NAME_MAX_CHARS}")
    registry = registry_for(args)
    trials = trials_of(registry, args.patient, args.session)
    if not trials:
        print("no trials to re-analyse")
        return 0
    live = sys.stderr.isatty()  # the progress line on a terminal; a log gets the list

    def said(done: int, outcome) -> None:
        if live:
            sys.stderr.write("\r\033[K")  # cleared for the trial's line
            sys.stderr.flush()
        print(outcome.line(), flush=True)
        for note in outcome.notes:
            print(f"  note: {note}", flush=True)
        if live:
            sys.stderr.write(f"re-analysed {done} of {len(trials)} trial(s) "
                             f"({100 * done // len(trials)} %)")
            sys.stderr.flush()

    outcomes = reanalyse(registry, trials, dry_run=args.dry_run, by=by, progress=said)
    if live:
        sys.stderr.write("\n")
    counts = {kind: sum(o.result == kind for o in outcomes)
              for kind in (CHANGED, UNCHANGED, SKIPPED)}
    changed = "would change" if args.dry_run else "changed"
    print(f"{len(outcomes)} trial(s): {counts[CHANGED]} {changed}, {counts[UNCHANGED]} "
          f"unchanged, {counts[SKIPPED]} skipped"
          + (" (dry run: nothing was stored)" if args.dry_run else ""))
    return 1 if counts[SKIPPED] else 0
