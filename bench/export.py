"""Export speed on a 60 s trial: CSV, TSV, .mat and BIDS.

Run: .venv/bin/python bench/export.py [--repeats N]
Simulates a healthy subject on the thesis's D for 60 s (30,000 samples at
500 Hz), writes its trial file to a temporary folder, then exports it N times
(default 3) in each format, each time into a fresh folder and starting from the
file on disk (the read is part of the export). Prints the best time, the speed
in MB/s of HDF5 input read and in samples/s, and the size of what was written.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from app.exports.plan import source_for_path
from app.exports.run import export_trial, export_trials
from core.trial import THESIS_SUBJECT
from device.recording.trialfile import SubjectInfo, write_trial

DURATION_S = 60.0
SAMPLES = 30_000


def make_trial(path: Path) -> Path:
    from app.trials.headless import simulate

    parameters = THESIS_SUBJECT.replace(repetitions=int(DURATION_S // THESIS_SUBJECT.duration_s))
    run = simulate(parameters, patient="healthy", seed=0)
    if len(run.records) < SAMPLES:
        raise SystemExit(f"the simulation gave {len(run.records)} samples, fewer than {SAMPLES}")
    return write_trial(
        path, run.records[:SAMPLES], parameters=parameters,
        subject=SubjectInfo.from_parameters("BENCH", parameters), robot=run.plan.robot,
        backend="simulator (healthy, seed 0)", sample_period_s=run.plan.period_s,
        events=run.events[:1], status="complete",
    )


def export_once(fmt: str, source: Path, folder: Path) -> tuple[float, int]:
    started = time.perf_counter()
    if fmt == "bids":
        result = export_trials([source_for_path(source)], folder, format="bids")
        files = result.files
    else:
        files = export_trial(source, folder, format=fmt)
    elapsed = time.perf_counter() - started
    return elapsed, sum(p.stat().st_size for p in files)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        source = make_trial(tmp / "bench.h5")
        size_mb = source.stat().st_size / 1e6
        print(f"export of a {DURATION_S:g} s trial: {SAMPLES:,} samples at 500 Hz, "
              f"HDF5 file {size_mb:.1f} MB; best of {args.repeats}")
        print(f"{'format':8}{'time s':>9}{'MB/s':>9}{'samples/s':>13}{'written MB':>12}")
        for fmt in ("csv", "tsv", "mat", "bids"):
            runs = [export_once(fmt, source, tmp / f"{fmt}-{i}") for i in range(args.repeats)]
            best, written = min(runs)
            print(f"{fmt:8}{best:9.3f}{size_mb / best:9.1f}{SAMPLES / best:13,.0f}"
                  f"{written / 1e6:12.1f}")


if __name__ == "__main__":
    main()
