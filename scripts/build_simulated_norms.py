"""Build the simulated normative model: the virtual healthy population through the
assessment battery, fitted by the norms' fitter, MDC95 from a retest session, labelled
simulated (app.population.norms).

Run: .venv/bin/python scripts/build_simulated_norms.py [--subjects 500] [--seed 0]
     [--workers 2] [--tasks reaching circle range strength position] [--no-retest]
     [--output resources/norms/simulated.json] [--overwrite]
     [--save-rows ROWS.json | --from-rows ROWS.json]

--save-rows keeps every visit's figures; --from-rows refits from them without running the
population again (seconds: for a change to the fitter, not to the simulation).

Prints the time it took, what the fit left out, the cross-validated calibration, the
MDC95s and who each MDC95 left out (and why). The same seed and size give the same model
(only its created_utc differs).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time
from pathlib import Path

from app.norms import NormsError, write_norms
from app.norms.fitting import calibration_lines
from app.norms.in_use import SHIPPED
from app.norms.modelfile import NormsFileError
from app.population.norms import build_simulated_norms, fit_simulated_norms
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
    rows_file = parser.add_mutually_exclusive_group()
    rows_file.add_argument("--save-rows", type=Path, help="write every visit's figures here")
    rows_file.add_argument("--from-rows", type=Path, help="refit from rows --save-rows wrote")
    args = parser.parse_args()
    start = time.perf_counter()
    try:
        if args.from_rows is not None:
            built = fit_simulated_norms(_read_rows(args.from_rows), args.subjects, args.seed,
                                        tasks=args.tasks, retest=not args.no_retest)
        else:
            built = build_simulated_norms(args.subjects, args.seed, workers=args.workers,
                                          tasks=args.tasks, retest=not args.no_retest)
        if args.save_rows is not None:
            _write_rows(args.save_rows, built.rows)
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
    for key, why in built.left_out_mdc.items():
        print(f"MDC95 of {key}: {why}")
    for key, why in built.skipped_mdc.items():
        print(f"no MDC95 for {key}: {why}")
    return 0


def _read_rows(path: Path) -> list[dict]:
    try:
        rows = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        raise NormsError(f"{path}: cannot read the rows ({error}); write them with "
                         "--save-rows") from None
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise NormsError(f"{path}: not the rows --save-rows writes (a list of objects)")
    return rows


def _write_rows(path: Path, rows: list[dict]) -> None:
    """Written whole or not at all (a temporary file renamed over the target)."""
    temporary = path.with_name(path.name + ".part")
    temporary.write_text(json.dumps(rows), encoding="utf-8")
    os.replace(temporary, path)


if __name__ == "__main__":
    sys.exit(main())
