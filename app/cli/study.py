"""`rehab study analyse FOLDER_OR_QUERY`: every trial's metrics and every patient's
progress table over a study's trial files, on Dask (app.study).

FOLDER_OR_QUERY is a folder of trial files, or the data folder's registry: a patient's
code, or `all` for every patient (an existing folder of that name is the folder). Trials
marked invalid are left out unless --include-invalid. The work runs on a local cluster of
worker processes (--workers, two by default) or on a cluster's scheduler (--scheduler
ADDRESS). The results go to --output (default: the data folder's exports/study) as
Parquet, partitioned by patient (or --partition-by site), and CSV; a file that cannot be
analysed is listed with why (`not analysed: FILE: why`) and the rest analysed, exit 1.
Everything is checked before any work: a bad input is one line and exit code 2.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import sys
from pathlib import Path

from app.cli.common import (
    CommandError,
    absolute,
    data_dir_for,
    data_roots,
    input_folder,
    progress_bar,
    registry_for,
    subcommands,
)
from app.records.datadir import EXPORTS
from app.records.registry import has_registry
from device.safewrite import shown

DEFAULT_OUTPUT = "study"
"""The default output, below the data folder's exports/."""


def add_study_commands(commands) -> None:
    parser = commands.add_parser(
        "study", help="analyse a whole study on Dask: every trial's metrics, every "
                      "patient's progress, as Parquet and CSV",
        description="Study-wide analysis on Dask (a local cluster, or a cluster's scheduler).")
    actions = subcommands(parser)
    analyse = actions.add_parser(
        "analyse", help="every trial's metrics and every patient's progress table",
        description="Compute every trial's metrics (the console's own analysis of each "
                    "file) and every patient's progress table over a folder of trial "
                    "files or the registry's patients, on Dask; write them as Parquet "
                    "(partitioned by patient or site) and CSV, queryable with DuckDB. "
                    "Files that cannot be analysed are listed with why.")
    analyse.add_argument("source", metavar="FOLDER_OR_QUERY",
                         help="a folder of trial files (.h5, below it), or the registry's: a "
                              "patient's code, or 'all' for every patient")
    analyse.add_argument("--output", help="folder for the results (default: the data "
                                          "folder's exports/study)")
    analyse.add_argument("--partition-by", choices=("patient", "site"), default="patient",
                         help="the Parquet dataset's partitions (default: patient)")
    analyse.add_argument("--site", help="the site of every trial analysed (default: the "
                                        "first folder below FOLDER for a study laid out "
                                        "SITE/PATIENT/FILE.h5)")
    analyse.add_argument("--scheduler", metavar="ADDRESS",
                         help="a Dask scheduler's address (tcp://HOST:PORT) to run on "
                              "(default: a local cluster on this machine)")
    analyse.add_argument("--connect-timeout", type=float, default=None, metavar="SECONDS",
                         help="how long to try to reach --scheduler (default: 30 s)")
    analyse.add_argument("--workers", type=int, default=None,
                         help="worker processes of the local cluster (default: 2)")
    analyse.add_argument("--include-invalid", action="store_true",
                         help="also the trials marked invalid (`rehab invalid`), each "
                              "saying why")
    analyse.add_argument("--overwrite", action="store_true",
                         help="replace the results of an earlier study in --output")
    analyse.set_defaults(func=cmd_study_analyse)


def cmd_study_analyse(args: argparse.Namespace) -> int:
    from app.study import sources
    from app.study.cluster import (
        CONNECT_TIMEOUT_S,
        LOCAL_WORKERS,
        scheduler_address,
        study_client,
    )
    from app.study.outputs import check_outputs, write_study
    from app.study.run import analyse_study

    if args.scheduler is not None:
        scheduler_address(args.scheduler)  # a typo is refused before anything is read
        if args.workers is not None:
            raise CommandError("--workers sets the local cluster's processes: a cluster's "
                               "scheduler has its own workers; give one of --workers and "
                               "--scheduler")
    elif args.connect_timeout is not None:
        raise CommandError("--connect-timeout is how long to try to reach --scheduler: give "
                           "--scheduler too, or leave it out")
    workers = LOCAL_WORKERS if args.workers is None else args.workers
    most = 2 * (os.cpu_count() or 1)
    if not 1 <= workers <= most:
        raise CommandError(f"--workers {workers}: give a whole number of worker processes "
                           f"from 1 to {most} (twice this machine's cores; one a core is "
                           "enough, the work is all computation)")
    if args.site is not None and not args.site.strip():
        raise CommandError("--site is empty: give the site's name, or leave it out")
    selection = _selection(args, sources)
    if args.output is not None:
        if not args.output.strip():
            raise CommandError("--output is empty: give a folder for the study's results")
        output = check_outputs(absolute(args.output), overwrite=args.overwrite,
                               roots=data_roots(args))
        owned = False
    else:
        output = check_outputs(data_dir_for(args).root / EXPORTS / DEFAULT_OUTPUT,
                               overwrite=args.overwrite, owned=True)
        owned = True
    bar = progress_bar(f"analysing {len(selection)} trial file(s)")
    timeout = CONNECT_TIMEOUT_S if args.connect_timeout is None else args.connect_timeout
    with study_client(args.scheduler, workers=workers, connect_timeout_s=timeout) as client:
        result = analyse_study(selection, client, progress=bar.update if bar else None)
    if bar:
        bar.done()
    dataset, trials_csv, failures_csv = write_study(
        result, output, partition_by=args.partition_by, overwrite=args.overwrite,
        roots=data_roots(args), owned=owned)
    print(f"analysed {len(result.trials)} trial(s) of {selection.what} on "
          f"{result.workers} worker(s) in {result.elapsed_s:.1f} s "
          f"({result.files_per_s:.1f} files/s)")
    for line in selection.settled:
        print(f"  note: {line}")
    if selection.left_out_invalid:
        print(f"  note: {selection.left_out_invalid} trial(s) marked invalid left out "
              "(`rehab trials CODE` says why); --include-invalid analyses them too")
    stale = int((result.trials.registry_differs.fillna("") != "").sum())
    if stale:
        print(f"  note: {stale} trial(s) have figures here that differ from the registry's, "
              "which an earlier analysis computed and `rehab progress`, the reports and "
              "`rehab export` show (column registry_differs names them): `rehab reanalyse "
              "--all --dry-run` lists them, without --dry-run it stores these")
    print(f"  Parquet, by {args.partition_by}: {dataset}")
    print(f"  CSV: {trials_csv}; failures: {failures_csv}")
    print(f"  query: {query_line(dataset)}")
    for failure in result.failures.itertuples(index=False):
        print(f"  not analysed: {failure.file}: {failure.reason}")
    return 0 if result.failures.empty else 1


def _selection(args: argparse.Namespace, sources):
    """What to analyse: the registry's patients for a code or 'all', else a folder."""
    text = args.source
    if not text.strip():
        raise CommandError("FOLDER_OR_QUERY is empty: give a folder of trial files, a "
                           "patient's code or 'all'")
    if sources.is_query(text):
        return sources.from_registry(registry_for(args), text,
                                     include_invalid=args.include_invalid, site=args.site)
    meant = text.strip().lower()
    meant = meant if meant == sources.EVERY_PATIENT else meant.upper()
    if not os.path.lexists(text) and sources.is_query(meant):
        # `ppr5aww` or `ALL`: no such folder, and a query is case-sensitive
        raise CommandError(f"FOLDER_OR_QUERY {shown(text)!r} is no folder; for the "
                           f"registry give {meant!r} (a patient's code is 'P' and 6 "
                           "capitals or digits; 'all' for every patient)")
    folder = input_folder(text, "FOLDER_OR_QUERY (a folder of trial files, a patient's "
                                "code or 'all')")
    data_dir = data_dir_for(args)
    registry = registry_for(args) if has_registry(data_dir) else None
    return sources.from_folder(folder, registry=registry,
                               include_invalid=args.include_invalid, site=args.site)


def query_line(dataset: Path) -> str:
    """A shell line that counts the rows of each patient of `dataset` with DuckDB, to paste
    as it is from any folder: the duckdb Python package (installed with the console) has
    no command of its own, so it runs in this console's own Python, named by its whole
    path (`.venv/bin/python` ran only from the console's folder), and the path is quoted
    for SQL, Python and the shell in turn."""
    files = "'" + f"{dataset}/*/*.parquet".replace("'", "''") + "'"
    sql = (f"SELECT patient, count(*) FROM read_parquet({files}, hive_partitioning = true) "
           "GROUP BY patient")
    code = f"import duckdb; duckdb.sql({json.dumps(sql)}).show()"
    if "!" in code:  # an interactive shell expands it even between double quotes
        return f"{shlex.quote(sys.executable)} -c {shlex.quote(code)}"
    # between double quotes, as the README writes it: the SQL's own quotes stay readable
    quoted = SHELL_DOUBLE_QUOTED.sub(r"\\\g<0>", code)
    return f'{shlex.quote(sys.executable)} -c "{quoted}"'


SHELL_DOUBLE_QUOTED = re.compile(r'[\\"$`]')
"""What a shell still reads between double quotes, each escaped with a backslash."""
