"""Peak memory of a headless trial against its length.

    .venv/bin/python bench/memory.py [--durations 20 60 120] [--repetitions 5]

Each trial runs in a fresh process exactly as `rehab run --output FILE` does it
(app.trials.headless.simulate_to_file: the records go to the file block by block, the
reference is computed a block at a time, the metrics come from the channels they need,
read back a block at a time) and prints that process's peak
resident memory (VmHWM) after it, the simulated length, and the memory per simulated
second above a 4 s trial's. Figures only, no assertion. Goal (docs/performance.md):
≤ 300 MB whatever the length.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

CHILD = """
import sys
from pathlib import Path
from app.trials.headless import simulate_to_file
from core.trial import THESIS_SUBJECT
duration, repetitions, out = float(sys.argv[1]), int(sys.argv[2]), Path(sys.argv[3])
trial, analysis, problem = simulate_to_file(
    THESIS_SUBJECT.replace(duration_s=duration, repetitions=repetitions), out)
peak = next(int(line.split()[1]) for line in open("/proc/self/status")
            if line.startswith("VmHWM"))
print(trial.simulated_s, peak / 1024)
"""


def peak(duration_s: float, repetitions: int, folder: Path) -> tuple[float, float]:
    out = folder / f"trial_{duration_s:g}x{repetitions}.h5"
    done = subprocess.run([sys.executable, "-c", CHILD, str(duration_s), str(repetitions),
                           str(out)], check=True, capture_output=True, text=True)
    simulated, mb = done.stdout.split()
    out.unlink()
    return float(simulated), float(mb)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--durations", type=float, nargs="+", default=[4.0, 20.0, 60.0, 120.0])
    parser.add_argument("--repetitions", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        base = None
        print(f"{'trial':>12} {'simulated s':>12} {'peak MB':>9} {'MB per s above 4 s':>19}")
        for duration in args.durations:
            simulated, mb = peak(duration, args.repetitions, Path(folder))
            if base is None:
                base = (simulated, mb)
                slope = ""
            else:
                slope = f"{(mb - base[1]) / (simulated - base[0]):.3f}"
            print(f"{duration:>7g} s × {args.repetitions:<2d} {simulated:>10.1f} {mb:>9.0f} "
                  f"{slope:>19}")


if __name__ == "__main__":
    main()
