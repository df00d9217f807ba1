"""Time to make a trial's PDF report, from reading its file to the written PDF.

Run: .venv/bin/python bench/report.py [--trials N] [--repetitions R]
Simulates N trials (default 10) of the thesis's D with R repetitions each (default
5, the thesis experiment: 20 s of exercise, 10,000 samples) over the virtual
patients, writes their files to a temporary folder, then times
read_trial + build_report + write_report_pdf for each, comparing every trial with
the one before it. Python start-up and imports are outside the timing; the first
report of the process (which also loads matplotlib's font cache) is shown on its own
line and left out of the percentiles. Goal: p50 and max under 2 s.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from app.reports.build import build_report, write_report_pdf
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.sim.patient_parameters import PATIENT_KINDS

GOAL_S = 2.0


def one_report(path: Path, previous: Path | None, out: Path) -> float:
    started = time.perf_counter()
    trial = read_trial(path)
    baseline = read_trial(previous) if previous is not None else None
    write_report_pdf(build_report(trial, previous_trial=baseline), out)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=10)
    parser.add_argument("--repetitions", type=int, default=THESIS_SUBJECT.repetitions)
    args = parser.parse_args()
    parameters = THESIS_SUBJECT.replace(repetitions=args.repetitions)
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        files = []
        for i in range(args.trials + 1):
            path = root / f"trial{i:02d}.h5"
            save(simulate(parameters, patient=PATIENT_KINDS[i % len(PATIENT_KINDS)], seed=i),
                 path)
            files.append(path)
        first = one_report(files[0], None, root / "first.pdf")
        times = [one_report(path, files[i], root / f"report{i:02d}.pdf")
                 for i, path in enumerate(files[1:])]
        size_kb = np.mean([p.stat().st_size for p in root.glob("report*.pdf")]) / 1024
    a = np.asarray(times)
    print(f"report of a {parameters.duration_s * parameters.repetitions:g} s trial "
          f"({args.trials} trials, {size_kb:.0f} kB each)")
    print(f"  first in a fresh process  {first:6.2f} s (font cache)")
    print(f"  p50                       {np.percentile(a, 50):6.2f} s")
    print(f"  max                       {a.max():6.2f} s   goal < {GOAL_S:g} s: "
          f"{'met' if a.max() < GOAL_S else 'NOT met'}")


if __name__ == "__main__":
    main()
