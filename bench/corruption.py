"""Corrupted files, read by the console: tracebacks, hangs, silent loads (goal 0, 0, 0).

    .venv/bin/python bench/corruption.py [--files 1000] [--seed 1] [--timeout 20] [--keep DIR]

Makes one file of every type the console reads (tests/corruption.make_originals: a trial
with EMG, MVCs and a pose, an as-needed headless trial, its video and timestamps, a
learned and an approved EMG model signed by a key of the bench's own, a Trigno export, a
plain CSV, an MVC contraction, the settings, a registry), then at least `--files`
corrupted copies: bit flips (half of them in the first 4 KB, where HDF5 keeps its
metadata), set bytes, zeroed 4 KB blocks, truncations, and every named edit (h5py edits
of a trial with and without its seal made again, links, huge claimed sizes, edited and
rehashed models, CSV lines over 131 KB, NaN, time backwards, deep JSON…). Each is read
by every reader of its type in a worker process, killed after `--timeout` s.

Prints a table of outcomes per type (tests/corruption: refused, same, noted, silent,
unchecked, crash, hang) and every crash, hang, silent, noted and unchecked case, and every
refusal that does not name the file it refuses (each must: one line, the file, what). `unchecked`:
read with other values from a format that carries no checksum (a digit changed in a CSV,
a pixel in a video), which no reader can tell from what was written. Figures go in
docs/performance.md ("Corrupted files").
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests import corruption


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--files", type=int, default=1000, help="at least this many cases")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--timeout", type=float, default=20.0, help="s per file")
    parser.add_argument("--keep", type=Path, help="build in this folder and keep it")
    args = parser.parse_args()
    folder = args.keep or Path(tempfile.mkdtemp(prefix="rehab-corruption-"))
    folder.mkdir(parents=True, exist_ok=True)
    config = folder / "config"
    config.mkdir(mode=0o700, exist_ok=True)
    import os

    os.environ["REHAB_CONFIG_DIR"] = str(config)  # the models are signed with its key

    start = time.perf_counter()
    originals = corruption.make_originals(folder / "originals")
    made = time.perf_counter()
    n_originals = sum(len(v) for v in originals.values())
    named = len(corruption.make_cases(originals, folder / "probe", per_file=0, seed=0))
    per_file = max(1, -(-(args.files - named) // (n_originals + 2 * len(originals["trial"]))))
    cases = corruption.make_cases(originals, folder / "cases", per_file=per_file,
                                  seed=args.seed)
    print(f"{len(cases)} corrupted files of {n_originals} originals "
          f"(originals made in {made - start:.0f} s)", flush=True)

    def progress(done, total):
        if done % 100 == 0 or done == total:
            print(f"  {done}/{total} read ({corruption.elapsed(made)})", flush=True)

    results = corruption.run(cases, timeout_s=args.timeout,
                             env=corruption.environment(config), progress=progress)
    took = time.perf_counter() - made
    table = corruption.tally(results)
    width = max(len(k) for k in table)
    print(f"\n{'type':<{width}} " + " ".join(f"{o:>9}" for o in corruption.OUTCOMES))
    totals = dict.fromkeys(corruption.OUTCOMES, 0)
    for kind, row in table.items():
        print(f"{kind:<{width}} " + " ".join(f"{row[o]:>9}" for o in corruption.OUTCOMES))
        for o in corruption.OUTCOMES:
            totals[o] += row[o]
    print(f"{'all':<{width}} " + " ".join(f"{totals[o]:>9}" for o in corruption.OUTCOMES))
    unnamed = corruption.unnamed(results)
    print(f"\ntracebacks {totals['crash']}, hangs {totals['hang']}, silent loads "
          f"{totals['silent']} (goal 0, 0, 0); refusals not naming their file "
          f"{len(unnamed)} of {totals['refused']}; {len(results)} files in {took:.0f} s "
          f"({1e3 * took / len(results):.0f} ms a file)")
    for outcome in ("crash", "hang", "silent", "noted", "unchecked"):
        listed = [r for r in results if r.outcome == outcome]
        if listed:
            print(f"\n{outcome}:")
            for r in listed:
                print(f"  {r.case.kind}: {r.case.how}: {r.detail[:300]}")
    if unnamed:
        print("\nrefusals not naming their file:")
        for r in unnamed:
            print(f"  {r.case.kind}: {r.case.how}: {r.detail[:300]}")
    if args.keep is None:
        import shutil

        shutil.rmtree(folder, ignore_errors=True)
    return 1 if totals["crash"] or totals["hang"] or totals["silent"] or unnamed else 0


if __name__ == "__main__":
    sys.exit(main())
