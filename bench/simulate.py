"""Headless simulation speed and controller tick cost.

    .venv/bin/python bench/simulate.py [--repetitions N]

Prints, for every virtual patient, the speed of a whole headless trial (the thesis's
D under SMC: simulator, rate estimate, controller, assistance, supervisor, subject
model and record, exactly as `rehab run` does it) as a multiple of real time, with
the compiled engine (the default) and the Python reference engine; then what the
compiled engine's first trial in a fresh process costs (loading the compiled
kernels from the cache, or compiling them when the cache is empty), the simulator's
own read+write cost per tick in Python, and the controller tick cost p99 with the
assistance on (from bench/controllers.py). Figures only, no assertion.
Goals (docs/performance.md): ≥ 500× real time; controller tick p99 ≤ 50 µs with the assistance.
"""

from __future__ import annotations

import argparse
import gc
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from controllers import inputs, run

from app.trials.headless import simulate
from core.control import PerformanceAssistance, make_controller
from core.robot import RobotModel
from core.trial import THESIS_SUBJECT, TrialParameters
from device.sim.patient_parameters import PATIENT_KINDS
from device.sim.simulator import INTEGRATORS, SimulatorBackend


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repetitions", type=int, default=5)
    args = parser.parse_args()
    params = THESIS_SUBJECT.replace(repetitions=args.repetitions)

    print(f"Whole headless trial: thesis D, {args.repetitions} × 4 s, SMC, assistance on "
          "(best of 3)")
    print(f"{'patient':<11}{'engine':<10}{'simulated s':>12}{'wall s':>9}{'× real time':>13}"
          f"{'µs/tick':>9}")
    simulate(params.replace(repetitions=1))  # load the compiled kernels (reported below)
    gc.collect()
    for kind in PATIENT_KINDS:
        for engine in ("compiled", "python"):
            best = None
            for _ in range(3):
                trial = simulate(params, patient=kind, engine=engine)
                if best is None or trial.elapsed_s < best.elapsed_s:
                    best = trial
            ticks = len(best.records)
            print(f"{kind:<11}{engine:<10}{best.simulated_s:12.1f}{best.elapsed_s:9.3f}"
                  f"{best.speed_vs_real_time:13.0f}{1e6 * best.elapsed_s / ticks:9.1f}")

    print("\nFirst compiled trial in a fresh process (healthy), from the kernel cache")
    code = ("import time; t = time.perf_counter(); from app.trials.headless import simulate; "
            "from core.trial import THESIS_SUBJECT as T; i = time.perf_counter(); "
            f"r = simulate(T.replace(repetitions={args.repetitions})); "
            "print(f'{i - t:.2f} {r.load_s:.2f} {r.elapsed_s:.3f} {r.speed_vs_real_time:.0f}')")
    root = Path(__file__).resolve().parents[1]
    line = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True,
                          text=True, check=True).stdout.split()
    print(f"import {line[0]} s, loading the kernels {line[1]} s, then the trial {line[2]} s "
          f"({line[3]}× real time)")

    print("\nSimulator alone (read + write per 2 ms tick, best of 3)")
    for (kind, integrator), us in bench_tick(kinds=("healthy", "passive")).items():
        print(f"{kind:<11}{integrator:<22}{us:6.1f} µs   {2000.0 / us:5.0f}× real time")

    robot = RobotModel()
    rows = inputs(robot)
    print("\nController tick (µs), 60 000 ticks along the D")
    print(f"{'controller':<22}{'p50':>7}{'p99':>7}{'max':>9}")
    for name in ("smc", "ctpid"):
        for assisted in (False, True):
            controller = make_controller(name, robot)
            assistance = PerformanceAssistance(robot) if assisted else None
            samples_ns, _ = run(controller, assistance, 60_000, rows)
            samples = samples_ns / 1000.0
            label = name + (" + assistance" if assisted else "")
            print(f"{label:<22}{np.percentile(samples, 50):7.2f}"
                  f"{np.percentile(samples, 99):7.2f}{samples.max():9.1f}")
    print("\nGoals: headless ≥ 500× real time; controller + assistance p99 ≤ 50 µs")


def bench_tick(
    kinds=("passive", "healthy", "weak", "spastic", "tremor", "wrong_way"),
    *,
    seconds: float = 4.0,
    integrators=INTEGRATORS,
    trial: TrialParameters = THESIS_SUBJECT,
    repeats: int = 3,
) -> dict[tuple[str, str], float]:
    """Wall-clock µs of one headless tick of the simulator alone (read at k·2 ms,
    then write), per (patient kind, integrator): the best of `repeats` runs.

    A first run with a joint PD on the path records the torques; the timed runs
    replay them, so the motion is a trial's and no controller is on the clock.
    """
    ticks = round(seconds / 0.002)
    robot = RobotModel()
    q_ref, qd_ref, _ = trial.trajectory().joint_reference(robot, np.arange(ticks) * 0.002)
    results = {}
    for integrator in integrators:
        for kind in kinds:
            sim = SimulatorBackend.from_trial(trial, kind, robot=robot, integrator=integrator)
            sim.open()
            torques = []
            for k in range(ticks):
                sim.read(k * 0.002)
                tr = sim.truth
                torques.append((
                    30.0 * (q_ref[k, 0] - tr.q1_rad) + (qd_ref[k, 0] - tr.q1_rate_rad_s),
                    30.0 * (q_ref[k, 1] - tr.q2_rad) + (qd_ref[k, 1] - tr.q2_rate_rad_s),
                ))
                sim.write(*torques[-1])
            times = [k * 0.002 for k in range(ticks)]
            best = math.inf
            for _ in range(repeats):
                sim.open()
                read, write = sim.read, sim.write
                start = time.perf_counter()
                for now, (tau1, tau2) in zip(times, torques, strict=True):
                    read(now)
                    write(tau1, tau2)
                best = min(best, time.perf_counter() - start)
            results[(kind, integrator)] = best / ticks * 1e6
    return results


if __name__ == "__main__":
    main()
