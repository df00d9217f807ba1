"""What verifying a trial file costs: the checks before h5py reads a value and the seal.

    .venv/bin/python bench/verify.py [--seconds 60 600] [--repeat 5]

For a headless trial of each length (the thesis's D, weak patient, as `rehab run` writes
it), the median of `--repeat` runs of: the global-heap scan (device.recording.trialfile.
verify.check_heaps: the whole file through mmap), the structure walk (`inventory`: every
link, layout, filter and size), the seal's digests of every part read back from the file
(what a reader does, `Seal.check` on each), and `read_trial` whole (which includes all
three, its samples hashed as it reads them) and with `channels=()` (tick and time only, as
the metrics' and EMG's readers do). Also the writer's side: the running digest of the
samples as they are appended (SHA-256 per batch) and the seal at close. Figures for
docs/performance.md ("Verifying a trial file").
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np


def median_ms(run, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, nargs="+", default=[60.0, 600.0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()

    from app.trials.headless import save, simulate
    from app.trials.reader import read_trial
    from core.trial import THESIS_SUBJECT
    from device.recording.trialfile import seal
    from device.recording.trialfile.verify import check_heaps, inventory

    folder = Path(tempfile.mkdtemp(prefix="rehab-verify-"))
    print(f"{'trial':>8} {'file':>9} {'heaps':>8} {'walk':>8} {'digests':>9} "
          f"{'read_trial':>11} {'tick+time':>10} {'sha256':>9}")
    for seconds in args.seconds:
        reps = max(1, round(seconds / THESIS_SUBJECT.duration_s))
        params = THESIS_SUBJECT.replace(repetitions=reps)
        path = folder / f"t{seconds:.0f}.h5"
        save(simulate(params, patient="weak", seed=1), path)
        size = path.stat().st_size

        def digests(path=path):
            with h5py.File(path, "r", locking=False) as f:
                found = inventory(f)
                parts = seal.Seal.read(f)
                for part in sorted(found.paths):
                    parts.check(part, found)

        def walk(path=path):
            with h5py.File(path, "r", locking=False) as f:
                inventory(f)

        heaps = median_ms(lambda path=path: check_heaps(path), args.repeat)
        walked = median_ms(walk, args.repeat)
        hashed = median_ms(digests, args.repeat)
        whole = median_ms(lambda path=path: read_trial(path), args.repeat)
        few = median_ms(lambda path=path: read_trial(path, channels=()), args.repeat)
        data = path.read_bytes()
        sha = median_ms(lambda data=data: seal.content_digest([np.frombuffer(data, np.uint8)]),
                        args.repeat)
        n = read_trial(path, channels=()).n_samples
        print(f"{n * 0.002:>7.0f}s {size / 2**20:>7.1f}MB {heaps:>6.1f}ms {walked:>6.1f}ms "
              f"{hashed:>7.1f}ms {whole:>9.1f}ms {few:>8.1f}ms {sha:>7.1f}ms")
    print("sha256: hashing the file's bytes once, for scale")


if __name__ == "__main__":
    main()
