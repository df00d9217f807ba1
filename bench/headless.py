"""A headless trial's speed on the realistic plant, and where its time goes.

    .venv/bin/python bench/headless.py [--repetitions 5] [--runs 5] [--patients healthy passive]

For each virtual patient: the thesis's D under SMC with the assistance on (THESIS_SUBJECT,
`--repetitions` laps), run by app.trials.headless.simulate on the realistic plant, compiled;
best of `--runs`. Prints the run's speed as a multiple of real time by the wall clock
(`SimulatedTrial.elapsed_s`, what bench/simulate.py and the goal use) and by this process's
CPU time over the same call (process_time: on a machine shared with other work the wall
clock counts the time other processes had the CPU, the CPU time does not), then the same
for the setup a population's trial pays besides the run (building the trial plan, the
patient and the simulator) and for the metrics afterwards. Figures only, no assertion.
Goal (docs/performance.md): the run at >= 1,000x real time on the realistic plant.
"""

from __future__ import annotations

import argparse
import os
import time

from app.trials.analysis import analyse
from app.trials.headless import simulate
from core.trial import THESIS_SUBJECT


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repetitions", type=int, default=5)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--patients", nargs="+", default=["healthy", "passive"])
    args = parser.parse_args()
    params = THESIS_SUBJECT.replace(repetitions=args.repetitions)
    simulate(params.replace(repetitions=1))  # load the compiled kernels first
    print(f"thesis D, {args.repetitions} × 4 s, SMC + assistance, realistic plant, compiled; "
          f"best of {args.runs}; load average {os.getloadavg()[0]:.1f} on "
          f"{os.cpu_count()} CPUs")
    print(f"{'patient':<10}{'simulated s':>12}{'run wall s':>11}{'× real (wall)':>15}"
          f"{'run CPU s':>11}{'× real (CPU)':>14}{'setup CPU s':>13}{'metrics CPU s':>15}")
    for kind in args.patients:
        best = None
        for _ in range(args.runs):
            c0 = time.process_time()
            trial = simulate(params, patient=kind)
            c1 = time.process_time()
            channels = {n: trial.records[n] for n in trial.records.dtype.names}
            analyse(channels, params)
            c2 = time.process_time()
            # the run's CPU time: the call's, less what it spent before the run started
            # (measured apart below)
            row = (trial.elapsed_s, c1 - c0, c2 - c1, trial.simulated_s)
            if best is None or row[1] < best[1]:
                best = row
        setup = min(_setup_cpu(params, kind) for _ in range(args.runs))
        wall, call_cpu, metrics_cpu, simulated = best
        run_cpu = max(call_cpu - setup, 1e-9)
        print(f"{kind:<10}{simulated:12.1f}{wall:11.3f}{simulated / wall:15.0f}"
              f"{run_cpu:11.3f}{simulated / run_cpu:14.0f}{setup:13.3f}{metrics_cpu:15.3f}")


def _setup_cpu(params, kind: str) -> float:
    """CPU time of what `simulate` does before its run: the plan, the patient, the
    simulator and the pipeline (the same calls, without run_trial)."""
    from device.loop.pipeline import TickPipeline, TrialPlan
    from device.sim.simulator import SimulatorBackend

    c0 = time.process_time()
    plan = TrialPlan.build(params)
    SimulatorBackend.from_trial(params, kind, seed=0, robot=plan.robot, compiled=True,
                                plant="realistic")
    TickPipeline(plan, compiled=True)
    return time.process_time() - c0


if __name__ == "__main__":
    main()
