"""What the assistance modes do in closed loop, and what the tick costs in each.

    .venv/bin/python bench/assistance.py [--ticks N] [--seed S]

1. The table of the assistance issue, redone: the thesis D (SMC, 5 × 4 s), every
   virtual patient × both assistance modes (thesis, as-needed) × both plants (ideal,
   realistic), one headless compiled trial each: the robot's torque RMS over the
   exercise, the robot's and the patient's net work (J), the robot's braking (its
   negative work), the net work of its help (the torque beyond what carried the robot's
   own dynamics, core.control.own), the help's share of the positive work of moving the
   handle (core.work.MechanicalWork), and the RMS position error
   in x and y (mm) against the reference the robot used.
2. The cost of one tick's `control` kernel compiled (rate estimate → reference →
   controller → assistance), timed around `TickPipeline.control` with
   `time.perf_counter_ns` along the D with a healthy patient's recorded sensor
   readings, for each mode: p50 / p99 / max in µs (goal: p99 ≤ 20 µs compiled).

Figures only; no assertion.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from app.trials.analysis import analyse
from app.trials.headless import simulate
from core.trial import THESIS_SUBJECT
from device.backend import SensorReading
from device.compiled.warmup import load_kernels
from device.loop.pipeline import TickPipeline, TrialPlan
from device.sim.patient_parameters import PATIENT_KINDS


def closed_loop(seed: int) -> None:
    print("thesis D, SMC, 5 × 4 s, seed", seed, "(work over the exercise phase)")
    print(f"{'patient':<10}{'mode':<11}{'plant':<10}{'τ RMS N·m':>10}{'W robot J':>10}"
          f"{'W patient J':>12}{'braking J':>10}{'W help J':>9}{'share %':>8}"
          f"{'RMSE x/y mm':>14}")
    for patient in PATIENT_KINDS:
        for mode in ("thesis", "as-needed"):
            for plant in ("ideal", "realistic"):
                params = THESIS_SUBJECT.replace(assist=mode)
                trial = simulate(params, patient=patient, seed=seed, plant=plant)
                channels = {n: trial.records[n] for n in trial.records.dtype.names}
                m = analyse(channels, params).metrics
                ex = channels["phase"] == 2
                rms = float(np.sqrt(np.mean(np.sum(channels["torque_applied"][ex] ** 2,
                                                   axis=1))))
                print(f"{patient:<10}{mode:<11}{plant:<10}{rms:10.4f}{m.robot_work_J:+10.2f}"
                      f"{m.patient_work_J:+12.2f}{m.robot_negative_work_J:+10.2f}"
                      f"{m.robot_help_work_J:+9.2f}{100 * m.robot_work_share:8.1f}"
                      f"{1000 * m.rmse_x_m:8.2f}/{1000 * m.rmse_y_m:.2f}"
                      + ("" if trial.status == "complete" else f"  ({trial.status})"))


def tick_cost(ticks: int, seed: int) -> None:
    load_kernels(("headless",))
    print(f"\ncompiled `control` kernel per tick ({ticks} ticks, healthy patient's readings)")
    print(f"{'mode':<11}{'p50 µs':>9}{'p99 µs':>9}{'max µs':>10}")
    for mode in ("thesis", "as-needed"):
        params = THESIS_SUBJECT.replace(assist=mode)
        recorded = simulate(params, patient="healthy", seed=seed).records
        readings = [SensorReading(float(r["time"]), float(r["robot_angle"][0]),
                                  float(r["robot_angle"][1]), float(r["force_sensor"][0]),
                                  float(r["force_sensor"][1]), float(r["force_sensor"][2]))
                    for r in recorded]
        plan = TrialPlan.build(params)
        pipeline = TickPipeline(plan, compiled=True)
        timer = time.perf_counter_ns
        costs = np.empty(ticks)
        n = len(readings)
        for k in range(ticks):
            if k % n == 0:
                pipeline.begin(readings[0].q1_rad, readings[0].q2_rad)
            reading = readings[k % n]
            start = timer()
            pipeline.control(k % n, reading)
            costs[k] = timer() - start
        us = costs[2000:] / 1e3
        p50, p99 = np.percentile(us, [50, 99])
        print(f"{mode:<11}{p50:9.2f}{p99:9.2f}{us.max():10.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=100_000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    closed_loop(args.seed)
    tick_cost(args.ticks, args.seed)


if __name__ == "__main__":
    main()
