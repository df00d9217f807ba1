"""Time to run the whole assessment battery on the simulator headless (issue 31, figure for
the note): every task's trials (core.assessment.protocol) for each virtual patient, run as
`rehab assess run CODE --task all` runs them (app.assessments.runner.run_battery, into a
scratch folder), with the simulated time, the wall time and the speed per task, and the
task figures of each patient side by side, with their Z-scores and task scores against the
shipped simulated norms (resources/norms/simulated.json) when they exist.

    .venv/bin/python bench/assessment.py [--patients healthy weak passive] [--seed 3]

The first task of the first patient includes loading the compiled kernels (and compiling
them when the cache is cold: printed apart).
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--patients", nargs="+", default=["healthy", "weak", "passive"])
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--age", type=float, default=60.0,
                        help="the age the Z-scores are for (default 60)")
    args = parser.parse_args()

    from app.assessments.runner import run_battery
    from core.assessment import TASKS, task_figures
    from device.compiled.warmup import load_kernels

    started = time.perf_counter()
    load_kernels(("headless",))
    print(f"kernels loaded in {time.perf_counter() - started:.1f} s")
    figures: dict[str, dict[str, float]] = {}
    for kind in args.patients:
        folder = Path(tempfile.mkdtemp(prefix=f"bench-assessment-{kind}-"))
        began = time.perf_counter()
        runs = run_battery(kind, seed=args.seed, folder=folder)
        wall = time.perf_counter() - began
        simulated = sum(t.simulated_s for trials in runs.values() for t in trials)
        print(f"{kind}: the battery ({sum(len(t) for t in runs.values())} trials) "
              f"{simulated:.0f} s simulated in {wall:.1f} s ({simulated / wall:.0f}× real time)")
        for task, trials in runs.items():
            sim = sum(t.simulated_s for t in trials)
            took = sum(t.elapsed_s for t in trials)
            status = ", ".join(sorted({t.status for t in trials}))
            print(f"  {task:9s} {len(trials)} trial(s) {sim:6.1f} s simulated in {took:5.2f} s "
                  f"({sim / took:5.0f}×), {status}")
            for trial in trials:
                figures.setdefault(kind, {}).update(trial.figures)
    norms, person = _norms(args.age)
    if norms is not None:
        print(f"\nZ-scores: {norms.label}; a {args.age:g}-year-old right-handed woman, right "
              "arm, simulator-realistic")
    print("\nfigure" + "".join(f"{k:>12s}" for k in args.patients)
          + ("".join(f"{'Z ' + k:>14s}" for k in args.patients) if norms else ""))
    for task in TASKS:
        for spec in task_figures(task):
            values = [figures.get(k, {}).get(spec.key) for k in args.patients]
            if all(v is None for v in values):
                continue
            cells = "".join(f"{'—' if v is None or not math.isfinite(v) else f'{v:.4g}':>12s}"
                            for v in values)
            if norms is not None:
                cells += "".join(f"{_z(norms, spec.key, v, person):>14s}" for v in values)
            print(f"{spec.key:36s}{cells}")
        if norms is not None:
            scores = [_score(norms, task, figures.get(k, {}), person) for k in args.patients]
            print(f"{'task score ' + task:36s}{'':>{12 * len(args.patients)}s}"
                  + "".join(f"{s:>14s}" for s in scores))


def _norms(age: float):
    """The shipped simulated norms (app.norms.in_use.SHIPPED) and the bench's person, or
    (None, None) when they are not there."""
    from app.norms import Covariates, load_norms
    from app.norms.in_use import SHIPPED

    if not SHIPPED.is_file():
        return None, None
    return load_norms(SHIPPED), Covariates(age, "female", "right", "right",
                                           "simulator-realistic")


def _z(norms, key: str, value, person) -> str:
    from app.norms import NormsError

    if value is None or key not in norms.figures:
        return "—"
    try:
        return f"{norms.z(key, value, person).z:+.2f}"
    except NormsError:
        return "n/a"


def _score(norms, task: str, metrics: dict, person) -> str:
    from app.norms import NormsError, TaskNotPerformed

    try:
        return f"{norms.task_score(task, metrics, person).score:.2f}"
    except TaskNotPerformed:
        return "not done"
    except NormsError:
        return "n/a"


if __name__ == "__main__":
    main()
