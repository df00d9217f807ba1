"""Time to run a three-block plan on the simulator through the live loop and recorder
(issue 30, figure for the note): the plan of tests/app/plans/test_live_plan.py (two laps of
a 2 s D, a 2 s circle, a 2 s reach out and back; 1 s rests) for each virtual patient,
run as `rehab plan run` runs it (app.plans.live), and where the time goes: the plan's
own exercise and rests against each round's Build (the simulator opened again for the
new exercise), approach, hold and finishing into the registry.

    .venv/bin/python bench/plan.py [--patients healthy weak passive] [--seed 3]

The loop process is started once (its start, kernels loaded, is timed apart).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--patients", nargs="+", default=["healthy", "weak", "passive"])
    parser.add_argument("--seed", type=int, default=3)
    args = parser.parse_args()

    from app.plans.dose import run_dose
    from app.plans.live import LivePlan
    from app.records.datadir import DataDir
    from app.records.registry import Registry
    from core.plan import Block, Plan
    from device.loop.client import DeviceClient
    from device.loop.messages import BackendConfig

    plan = Plan("Three short blocks", (
        Block(shape="d", repetitions=2, duration_s=2.0, rest_s=1.0, name="D"),
        Block(shape="circle", repetitions=1, duration_s=2.0, rest_s=1.0, name="Circle"),
        Block(shape="reach", repetitions=1, duration_s=2.0, rest_s=0.0, radius_m=0.06,
              name="Reach"),
    ))
    registry = Registry(DataDir(Path(tempfile.mkdtemp(prefix="bench-plan-")) / "data"))
    began = time.monotonic()
    with DeviceClient() as client:
        print(f"plan: {plan.planned_active_s():.0f} s of exercise and "
              f"{plan.planned_rest_s():.0f} s of rest in {len(plan.blocks)} blocks, "
              f"{plan.planned_movements()} movements")
        for kind in args.patients:
            code = registry.create_patient(kind, "Bench", body_mass_kg=91.0,
                                           upper_arm_m=0.3048, forearm_m=0.3048,
                                           side="right", shoulder_m=(-0.12, 0.73)).code
            stored = registry.save_plan(code, plan)
            live = LivePlan(registry, stored, client,
                            BackendConfig(patient=kind, seed=args.seed))
            phases: dict[str, float] = {}
            last = [time.monotonic(), "idle"]

            def watch(_live, state, phases=phases, last=last):
                now = time.monotonic()
                phases[last[1]] = phases.get(last[1], 0.0) + now - last[0]
                last[0], last[1] = now, state.phase

            result = live.run(watch)
            dose = run_dose(registry, result.run_id)
            spent = ", ".join(f"{name} {seconds:.1f} s" for name, seconds in phases.items()
                              if name not in ("idle", "ended"))
            print(f"{kind:8s} {result.outcome}: {result.elapsed_s:5.1f} s for "
                  f"{dose.movements} of {dose.planned_movements} movements, "
                  f"{dose.active_s:.1f} s of exercise, {dose.rest_s:.1f} s of rest "
                  f"({spent})")
    print(f"whole bench {time.monotonic() - began:.1f} s, the loop's start included")


if __name__ == "__main__":
    main()
