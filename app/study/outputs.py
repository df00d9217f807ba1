"""A study's results on disk: Parquet for DuckDB, pandas and Dask, CSV for everyone else.

In the output folder:

==================  ===================================================================
``trials/``         the analysed trials as a Parquet dataset, hive-partitioned by patient
                    (``trials/patient=P1ZTTAQ/part-0.parquet``) or by site
                    (``trials/site=north/…``); each patient's rows are their progress
                    table, by session and trial
``trials.csv``      the same rows in one table (one header line, SI units in the names)
``failures.csv``    file, patient, session, trial, reason: every file not analysed
==================  ===================================================================

DuckDB reads the dataset as one table, the partition a column::

    SELECT patient, avg(metric_sparc)
    FROM read_parquet('OUT/trials/*/*.parquet', hive_partitioning = true)
    GROUP BY patient

Written as every output of the console is (app.records.safewrite): nothing replaced unless
`overwrite`, and then only whole; nothing a data folder owns, ever (an output folder inside
a data folder only below its exports/ or reports/); refused before anything is written.
The CSV files are written atomically (device.safewrite); the Parquet dataset is written
whole into a private temporary folder beside its place, made durable, and renamed into
place: a reader sees the old dataset or the new one, never part of one.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import shutil
from collections.abc import Iterable
from pathlib import Path

import pandas as pd

from app.records.safewrite import (
    OutputRefused,
    atomic_output,
    check_output,
    check_output_folder,
    refuse_owned_folder,
)
from app.study.run import StudyResult
from device.safewrite import (
    PRIVATE_FILE,
    PRIVATE_FOLDER,
    absolute,
    shown,
    sync_folder,
    write_failed,
)

PARTITIONS = ("patient", "site")
DATASET, TRIALS_CSV, FAILURES_CSV = "trials", "trials.csv", "failures.csv"
_TEMPORARY = ".rehab-{token}.part"
_OLD = ".rehab-{token}.old"


def outputs(folder: Path) -> tuple[Path, Path, Path]:
    """The dataset folder and the two CSV files a study writes in `folder`."""
    return folder / DATASET, folder / TRIALS_CSV, folder / FAILURES_CSV


def check_outputs(folder: str | os.PathLike, *, overwrite: bool = False,
                  roots: Iterable[Path] = (), owned: bool = False) -> Path:
    """The output folder, refused (OutputRefused, one line) before any work is done when it
    is a data folder's own place (unless `owned`: the data folder's exports/study) or
    would replace a result without `overwrite`. Nothing is created here."""
    roots = tuple(roots)
    folder = absolute(folder)
    if not owned:
        refuse_owned_folder(folder, roots=roots, what="--output")
    if os.path.lexists(folder) and not folder.is_dir():
        raise OutputRefused(f"the output {shown(folder)} is a file, not a folder: give a "
                            "folder for the study's results")
    dataset, *tables = outputs(folder)
    if os.path.lexists(dataset):
        if not overwrite:
            raise OutputRefused(f"{shown(dataset)} already exists and is kept: give another "
                                "--output, or --overwrite to replace the study's results")
        if os.path.islink(dataset) or not dataset.is_dir():
            raise OutputRefused(f"{shown(dataset)} is not a folder of Parquet files: move "
                                "it, or give another --output")
    if folder.is_dir():
        for path in tables:
            check_output(path, overwrite=overwrite, what="--output")
    return folder


def write_study(result: StudyResult, folder: str | os.PathLike, *,
                partition_by: str = "patient", overwrite: bool = False,
                roots: Iterable[Path] = (), owned: bool = False) -> tuple[Path, ...]:
    """Write the results (see the module's doc); returns the dataset folder and the CSV
    files. OutputRefused (one line) when a result would be replaced without `overwrite`,
    the place is a data folder's own, or the disk refuses."""
    if partition_by not in PARTITIONS:
        raise OutputRefused(f"partition by {partition_by!r}: give one of "
                            f"{', '.join(PARTITIONS)}")
    roots = tuple(roots)
    folder = check_outputs(folder, overwrite=overwrite, roots=roots, owned=owned)
    folder = check_output_folder(folder, roots=roots, owned=owned, what="--output")
    dataset, trials_csv, failures_csv = outputs(folder)
    _write_csv(result.trials, trials_csv, overwrite)
    _write_csv(result.failures, failures_csv, overwrite)
    _write_dataset(result.trials, dataset, partition_by, overwrite)
    return dataset, trials_csv, failures_csv


def _write_csv(table: pd.DataFrame, path: Path, overwrite: bool) -> None:
    # owned: the folder was checked as a whole above (a data folder's exports/ is allowed)
    with atomic_output(path, overwrite=overwrite, text=True, owned=True) as stream:
        table.to_csv(stream, index=False, lineterminator="\n")


def _write_dataset(table: pd.DataFrame, dataset: Path, partition_by: str,
                   overwrite: bool) -> None:
    import pyarrow as pa
    import pyarrow.dataset as ds

    temporary = dataset.with_name(_TEMPORARY.format(token=secrets.token_hex(6)))
    try:
        os.mkdir(temporary, PRIVATE_FOLDER)
        arrow = pa.Table.from_pandas(table, preserve_index=False)
        ds.write_dataset(arrow, temporary, format="parquet", partitioning=[partition_by],
                         partitioning_flavor="hive", basename_template="part-{i}.parquet",
                         existing_data_behavior="error")
        _private_and_durable(temporary)
        _into_place(temporary, dataset, overwrite)
    except OSError as exc:
        raise write_failed(dataset, exc) from None
    finally:
        shutil.rmtree(temporary, ignore_errors=True)


def _private_and_durable(folder: Path) -> None:
    """Every file and folder below `folder` its user's only, on the disk."""
    for here, folders, files in os.walk(folder):
        os.chmod(here, PRIVATE_FOLDER)
        for name in files:
            path = os.path.join(here, name)
            os.chmod(path, PRIVATE_FILE)
            fd = os.open(path, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        for name in folders:
            os.chmod(os.path.join(here, name), PRIVATE_FOLDER)
        sync_folder(Path(here))


def _into_place(temporary: Path, dataset: Path, overwrite: bool) -> None:
    """The new dataset into its place: a rename fails when a folder with files is there
    (made meanwhile by someone else); with `overwrite` the old one is moved aside first
    and removed once the new one is in place."""
    old = None
    if overwrite and os.path.lexists(dataset):
        old = dataset.with_name(_OLD.format(token=secrets.token_hex(6)))
        os.rename(dataset, old)
    try:
        os.rename(temporary, dataset)
    except OSError:
        if old is not None:
            with contextlib.suppress(OSError):
                os.rename(old, dataset)  # the old results back where they were
        if os.path.lexists(dataset) and old is None:
            raise OutputRefused(f"{shown(dataset)} appeared while the study was being "
                                "written and is kept: give another --output, or "
                                "--overwrite") from None
        raise
    sync_folder(dataset.parent)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
