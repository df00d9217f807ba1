"""A study's analysis on Dask: the researcher's Python API, and what `rehab study analyse`
runs.

Example (tests/app/study/test_study.py runs the same)::

    from app.study import sources
    from app.study.cluster import study_client
    from app.study.run import analyse_study, study_frame

    selection = sources.from_folder("study")        # every .h5 file below it
    frame = study_frame(selection)                  # a Dask dataframe, lazy
    with study_client() as client:                  # two local worker processes
        sparc = frame[frame.failure == ""].groupby("patient").metric_sparc.mean().compute()
        result = analyse_study(selection, client)   # computed: rows and failures
    result.trials                                   # pandas, one row per analysed trial
    result.failures                                 # file, reason: what could not be read

The work is cut into chunks of trial files (a chunk is one task, and one partition of the
dataframe), enough of them for every worker to stay busy to the end and few enough that
the scheduler's cost per task (milliseconds) stays small beside a chunk's (seconds). A
worker reads and measures each file of its chunk itself (app.study.rows). A chunk whose
worker dies (a file that crashes the HDF5 library, memory) is done again one file a task,
so that only the file that kills a worker is listed, with why, and the rest is analysed.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import pandas as pd

from app.study.rows import StudyTrial, analyse_trials, failure_reason
from app.study.schema import SORT, empty_frame, frame
from app.study.sources import Selection

Progress = Callable[[float], None]

CHUNK_MAX = 50
"""Files per task at most: about 3 s of work on this machine (60 ms a file)."""
CHUNKS_PER_WORKER = 16
"""Tasks per worker at least when there are files enough: the last tasks to finish leave
the other workers idle for at most a sixteenth of the run."""
FAILURE_COLUMNS = ("file", "patient", "session", "trial", "reason")


@dataclass(frozen=True, slots=True)
class StudyResult:
    """A study computed: every analysed trial's row, and every file that could not be
    analysed with why."""

    trials: pd.DataFrame
    """One row per analysed trial (app.study.schema.COLUMNS, `failure` ''), by patient,
    session and trial: each patient's rows are their progress table."""
    failures: pd.DataFrame
    """FAILURE_COLUMNS: the file (relative to the study's root), who it was, and why it
    could not be analysed."""
    selection: Selection
    workers: int
    elapsed_s: float

    @property
    def files_per_s(self) -> float:
        done = len(self.trials) + len(self.failures)
        return done / self.elapsed_s if self.elapsed_s > 0 else math.inf


def chunks(trials: Sequence[StudyTrial], workers: int = 2,
           size: int | None = None) -> list[tuple[StudyTrial, ...]]:
    """The trials cut into tasks of `size` files (default: see CHUNK_MAX and
    CHUNKS_PER_WORKER), in order."""
    if size is None:
        size = min(CHUNK_MAX, max(1, math.ceil(len(trials) / (CHUNKS_PER_WORKER
                                                              * max(1, workers)))))
    return [tuple(trials[i:i + size]) for i in range(0, len(trials), size)]


def study_frame(selection: Selection, *, workers: int = 2, chunk_size: int | None = None):
    """The study as a lazy Dask dataframe: one partition a chunk of files, every column of
    app.study.schema.COLUMNS; a file that could not be analysed is a row whose `failure`
    says why (`frame[frame.failure == ""]` keeps the trials). Computed where the
    caller's client (or Dask's default scheduler) runs it."""
    import dask.dataframe as dd

    return dd.from_map(analyse_trials, chunks(selection.trials, workers, chunk_size),
                       meta=empty_frame(), label="study-trials", enforce_metadata=False)


def analyse_study(selection: Selection, client, *, progress: Progress | None = None,
                  chunk_size: int | None = None) -> StudyResult:
    """Compute the study on `client`'s cluster (app.study.cluster.study_client):
    `progress(fraction)` as chunks are done."""
    from distributed import as_completed

    from app.study.cluster import worker_count

    workers = worker_count(client)
    started = time.perf_counter()
    parts = chunks(selection.trials, workers, chunk_size)
    futures = client.map(analyse_trials, parts, pure=False)
    chunk_of = {future.key: part for future, part in zip(futures, parts, strict=True)}
    frames: list[pd.DataFrame] = []
    lost: list[tuple[StudyTrial, ...]] = []
    if progress is not None:
        progress(0.0)
    for done, future in enumerate(as_completed(futures), start=1):
        if future.status == "finished":
            frames.append(future.result())
        else:
            lost.append(chunk_of[future.key])
        future.release()
        if progress is not None:
            progress(done / len(futures))
    for part in lost:
        frames.append(_one_by_one(client, part))
    rows = pd.concat([empty_frame(), *frames], ignore_index=True) if frames else empty_frame()
    elapsed = time.perf_counter() - started
    failed = rows["failure"].fillna("") != ""
    trials = rows[~failed].sort_values(list(SORT), na_position="last", kind="stable")
    failures = rows[failed].sort_values("file", kind="stable")
    failures = failures.rename(columns={"failure": "reason"})[list(FAILURE_COLUMNS)]
    return StudyResult(trials.reset_index(drop=True), failures.reset_index(drop=True),
                       selection, workers, elapsed)


def _one_by_one(client, part: tuple[StudyTrial, ...]) -> pd.DataFrame:
    """A chunk whose task failed (its worker died), a file a task: the file that fails
    again is a row with why."""
    futures = client.map(analyse_trials, [(trial,) for trial in part], pure=False)
    rows = []
    for trial, future in zip(part, futures, strict=True):
        try:
            rows.append(future.result())
        except Exception as exc:
            died = failure_reason(exc)
            rows.append(frame([{**trial.identity(), "notes": "",
                                "failure": f"the worker reading it stopped ({died}): the file "
                                           "may crash the HDF5 library; check it alone with "
                                           "`rehab report` or restore it from the backup"}]))
        future.release()
    return pd.concat(rows, ignore_index=True)
