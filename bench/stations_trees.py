"""bench/stations.py's before/after comparison of source trees (`--trees`) on one fill: what
each tree's registry stores differently on the server, and the progress query read by a
process of each tree's own.

A tree's `create_registry` may set how the server stores a trial's row (app.records.registry.
postgres.TRIALS_UNCOMPRESSED, since 2026-12-06): the fill then writes a share of the
patients under each tree's setting (the table's setting at the moment a row is written is
the one it keeps), and each tree's phases read and register for its own share with the
table set as that tree sets it. The progress query is read by a process importing `app` from
the tree (spawned, as the stations are), so a change to the query's code is compared too.
Imported by bench/stations.py, which puts the repository on the path first.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import random
import sys
from pathlib import Path

import sqlalchemy as sa

RESET = "ALTER TABLE trials RESET (toast_tuple_target)"
"""The trials table as the server stores it by default (before TRIALS_UNCOMPRESSED)."""


@contextlib.contextmanager
def stations_from(tree: Path):
    """The processes spawned meanwhile import `app` from `tree` (a spawned process takes
    this one's sys.path; this repository stays on it, after `tree`, so that the bench's own
    modules load as they do here)."""
    saved = sys.path[:]
    sys.path.insert(0, str(Path(tree).resolve()))
    try:
        yield
    finally:
        sys.path[:] = saved


def _storage_statement(results) -> None:
    from app.records.registry import postgres

    results.put(getattr(postgres, "TRIALS_UNCOMPRESSED", None))


def tree_storage(tree: Path) -> str | None:
    """The statement with which `tree`'s create_registry sets the trials' storage (None:
    the server's default), read in a process importing `app` from `tree`."""
    ctx = mp.get_context("spawn")
    results = ctx.Queue()
    with stations_from(tree):
        process = ctx.Process(target=_storage_statement, args=(results,))
        process.start()
    statement = results.get(timeout=300)
    process.join(60)
    return statement


def set_storage(owner_url: str, statement: str | None) -> None:
    """The trials table stored as a registry whose create_registry runs `statement` does."""
    engine = sa.create_engine(owner_url, poolclass=sa.NullPool)
    try:
        with engine.begin() as conn:
            conn.exec_driver_sql(RESET)
            if statement:
                conn.exec_driver_sql(statement)
    finally:
        engine.dispose()


def shares(codes: list[str], n: int) -> list[list[str]]:
    """The patients split into `n` shares of consecutive codes, one a tree."""
    size = -(-len(codes) // n)
    return [codes[i * size:(i + 1) * size] for i in range(n)]


def reader(url: str, folder: str, codes: list[str], n: int, seed: int, pause_s: float,
           start, results) -> None:
    """A process reading `n` progress queries of random patients among `codes` (after
    `start`, a barrier, when given), then `n` bare round trips; puts (wall times, CPU
    times, spans, round trips, trials a patient) on `results`."""
    from stations import progress_queries, round_trips  # the bench's own, in this process

    from app.records.registry import Registry

    registry = Registry(Path(folder), server=sa.make_url(url))
    registry.trial_summaries(codes[0])  # the pool's first connection, as a running console
    if start is not None:
        start.wait(600)
    cpu: list[float] = []
    spans: list[tuple[float, float]] = []
    samples, rows = progress_queries(registry, codes, n, random.Random(seed), cpu, pause_s,
                                     spans)
    trips = round_trips(registry, n)
    results.put((samples, cpu, spans, trips, rows))


def read_idle(tree: Path, url: str, folder: Path, codes: list[str], n: int, seed: int):
    """`reader` from `tree`, alone: (wall times, CPU times, spans, round trips, rows)."""
    ctx = mp.get_context("spawn")
    results = ctx.Queue()
    with stations_from(tree):
        process = ctx.Process(target=reader, args=(url, str(folder), codes, n, seed, 0.0,
                                                   None, results))
        process.start()
    out = results.get(timeout=1800)
    process.join(60)
    return out
