"""What one trial's registration sends to the PostgreSQL registry, statement by statement
(issue 32: registration p99 < 10 ms; docs/performance.md, "The shared registry on
PostgreSQL").

Run: .venv/bin/python bench/registration.py [--patients 100] [--trials-per-patient 1000]
     [--calls 300] [--pause-ms 0]

Starts a throwaway server (tests/postgres.py), fills a registry as bench/stations.py does
(the patients, their sessions, trials and a proposal after each trial, by COPY through the
server's numbering and seal triggers), then one station, alone on the server, registers
`--calls` trials for random patients as the console does: `begin_trial`, `finish_trial`
with metrics, `record_proposal` (`--pause-ms`: that long between two trials, as a station
waits for its patient; its processes' caches, and the server process's, go cold meanwhile).
For each call it prints

* its wall time p50 / p99 / max, and the station's CPU time in it (`time.process_time`);
* the round trips it makes to the server: BEGIN (the registry's own statement, which is
  also the connection's check: `Database._on_server`), each statement, COMMIT or ROLLBACK
  (counted by SQLAlchemy's events on the station's engine: `before_cursor_execute`,
  `commit`, `rollback`; tests/app/records/postgres/test_postgres_round_trips.py counts them
  on the wire);
* each statement with its median time as the station sees it (the round trip included).

Where a statement's time goes in the server (its triggers, its plan), EXPLAIN ANALYZE says:
docs/performance.md has what was found. Prints figures only; asserts nothing.
"""

from __future__ import annotations

import argparse
import collections
import random
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import sqlalchemy as sa

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:  # tests.postgres and bench.stations, when run as a file
    sys.path.insert(0, str(REPO))

from app.records.registry import Registry  # noqa: E402
from bench.stations import (  # noqa: E402
    fill,
    make_registry,
    parameters_for,
    percentiles,
    proposal_for,
    server_settings,
    single_metrics,
    throwaway_server,
)

CALLS = ("begin_trial", "finish_trial", "record_proposal")


class Counter:
    """The round trips and statements of the station's engine, per call."""

    def __init__(self, engine: sa.Engine) -> None:
        self.trips: list[str] = []
        self.times: list[tuple[str, float]] = []
        self._t0 = 0.0
        sa.event.listen(engine, "before_cursor_execute", self._before)
        sa.event.listen(engine, "after_cursor_execute", self._after)
        sa.event.listen(engine, "commit", lambda conn: self.trips.append("COMMIT"))
        sa.event.listen(engine, "rollback", lambda conn: self.trips.append("ROLLBACK"))

    def _before(self, conn, cursor, statement, parameters, context, many) -> None:
        self._t0 = time.perf_counter()

    def _after(self, conn, cursor, statement, parameters, context, many) -> None:
        text = " ".join(statement.split())
        self.trips.append(text)
        self.times.append((text, time.perf_counter() - self._t0))

    def take(self) -> tuple[list[str], list[tuple[str, float]]]:
        trips, times = self.trips, self.times
        self.trips, self.times = [], []
        return trips, times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--patients", type=int, default=100)
    parser.add_argument("--trials-per-patient", type=int, default=1000)
    parser.add_argument("--calls", type=int, default=300)
    parser.add_argument("--pause-ms", type=float, default=0.0,
                        help="the pause before each trial (default 0: back to back)")
    parser.add_argument("--fill-workers", type=int, default=2)
    args = parser.parse_args()

    print(f"load before: {Path('/proc/loadavg').read_text().strip()}", flush=True)
    server = throwaway_server()
    data_root = Path(tempfile.mkdtemp(prefix="rehab-bench-registration-"))
    try:
        bench = make_registry(server)
        codes, times = fill(bench, data_root, args.patients, args.trials_per_patient,
                            args.fill_workers, proposals=True)
        print(f"{server_settings(bench)}; {int(times['rows']):,} trials of {args.patients} "
              f"patients filled in {times['trials']:.0f} s", flush=True)
        station = Registry(data_root / "station", server=sa.make_url(bench.clinic_url))
        counter = Counter(station._writer)
        parameters = parameters_for(3, 4)
        rng = np.random.default_rng(7)
        pick = random.Random(7)
        station.trial_summaries(codes[0])  # the pool's first connection, as a running station
        walls: dict[str, list[float]] = collections.defaultdict(list)
        cpu: dict[str, list[float]] = collections.defaultdict(list)
        trips: dict[str, list[int]] = collections.defaultdict(list)
        statements: dict[str, dict[str, list[float]]] = collections.defaultdict(
            lambda: collections.defaultdict(list))
        shown: dict[str, list[str]] = {}
        for i in range(args.calls):
            code = pick.choice(codes)
            metrics = single_metrics(rng)
            begun = None
            if args.pause_ms:
                time.sleep(args.pause_ms / 1000.0)
            for call in CALLS:
                counter.take()
                c0, t0 = time.process_time(), time.perf_counter()
                if call == "begin_trial":
                    begun = station.begin_trial(code, parameters, backend="simulator",
                                                patient_kind="weak")
                elif call == "finish_trial":
                    station.finish_trial(begun.trial_id, "complete", metrics)
                else:
                    station.record_proposal(begun.trial_id, proposal_for(parameters, i))
                walls[call].append(time.perf_counter() - t0)
                cpu[call].append(time.process_time() - c0)
                sent, timed = counter.take()
                trips[call].append(len(sent))
                shown.setdefault(call, sent)
                for text, seconds in timed:
                    statements[call][text].append(seconds)
        print(f"load after: {Path('/proc/loadavg').read_text().strip()}")
        pace = f"{args.pause_ms:g} ms apart" if args.pause_ms else "back to back"
        print(f"\none station alone, {args.calls} trials for random patients "
              f"({args.trials_per_patient} trials each), {pace}, ms:")
        print(f"  {'call':<18} {'p50':>7} {'p99':>7} {'max':>7}  {'CPU p50':>7} {'p99':>7}"
              "  round trips")
        for call in CALLS:
            p50, p99, worst = percentiles(walls[call])
            cpu50, cpu99, _ = percentiles(cpu[call])
            counts = collections.Counter(trips[call])
            print(f"  {call:<18} {p50:7.2f} {p99:7.2f} {worst:7.2f}  {cpu50:7.2f} {cpu99:7.2f}  "
                  + ", ".join(f"{n} ({k}×)" for n, k in sorted(counts.items())))
            if len(counts) > 1:  # begin_trial opening today's session, or going on with it
                for n in sorted(counts):
                    p50, p99, worst = percentiles(
                        [w for w, t in zip(walls[call], trips[call], strict=True) if t == n])
                    print(f"    {n} round trips     {p50:7.2f} {p99:7.2f} {worst:7.2f}")
        for call in CALLS:
            print(f"\n{call}, as its first call sent it (the median of each statement over "
                  "every call, ms):")
            for text in shown[call]:
                samples = statements[call].get(text)
                median = f"{statistics.median(samples) * 1000:7.2f}" if samples else " " * 7
                print(f"  {median}  {text[:110]}")
    finally:
        server.stop()
        shutil.rmtree(data_root, ignore_errors=True)


if __name__ == "__main__":
    main()
