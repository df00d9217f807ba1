"""Build the simulated normative model: the virtual healthy population through the
assessment battery, fitted by the norms' fitter, MDC95 from a retest session, labelled
simulated (app.population.norms).

Run: .venv/bin/python scripts/build_simulated_norms.py [--subjects 500] [--seed 0]
     [--workers 2] [--tasks reaching circle range strength position] [--no-retest]
     [--output resources/norms/simulated.json] [--overwrite]

Prints the time it took, what the fit left out, the cross-validated calibration and the
MDC95s. The same seed and size give the same model (only its created_utc differs).
"""

from __future__ import annotations

import argparse
import resource
import sys
import time

from app.norms import NormsError, write_norms
from app.norms.fitting import calibration_lines
from app.norms.in_use import SHIPPED
from app.norms.modelfile import NormsFileError
from app.population.norms import build_simulated_norms
from core.assessment import TASKS
from core.errors import ParameterError


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=500)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--tasks", nargs="+", default=list(TASKS), choices=TASKS)
    parser.add_argument("--no-retest", action="store_true", help="no MDC95 (half the time)")
    parser.add_argument("--output", default=str(SHIPPED))
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args()
    start = time.perf_counter()
    try:
        built = build_simulated_norms(args.subjects, args.seed, workers=args.workers,
                                      tasks=args.tasks, retest=not args.no_retest)
        path = write_norms(args.output, built.document, overwrite=args.overwrite)
    except (ParameterError, NormsError, NormsFileError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    wall = time.perf_counter() - start
    usage = [resource.getrusage(who) for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)]
    cpu = sum(u.ru_utime + u.ru_stime for u in usage)
    visits = len(built.rows)
    refused = [r for r in built.rows if r["refused"]]
    print(f"{args.subjects} subjects × {visits // args.subjects} sessions, tasks "
          f"{', '.join(args.tasks)}: {wall:.0f} s on {args.workers} workers "
          f"({wall / visits:.2f} s a visit), {cpu:.0f} s of CPU in all "
          f"({cpu / visits:.2f} s a visit); {len(refused)} visits refused")
    for r in refused[:5]:
        print(f"  refused: subject {r['subject']} session {r['session']}: {r['refused']}")
    print(f"wrote {path}")
    print("left out: " + ("; ".join(f"{k}: {v}" for k, v in built.fit.left_out.items())
                          or "nothing"))
    for line in calibration_lines(built.document["calibration"]["held_out"]):
        print(line)
    mdc = {k: v.get("mdc95") for k, v in built.document["figures"].items()}
    print("MDC95: " + ", ".join(f"{k} {v:.3g}" for k, v in mdc.items() if v is not None))
    return 0


if __name__ == "__main__":
    sys.exit(main())
