"""The shared registry on PostgreSQL with several stations (issue 32, "Figures for your note").

Run: .venv/bin/python bench/stations.py [--patients 1000] [--trials-per-patient 1000]
     [--stations 8] [--queries 200] [--pause-ms 0 100] [--reader-pause-ms 0]
     [--trees DIR ...]

A before/after comparison on one fill: `--trees` names source trees (e.g. `git archive`
of each commit unpacked in a folder); each registration phase runs once per tree, in turn,
the stations and the progress query's reader importing `app` from it, each tree with a
share of the patients of its own, filled and written as that tree's registry stores a
trial's row (bench/stations_trees.py; the fill's code stays this tree's).

A quick run: --patients 100 --trials-per-patient 100.

Starts a throwaway PostgreSQL server as the tests do (tests/postgres.py), makes a registry
on it as a department's owner does (app.records.registry.postgres.create_registry) with a
station's clinic login, and measures:

1. the fill: N patients (through Registry.create_patient), then their sessions (20 trials
   each), trials and proposals (one after each trial, as app.trials.finalize records them,
   each decided by the next trial, the last pending; `--no-proposals`: none) by COPY, with
   the server's numbering and seal triggers active (each row numbered, checked and sealed
   as a station's would be); parameters made harder over the course, the scalar metrics of
   core.metrics.TrialMetrics as bench/registry.py makes them. Then VACUUM ANALYZE.
   The registry and the fill are bench/stations_fill.py.
2. the progress query (Registry.trial_summaries) for random patients through the clinic
   login, read by a process of its own: p50 / p99 / max, idle and while the stations
   register, with that process's CPU time in each call, the query's time in the server
   (EXPLAIN ANALYZE, idle: it sends no row, so decompressing the metrics is not in it),
   and a bare round trip (SELECT 1) beside it.
3. registration: `--stations` processes (spawn), each a station with its own
   Registry(…, server=clinic URL), registering trials (begin_trial, then finish_trial with
   metrics, then record_proposal as the console does) for its own patients and, one
   trial in four, for a patient every station shares (their numbers then interleave in one
   session): p50 / p99 / max of each call per station and overall, trials per second,
   the station's CPU time in a begin + finish and its wait for a core meanwhile (runnable
   but not running: /proc/self/schedstat); a station's first trial apart from the others.
   Once flat out (as fast as the server lets them: a stress test, a station really
   registers a trial a minute), then with a pause of 50-150 ms between a station's trials
   (`--pause-ms`: one phase per value; with a pause each station begins at a moment of its
   own within the first, as stations that are not in step do). Meanwhile this process
   reads the progress of random patients, back to back (a stress: on this machine the
   reader takes a core from the stations while it reads) or `--reader-pause-ms` apart; the
   trials begun while it read are shown apart from the others.
4. afterwards: every patient's session numbers and every session's trial numbers are
   1..n without gaps or repeats, every trial a station registered is there once, and every
   row matches its seal (app.records.registry.postgres.seals.verify, what `rehab db
   status` checks), with how long that check took (bench/stations_checks.py).

Prints figures only; asserts nothing. docs/performance.md ("The shared registry on
PostgreSQL") has the figures and what they mean.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing as mp
import os
import random
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import sqlalchemy as sa

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:  # tests.postgres, when run as a file
    sys.path.insert(0, str(REPO))
sys.path.insert(0, str(Path(__file__).resolve().parent))  # stations_fill

from stations_checks import check_numbers, server_settings, verify_seals  # noqa: E402
from stations_fill import (  # noqa: E402
    TRIALS_PER_SESSION,
    Bench,
    fill,
    make_registry,
    parameters_for,
    proposal_for,
    single_metrics,
    throwaway_server,
)
from stations_trees import (  # noqa: E402
    read_idle,
    reader,
    set_storage,
    shares,
    stations_from,
    tree_storage,
)

from app.records.registry import Registry  # noqa: E402
from app.records.registry.queries import _SUMMARY_SELECT  # noqa: E402
from app.records.registry.statements import translated  # noqa: E402

SHARED_PATIENTS = 2
"""Patients every station registers for now and then (one trial in `SHARED_EVERY`)."""
SHARED_EVERY = 4


def percentiles(samples_s) -> tuple[float, float, float]:
    if len(samples_s) == 0:
        return math.nan, math.nan, math.nan
    a = np.asarray(samples_s) * 1000.0
    return float(np.percentile(a, 50)), float(np.percentile(a, 99)), float(a.max())


# -- 2. the progress query -----------------------------------------------------------------


def progress_queries(registry: Registry, codes: list[str], n: int, rng: random.Random,
                     cpu: list[float] | None = None, pause_s: float = 0.0,
                     spans: list[tuple[float, float]] | None = None
                     ) -> tuple[list[float], int]:
    """`n` progress queries of random patients: their wall times (and in `cpu`, this
    process's CPU time in each; in `spans`, when each ran, time.monotonic); `pause_s`
    apart on average (0: back to back)."""
    samples: list[float] = []
    rows = 0
    while len(samples) < n:
        if pause_s and samples:
            time.sleep(pause_s * rng.uniform(0.5, 1.5))
        code = rng.choice(codes)
        c0, t0, m0 = time.process_time(), time.perf_counter(), time.monotonic()
        result = registry.trial_summaries(code)
        samples.append(time.perf_counter() - t0)
        if spans is not None:
            spans.append((m0, time.monotonic()))
        if cpu is not None:
            cpu.append(time.process_time() - c0)
        rows = max(rows, len(result))
    return samples, rows


def server_times(bench: Bench, codes: list[str], n: int, rng: random.Random) -> list[float]:
    """The progress query's own time in the server (EXPLAIN ANALYZE's execution time, s)
    for `n` random patients, through the clinic login."""
    explain = sa.text("EXPLAIN (ANALYZE, FORMAT JSON) "
                      + translated(_SUMMARY_SELECT, "postgresql"))
    samples = []
    engine = sa.create_engine(bench.clinic_url, poolclass=sa.NullPool)
    try:
        with engine.connect() as conn:
            for _ in range(n):
                patient = conn.execute(sa.text("SELECT id FROM patients WHERE code = :c"),
                                       {"c": rng.choice(codes)}).scalar_one()
                plan = conn.execute(explain, {"p0": patient}).scalar_one()
                samples.append(plan[0]["Execution Time"] / 1000.0)
    finally:
        engine.dispose()
    return samples


def round_trips(registry: Registry, n: int) -> list[float]:
    """`n` bare round trips to the server through the registry's pool (`SELECT 1`, a
    connection already open): the floor under every statement a registration sends."""
    samples = []
    with registry._writer.connect() as conn:
        for _ in range(n):
            t0 = time.perf_counter()
            conn.exec_driver_sql("SELECT 1").scalar_one()
            samples.append(time.perf_counter() - t0)
        conn.rollback()
    return samples


# -- 3. the stations -----------------------------------------------------------------------


def core_wait() -> float:
    """This process's time so far waiting for a core while runnable, s (the kernel's
    scheduler statistics, /proc/self/schedstat: the run queue's wait of its main thread);
    NaN where the kernel keeps none."""
    try:
        return int(Path("/proc/self/schedstat").read_text().split()[1]) / 1e9
    except (OSError, IndexError, ValueError):
        return math.nan


def station(index: int, url: str, folder: str, own: list[str], shared: list[str],
            minimum: int, pause_s: float, proposals: bool, start, stop, results) -> None:
    """One station: begin_trial + finish_trial for its own patients and, one in
    SHARED_EVERY, a shared one, until `stop` is set and it has registered `minimum`."""
    rng = np.random.default_rng(1000 + index)
    pick = random.Random(index)
    registry = Registry(Path(folder), server=sa.make_url(url))
    parameters = parameters_for(3, 4)
    begins: list[float] = []
    finishes: list[float] = []
    cpu: list[float] = []
    waits: list[float] = []  # begin_trial's time runnable but waiting for a core
    starts: list[float] = []  # each begin_trial's start, time.monotonic (one clock for all)
    proposing: list[float] = []
    registered: list[tuple[int, str, int, int]] = []
    error = None
    try:
        registry.trial_summaries(own[0])  # the pool's first connection, as a running station
        start.wait(600)
        t_start = time.perf_counter()
        if pause_s:  # stations are not in step: each starts at its own moment of a pause
            time.sleep(pause_s * pick.uniform(0.0, 1.0))
        while len(begins) < minimum or not stop.is_set():
            code = pick.choice(shared) if pick.random() < 1 / SHARED_EVERY else pick.choice(own)
            metrics = single_metrics(rng)
            w0 = core_wait()
            starts.append(time.monotonic())
            c0, t0 = time.process_time(), time.perf_counter()
            trial = registry.begin_trial(code, parameters, backend="simulator",
                                         patient_kind="weak")
            t1 = time.perf_counter()
            waits.append(core_wait() - w0)  # begin_trial's
            t_finish = time.perf_counter()
            registry.finish_trial(trial.trial_id, "complete", metrics)
            t2, c2 = time.perf_counter(), time.process_time()
            begins.append(t1 - t0)
            finishes.append(t2 - t_finish)
            cpu.append(c2 - c0)
            if proposals:  # as app.trials.finalize does after an exercise trial
                t0 = time.perf_counter()
                registry.record_proposal(trial.trial_id, proposal_for(parameters, len(begins)))
                proposing.append(time.perf_counter() - t0)
            registered.append((trial.trial_id, code, trial.session_number,
                               trial.trial_number))
            if pause_s:
                time.sleep(pause_s * pick.uniform(0.5, 1.5))
        elapsed = time.perf_counter() - t_start
    except BaseException as exc:  # reported, not raised: the bench prints what it got
        error = f"{type(exc).__name__}: {exc}"
        elapsed = math.nan
    results.put((index, begins, finishes, registered, elapsed, error, cpu, proposing, waits,
                 starts))


def run_stations(bench: Bench, data_root: Path, codes: list[str], n_stations: int,
                 minimum: int, pause_s: float, queries: int, seed: int, proposals: bool,
                 reader_pause_s: float):
    ctx = mp.get_context("spawn")
    shared = codes[:SHARED_PATIENTS]
    rest = codes[SHARED_PATIENTS:]
    start = ctx.Barrier(n_stations + 2)  # the stations, the reader and this process
    stop = ctx.Event()
    results = ctx.Queue()
    read_results = ctx.Queue()
    processes = []
    for i in range(n_stations):
        own = rest[i::n_stations][:25] or rest[:1]
        folder = data_root / f"station{i}"
        processes.append(ctx.Process(target=station, args=(
            i, bench.clinic_url, str(folder), own, shared, minimum, pause_s, proposals, start,
            stop, results)))
    # the progress query read by a process of its own meanwhile, importing app as they do
    processes.append(ctx.Process(target=reader, args=(
        bench.clinic_url, str(data_root / "reader"), codes, queries, seed, reader_pause_s,
        start, read_results)))
    for process in processes:
        process.start()
    start.wait(600)
    t0 = time.perf_counter()
    # its wall and CPU times, when each progress query ran, its round trips
    samples, cpu, read, trips, _ = read_results.get(timeout=3600)
    stop.set()
    out = [results.get(timeout=600) for _ in processes[:n_stations]]
    wall = time.perf_counter() - t0
    for process in processes:
        process.join(60)
    return sorted(out), samples, cpu, trips, wall, read


# -- the whole run -------------------------------------------------------------------------


def line(label: str, samples, extra: str = "") -> str:
    p50, p99, worst = percentiles(samples)
    return (f"  {label:<44} {p50:8.2f} {p99:8.2f} {worst:8.2f}  {len(samples):>6}"
            + (f"  {extra}" if extra else ""))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--patients", type=int, default=1000)
    parser.add_argument("--trials-per-patient", type=int, default=1000)
    parser.add_argument("--stations", type=int, default=8)
    parser.add_argument("--station-trials", type=int, default=100,
                        help="at least this many trials per station (default 100); they go "
                             "on until the progress queries under load are done")
    parser.add_argument("--queries", type=int, default=200)
    parser.add_argument("--pause-ms", type=float, nargs="+", default=[0.0, 100.0],
                        help="a phase of registration for each: the mean pause of a station "
                             "between trials (default 0 100: flat out, then 100 ms apart)")
    parser.add_argument("--reader-pause-ms", type=float, default=0.0,
                        help="the mean pause between the progress queries read while the "
                             "stations register (default 0: back to back, a stress; a "
                             "therapist opens a patient's progress now and then)")
    parser.add_argument("--trees", nargs="+", type=Path, default=[REPO],
                        help="the source trees whose app/ the stations run (default: this "
                             "one): each --pause-ms phase runs once per tree, in turn, on "
                             "the one fill; a before/after comparison interleaved in one run "
                             "(e.g. --trees /tmp/lead . with --pause-ms 2000 2000)")
    parser.add_argument("--fill-workers", type=int, default=2)
    parser.add_argument("--no-proposals", action="store_true",
                        help="no proposals: neither in the fill nor after a station's trial")
    parser.add_argument("--no-verify", action="store_true",
                        help="skip the check of every row's seal at the end")
    args = parser.parse_args()

    print(f"load before: {Path('/proc/loadavg').read_text().strip()}  "
          f"({os.cpu_count()} cores)", flush=True)
    server = throwaway_server()
    data_root = Path(tempfile.mkdtemp(prefix="rehab-bench-stations-"))
    try:
        bench = make_registry(server)
        print(f"server: {server.path}; {server_settings(bench)}", flush=True)
        # each tree's share of the patients filled as its registry stores a trial's row
        storage = {tree: tree_storage(tree) for tree in args.trees}
        codes, fill_times = fill(
            bench, data_root, args.patients, args.trials_per_patient, args.fill_workers,
            not args.no_proposals, lambda codes: [
                (share, lambda tree=tree: set_storage(bench.owner_url, storage[tree]))
                for share, tree in zip(shares(codes, len(args.trees)), args.trees,
                                       strict=True)])
        own = dict(zip(args.trees, shares(codes, len(args.trees)), strict=True))
        rows = int(fill_times["rows"])
        print(f"fill: {args.patients} patients in {fill_times['patients']:.1f} s "
              f"(Registry.create_patient); {rows} trials in "
              f"{math.ceil(args.trials_per_patient / TRIALS_PER_SESSION) * args.patients} "
              f"sessions{'' if args.no_proposals else ', each trial with its proposal,'} "
              f"by COPY through the triggers in {fill_times['trials']:.1f} s "
              f"({rows / fill_times['trials']:,.0f} trials/s, {args.fill_workers} "
              f"connections); VACUUM ANALYZE {fill_times['analyze']:.1f} s; database "
              f"{fill_times['size_mb']:,.0f} MB", flush=True)

        idle = {}  # tree: (wall times, CPU times, spans, round trips, rows)
        for tree in args.trees:
            set_storage(bench.owner_url, storage[tree])
            idle[tree] = read_idle(tree, bench.clinic_url, data_root / "reader", own[tree],
                                   args.queries, seed=1)
        idle_server = server_times(bench, codes, args.queries, random.Random(3))
        n_rows = max(r[4] for r in idle.values())
        print(f"progress query idle done ({n_rows} trials a patient)", flush=True)

        phases = []
        for pause_ms, tree in [(p, t) for p in args.pause_ms for t in args.trees]:
            print(f"load before the stations ({pause_ms:g} ms pause, {tree}): "
                  f"{Path('/proc/loadavg').read_text().strip()}", flush=True)
            set_storage(bench.owner_url, storage[tree])
            with stations_from(tree):
                phases.append((pause_ms, *run_stations(
                    bench, data_root, own[tree], args.stations, args.station_trials,
                    pause_ms / 1000.0, args.queries, seed=2 + len(phases),
                    proposals=not args.no_proposals,
                    reader_pause_s=args.reader_pause_ms / 1000.0), tree))
        registered = [r for phase in phases for o in phase[1] for r in o[3]]
        t0 = time.perf_counter()
        problems = check_numbers(bench, registered)
        check_s = time.perf_counter() - t0
        seal_s, seal_verdict = (math.nan, "not checked (--no-verify)") if args.no_verify \
            else verify_seals(bench)
        print(f"load after: {Path('/proc/loadavg').read_text().strip()}", flush=True)

        print()
        print(f"PostgreSQL registry: {args.patients} patients × {args.trials_per_patient} "
              f"trials ({rows:,} trials); {args.stations} stations, each in a process of its "
              "own")
        print(f"  {'ms':<44} {'p50':>8} {'p99':>8} {'max':>8}  {'n':>6}")
        for tree, (wall, cpu, _, trips, _) in idle.items():
            whose = f", app/ of {tree}" if len(args.trees) > 1 else ""
            print(line(f"progress query, idle{whose}", wall,
                       f"goal p99 < 50 ms; {n_rows} trials"
                       + (f"; trials {'un' if storage[tree] else ''}compressed"
                          if len(args.trees) > 1 else "")))
            print(line("  its CPU time in the reading process", cpu))
            print(line("a bare round trip (SELECT 1), idle", trips))
        # EXPLAIN ANALYZE sends no row: the decompression of compressed metrics is not in it
        print(line("  its time in the server (EXPLAIN ANALYZE)", idle_server,
                   "sends no row: no decompression"))
        for pause_ms, out, busy, busy_cpu, trips, wall, read, tree in phases:
            how = "flat out" if not pause_ms else f"{pause_ms:g} ms apart"
            how += f", app/ of {tree}" if len(args.trees) > 1 else ""
            print(f"  -- {args.stations} stations registering {how}")
            reader = ("back to back" if not args.reader_pause_ms
                      else f"{args.reader_pause_ms:g} ms apart")
            print(line("progress query meanwhile", busy,
                       f"{reader}, over {read[-1][1] - read[0][0]:.1f} s"))
            print(line("  its CPU time in the reading process", busy_cpu))
            print(line("a bare round trip (SELECT 1) meanwhile", trips))
            print(line("begin_trial, all stations", [x for o in out for x in o[1]],
                       "goal p99 < 10 ms"))
            print(line("finish_trial, all stations", [x for o in out for x in o[2]],
                       "goal p99 < 10 ms"))
            # a station's first trial is its process's first: its statements not yet
            # compiled by SQLAlchemy nor prepared by psycopg (its server process has run a
            # registration already: the connection's warm-up, postgres/warm.py); flat out
            # (no pause) the stations also start it all at once
            print(line("  begin_trial, each station's first trial", [o[1][0] for o in out
                                                                    if o[1]]))
            # each trial after the first: its time, and whether a progress query ran
            # while it was being registered
            after = [(x, any(q0 < t + x and t < q1 for q0, q1 in read))
                     for o in out for x, t in zip(o[1][1:], o[9][1:], strict=True)]
            print(line("  begin_trial, the trials after", [x for x, _ in after]))
            # the reader's progress queries take a core of their own while they run: the
            # stations' trials begun then, and the others
            print(line("    while a progress query ran",
                       [x for x, during in after if during]))
            print(line("    with no progress query running",
                       [x for x, during in after if not during]))
            # the 8 stations' own CPU shares the server's 2 cores here; in a department each
            # station is a computer of its own and waits for no other station's process
            print(line("    begin_trial's wait for a core, the trials after",
                       [x for o in out for x in o[8][1:]], "runnable, not running"))
            print(line("    begin_trial less that wait, the trials after",
                       [b - w for o in out for b, w in zip(o[1][1:], o[8][1:], strict=True)],
                       "as on a computer of its own"))
            print(line("  finish_trial, the trials after", [x for o in out for x in o[2][1:]]))
            print(line("begin + finish, all stations",
                       [b + f for o in out for b, f in zip(o[1], o[2], strict=True)]))
            print(line("  their CPU time in the station's process", [x for o in out for x in o[6]]))
            if not args.no_proposals:
                print(line("record_proposal after each trial",
                           [x for o in out for x in o[7]]))
            for index, begins, finishes, _, elapsed, *_ in out:
                rate = len(begins) / elapsed if elapsed == elapsed and elapsed else math.nan
                p50b, p99b, maxb = percentiles(begins)
                p50f, p99f, maxf = percentiles(finishes)
                print(f"     station {index}: {len(begins):>5} trials, {rate:6.1f}/s; begin "
                      f"{p50b:.2f}/{p99b:.2f}/{maxb:.2f}, finish {p50f:.2f}/{p99f:.2f}/"
                      f"{maxf:.2f} ms (p50/p99/max)")
            count = sum(len(o[3]) for o in out)
            print(f"     throughput: {count} trials in {wall:.1f} s = {count / wall:.0f} "
                  "trials/s across the stations")
            for index, _, _, _, _, error, *_ in out:
                if error:
                    print(f"     station {index} FAILED: {error}")
        shared = sum(1 for r in registered
                     if r[1] in {c for share in own.values() for c in share[:SHARED_PATIENTS]})
        print(f"  numbering: {len(registered)} trials ({shared} for the {SHARED_PATIENTS} "
              f"patients every station shares): "
              + ("gap-free and unique per patient and session, each stored as handed out"
                 if not problems else "PROBLEMS: " + "; ".join(problems[:5]))
              + f" (checked over the whole registry in {check_s:.1f} s)")
        print(f"  seals: {seal_verdict}"
              + ("" if math.isnan(seal_s) else f" (verify took {seal_s:.1f} s)"))
    finally:
        server.stop()
        shutil.rmtree(data_root, ignore_errors=True)


if __name__ == "__main__":
    main()
