"""Registry and progress-query cost on a realistic patient history.

Run: .venv/bin/python bench/registry.py [--trials N] [--repeats N]
Creates a temporary data folder with one patient and N trials (default 1,000:
50 sessions of 20 trials, parameters made harder over time, all of
core.metrics.TrialMetrics' scalar metrics), placeholder trial files with 2 % of
them missing, then prints p50 / p99 / max in ms of the progress query (goal:
< 50 ms for 1,000 trials), of registering one trial (begin + finish), and of the first
read of a registry opened anew, which checks its structure and every row's seal.

The progress query's p99 is set by the interpreter's full garbage-collector
passes over every live object (about 35 ms for this process's ~75,000), which
its allocations now and then trigger; the third line shows it with the
start-up objects frozen (gc.freeze()), as a long-running window can do.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import gc
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.progress import HDF5_SIGNATURE, progress
from core.metrics import TrialMetrics
from core.trial import TrialParameters

TRIALS_PER_SESSION = 20
METRIC_NAMES = tuple(f.name for f in dataclasses.fields(TrialMetrics)
                     if f.type in ("float", "int"))


def percentiles(samples_s: list[float]) -> tuple[float, float, float]:
    a = np.asarray(samples_s) * 1000.0
    return float(np.percentile(a, 50)), float(np.percentile(a, 99)), float(a.max())


def parameters_for(session: int, n_sessions: int) -> TrialParameters:
    # A course of therapy: a bigger D, less time per lap, less assistance.
    stage = min(3, 4 * session // max(n_sessions, 1))
    return TrialParameters(
        radius_m=0.08 + 0.02 * stage,
        duration_s=6.0 - stage,
        assistance_level=1.0 - 0.15 * stage,
    )


def metrics_for(rng: np.random.Generator, progress_fraction: float) -> dict[str, float]:
    skill = 1.0 - 0.6 * progress_fraction
    values = {name: float(rng.lognormal(0.0, 0.3)) for name in METRIC_NAMES}
    values.update(
        rmse_x_m=0.02 * skill * rng.lognormal(0.0, 0.2),
        rmse_y_m=0.025 * skill * rng.lognormal(0.0, 0.2),
        directional_performance_pct=100.0 * min(1.0, 0.5 + 0.4 * progress_fraction
                                                + 0.05 * rng.standard_normal()),
        sparc=-2.5 * skill + 0.1 * rng.standard_normal(),
        ldlj=-8.0 * skill + 0.3 * rng.standard_normal(),
        path_length_ratio=1.0 + 0.4 * skill * rng.lognormal(0.0, 0.2),
        n_reaches=0.0,
        reaction_time_s=math.nan,  # undefined on a D: stored as null
    )
    return values


def populate(registry: Registry, n_trials: int, rng: np.random.Generator) -> tuple[str, float]:
    patient = registry.create_patient("Bench", "Patient", side="right", body_mass_kg=80.0)
    n_sessions = max(1, math.ceil(n_trials / TRIALS_PER_SESSION))
    start = datetime.datetime(2024, 1, 8, 9, 0, tzinfo=datetime.UTC)
    t0 = time.perf_counter()
    for i in range(n_trials):
        session = i // TRIALS_PER_SESSION
        began = start + datetime.timedelta(days=2 * session, minutes=3 * (i % 20))
        trial = registry.begin_trial(
            patient.code, parameters_for(session, n_sessions), backend="simulator",
            session_number=session + 1, patient_kind="weak", started_at=began,
        )
        registry.finish_trial(trial.trial_id, "complete", metrics_for(rng, i / n_trials),
                              ended_at=began + datetime.timedelta(seconds=40))
        if rng.random() >= 0.02:
            trial.path.write_bytes(HDF5_SIGNATURE + bytes(56))
    return patient.code, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=100)
    args = parser.parse_args()
    rng = np.random.default_rng(7)

    with tempfile.TemporaryDirectory(prefix="rehab-bench-") as folder:
        registry = Registry(DataDir(Path(folder)))
        code, fill_s = populate(registry, args.trials, rng)
        print(f"registry: 1 patient, {args.trials} trials, {len(METRIC_NAMES)} metrics each; "
              f"filled in {fill_s:.1f} s")

        gc.collect()
        cases = (("with file check", True, False), ("registry only", False, False),
                 ("file check, gc.freeze()", True, True))
        for label, check_files, freeze in cases:
            if freeze:
                # What the window can do once started: move the start-up objects out
                # of the collector's reach, so that its full passes stay short.
                gc.freeze()
            samples = []
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                result = progress(registry, code, check_files=check_files)
                samples.append(time.perf_counter() - t0)
            gc.unfreeze()
            p50, p99, worst = percentiles(samples)
            print(f"progress query ({label:<23}): p50 {p50:6.2f} ms  p99 {p99:6.2f} ms  "
                  f"max {worst:6.2f} ms  ({len(result)} trials, "
                  f"{len(result.exercises)} exercises, "
                  f"{int((~result.file_ok).sum())} files missing)")

        samples = []
        parameters = TrialParameters()
        for _ in range(min(args.repeats, 50)):
            t0 = time.perf_counter()
            trial = registry.begin_trial(code, parameters, backend="simulator")
            registry.finish_trial(trial.trial_id, "complete", metrics_for(rng, 1.0))
            samples.append(time.perf_counter() - t0)
        p50, p99, worst = percentiles(samples)
        print(f"register one trial (begin + finish): p50 {p50:6.2f} ms  p99 {p99:6.2f} ms  "
              f"max {worst:6.2f} ms")
        samples = []
        for _ in range(5):
            # a console (or a command) that opens the registry checks it whole once: its
            # structure and every row's seal (app.records.registry.seals)
            fresh = Registry(DataDir(Path(folder)))
            t0 = time.perf_counter()
            fresh.patients()
            samples.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            fresh.patients()
            again = time.perf_counter() - t0
        p50, _, worst = percentiles(samples)
        print(f"first read, structure and seals checked: p50 {p50:6.2f} ms  max {worst:6.2f} "
              f"ms; a read after it: {again * 1000:.2f} ms")
        problems = registry.integrity_check()
        print("integrity check:", "ok" if not problems else "; ".join(problems))


if __name__ == "__main__":
    main()
