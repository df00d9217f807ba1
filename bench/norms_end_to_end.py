"""Norms end to end on the simulator: virtual healthy controls run a task of the battery,
registered as a clinic would; `rehab norms fit --trials` fits norms from their trial files
and the registry; the virtual healthy, weak and passive patients' trials are scored with
`rehab norms score`.

    .venv/bin/python bench/norms_end_to_end.py [--controls 24] [--task circle] [--seed 7]

Controls: device.sim.population.draw_population(N, seed), each tested on their dominant
arm or, every other one, the other (so that handedness and the tested side are not one
covariate). Prints the time of each stage, the calibration, and each patient's task score
and figures' worse-Z. Figures only; no assertion.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import tempfile
import time
from pathlib import Path

from app.assessments.runner import run_task
from app.cli.main import main as rehab
from app.records.datadir import DataDir
from app.records.registry import Registry
from device.sim.population import draw_population


def quiet(args: list[str]) -> tuple[int, str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = rehab(args)
    return code, out.getvalue()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--controls", type=int, default=24)
    parser.add_argument("--task", default="circle")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="norms-e2e-"))
    data = folder / "data"
    registry = Registry(DataDir(data), create=True)
    start = time.perf_counter()
    for i, s in enumerate(draw_population(args.controls, args.seed)):
        other = "left" if s.handedness == "right" else "right"
        side = s.handedness if i % 2 == 0 else other
        p = registry.create_patient(s.code, "Control", birth_year=s.birth_year, side=side,
                                    sex=s.sex, handedness=s.handedness,
                                    body_mass_kg=s.body_mass_kg, upper_arm_m=s.upper_arm_m,
                                    forearm_m=s.forearm_m)
        run_task(args.task, "healthy", None, s.trial_seed(0) % 2**31, registry=registry,
                 code=p.code, patient_options=s.patient_options(0, side, guided=False))
    controls_s = time.perf_counter() - start
    norms = folder / "norms.json"
    start = time.perf_counter()
    code, out = quiet(["norms", "fit", "--data-dir", str(data), "--trials",
                       str(data / "trials"), "--source", f"{args.controls} virtual controls "
                       f"(population seed {args.seed}), bench", "--simulated", "--output",
                       str(norms)])
    fit_s = time.perf_counter() - start
    print(f"{args.controls} virtual controls, task {args.task}: run {controls_s:.1f} s; "
          f"fit {fit_s:.1f} s (exit {code})")
    print(out.rstrip())
    if code != 0:
        return
    for kind in ("healthy", "weak", "passive"):
        p = registry.create_patient(kind, "Patient", birth_year=1960, side="right", sex="male",
                                    handedness="right")
        trials = run_task(args.task, kind, None, 3, registry=registry, code=p.code)
        code, out = quiet(["norms", "score", "--data-dir", str(data), "--norms", str(norms),
                           "--json", str(trials[0].path)])
        if code != 0:
            print(f"{kind}: not scored (exit {code})")
            continue
        result = json.loads(out)
        task = result["task_score"]
        worst = sorted(result["figures"].items(), key=lambda kv: -kv[1]["worse_z"])[:3]
        print(f"{kind:<8} task score "
              + (f"{task['score']:.2f} (Z-Task {task['z_task']:.2f})" if task else
                 f"none ({result['why_no_task_score']})")
              + "; worst figures: " + ", ".join(f"{k} {v['worse_z']:.1f}" for k, v in worst))


if __name__ == "__main__":
    main()
