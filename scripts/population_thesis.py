"""The virtual healthy population on the thesis's experiment (section 3.6) against the
thesis's healthy subject, figure by figure. Prints a markdown table for docs/validation.md.

Run: .venv/bin/python scripts/population_thesis.py [--subjects 100] [--seed 0] [--workers 2]
"""

from __future__ import annotations

import argparse
import sys
import time

from app.population.thesis import against_thesis
from core.errors import ParameterError


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repetitions", type=int, default=5)
    args = parser.parse_args()
    start = time.perf_counter()
    try:
        rows, spreads = against_thesis(args.subjects, args.seed, workers=args.workers,
                                       repetitions=args.repetitions)
    except ParameterError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    wall = time.perf_counter() - start
    refused = [r for r in rows if r["refused"]]
    print(f"{args.subjects} virtual healthy subjects (seed {args.seed}), the thesis's D with "
          f"the thesis's settings, {args.repetitions} laps, right arm, realistic plant; "
          f"{len(refused)} refused (D out of reach); {wall:.0f} s on {args.workers} "
          f"workers.\n")
    print("| figure | role | thesis | min | 5 % | median | 95 % | max | thesis inside |")
    print("|---|---|---|---|---|---|---|---|---|")
    for s in spreads:
        f = s.figure
        cells = [s.low, s.percentile(5), s.percentile(50), s.percentile(95), s.high]
        print(f"| {f.label} ({f.unit}) | {f.role} | {f.thesis:.3g} | "
              + " | ".join(f"{v:.3g}" for v in cells)
              + f" | {'yes' if s.contains_thesis else 'no'} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
