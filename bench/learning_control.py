"""Learned inverse dynamics inside the computed-torque PID (eq. 4.8) on the simulator's
realistic plant (thesis chapter 4; the plant: device.sim.plant, the trials:
app.learning.closedloop).

    .venv/bin/python bench/learning_control.py [--epochs N] [--omega W ...]

1. Runs the training trials (six shapes, places and speeds, two repetitions each) on the
   unknown robot with the console's sliding-mode controller and a passive virtual
   patient, and turns them into (θ, θ̇, θ̈, τ) samples two ways: the robot alone (the
   applied torque with the hand's J_Rᵀ F added back, as section 4.4.1 asks of eq. 4.9),
   and robot and arm together (the applied torque as it is).
2. Trains a DeLaN, an FNN and a GRU on each (Adam, one validation split of 20 % of the
   trials, seeds fixed) and prints the training time.
3. Runs CT-PID on the held-out trials (a shape, places and speeds never trained on) in
   closed loop on the same plant with each model in place of M, C and f, and with: the
   nominal model, the nominal model with link masses and inertias +20 % and −20 %, the
   plant's own parameters (the best a model of the robot alone could do), and PID alone
   (M's diagonal at rest, no C, no f). Prints, for each outer-loop bandwidth ω (the
   console's 20 rad/s and softer ones), the mean over the held-out trials of the RMS
   tracking error in x and y (mm), the worst trial's larger one, and the RMS torque per
   joint (N·m). A faulted trial is counted and left out of the means.
4. Times the live loop's tick over one held-out trial: device.loop.engine.TickEngine.step
   as the loop process runs it on the compiled simulator, with the analytic CT-PID and
   with a DeLaN's and an FNN's, each compiled (the loop's default; a learned model through
   core.learning.kernel) and interpreted: p50 / p99 / max of the compute time from the
   sensor read to the torque written, against the 2 ms period.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from app.learning import closedloop as cl
from core.learning.tick import LearnedInverseDynamics
from core.learning.training import TrainingOptions, train
from core.robot import RobotModel
from device.compiled.warmup import load_kernels
from device.loop.engine import TickEngine
from device.loop.pipeline import TickPipeline, TrialPlan
from device.safety.supervisor import SafetySupervisor
from device.sim.patients import make_patient
from device.sim.simulator import SimulatorBackend

KINDS = ("delan", "fnn", "rnn")
TARGETS = {"robot": True, "robot+arm": False}  # name: the hand's J_Rᵀ F added back


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--epochs", type=int, default=60)
    parser.add_argument("--no-average-weights", action="store_true",
                        help="keep the last step's weights, not their average over an epoch")
    parser.add_argument("--batch-size", type=int, help="every model's (default: its own)")
    parser.add_argument("--omega", type=float, nargs="+", default=[20.0, 5.0],
                        help="outer-loop bandwidths, rad/s (default 20, the console's, and 5)")
    parser.add_argument("--acceleration", choices=("estimated", "desired"),
                        default="estimated",
                        help="the θ̈ learned from: the loop's estimate (default) or the "
                             "reference's, as the thesis trained (section 4.3)")
    args = parser.parse_args()
    nominal = RobotModel()
    plant = cl.unknown_plant(nominal)
    started = time.perf_counter()
    runs = cl.training_runs(plant, robot=nominal)
    samples = {target: cl.samples_of(runs, nominal, without_hand_force=without,
                                        acceleration=args.acceleration)
               for target, without in TARGETS.items()}
    print(f"training data: {len(cl.TRAINING_TRIALS)} trials, {len(samples['robot'][0]):,} "
          f"samples, θ̈ {args.acceleration}, simulated in {time.perf_counter() - started:.1f} s")
    models = {}
    print(f"{'model':<22}{'params':>7}{'train s':>9}{'val RMSE τ1, τ2 N·m':>22}")
    for target, data in samples.items():
        for kind in KINDS:
            options = TrainingOptions(kind=kind, epochs=args.epochs, folds=1, seed=0,
                                      mass_scale=0.5, batch_size=args.batch_size,
                                      average_weights=not args.no_average_weights)
            result = train(*data, options)
            name = f"{kind} ({target})"
            models[name] = LearnedInverseDynamics(result.spec, result.params, name)
            rmse = result.metrics["cross_validation_rmse"]
            print(f"{name:<22}{result.metrics['parameters']:>7}"
                  f"{result.metrics['training_seconds']:>9.1f}"
                  f"{rmse[0]:>11.3f}, {rmse[1]:.3f}")
    references = {
        "PID alone": cl.pid_alone(nominal),
        "CT-PID nominal": nominal,
        "CT-PID +20 % inertia": cl.inertia_scaled(nominal, 1.2),
        "CT-PID -20 % inertia": cl.inertia_scaled(nominal, 0.8),
        "CT-PID plant's own": plant.robot,
    }
    cases = {**references, **{f"CT-PID {n}": m for n, m in models.items()}}
    print(f"\nheld out: {', '.join(cl.describe(p) for p in cl.HELD_OUT_TRIALS)}")
    for omega in args.omega:
        gains = cl.soft_gains(omega)
        print(f"\nω = {omega:g} rad/s (K_p {gains.kp_1_s2[0]:g} 1/s², K_i {gains.ki_1_s3[0]:g}"
              f" 1/s³, K_d {gains.kd_1_s[0]:g} 1/s)")
        print(f"{'controller':<30}{'x mm':>7}{'y mm':>7}{'worst mm':>10}"
              f"{'τ1 RMS':>8}{'τ2 RMS':>8}{'faults':>8}")
        for name, model in cases.items():
            results = [cl.Tracking.of(cl.run_on_plant(p.replace(controller="ctpid"), plant,
                                                      cl.ctpid(model, gains, nominal),
                                                      robot=nominal))
                       for p in cl.HELD_OUT_TRIALS]
            done = [r for r in results if r.status == "complete"]
            faults = len(results) - len(done)
            if done:
                rmse = np.array([r.rmse_m for r in done]) * 1e3
                torque = np.array([r.torque_rms_Nm for r in done])
                x, y = rmse.mean(axis=0)
                t1, t2 = torque.mean(axis=0)
                print(f"{name:<30}{x:7.2f}{y:7.2f}{rmse.max():10.2f}{t1:8.3f}{t2:8.3f}"
                      f"{faults:8d}")
            else:
                print(f"{name:<30}{'-':>7}{'-':>7}{'-':>10}{'-':>8}{'-':>8}{faults:8d}")
    print("\nthe live loop's tick (TickEngine.step on the compiled simulator), µs")
    print(f"{'controller':<36}{'p50':>8}{'p99':>8}{'max':>9}{'of 2 ms (p99)':>15}")
    trial = cl.HELD_OUT_TRIALS[1].replace(controller="ctpid")
    load_kernels(("loop",))
    ticking = {"CT-PID nominal": nominal,
               **{f"CT-PID {n}": models[n] for n in ("delan (robot)", "fnn (robot+arm)")}}
    for name, model in ticking.items():
        for compiled in (True, False):
            controller = cl.ctpid(model, cl.soft_gains(20.0), nominal)
            us = tick_costs(trial, plant, controller, nominal, compiled) * 1e6
            p50, p99 = np.percentile(us, [50, 99])
            label = f"{name}, {'compiled' if compiled else 'interpreted'}"
            print(f"{label:<36}{p50:8.0f}{p99:8.0f}{us.max():9.0f}{p99 / 2000:14.0%}")
    print(f"\ntotal {time.perf_counter() - started:.0f} s")


def tick_costs(parameters, plant, controller, robot, compiled: bool) -> np.ndarray:
    """Compute time (s) of each tick of one trial as the loop process runs it, its pipeline
    compiled (the loop's default) or interpreted."""
    plan = TrialPlan.build(parameters, robot)
    patient = make_patient(cl.PATIENT, parameters.arm(), parameters.trajectory(), seed=0)
    backend = SimulatorBackend(patient, seed=0, plant=plant, compiled=True)
    pipeline = TickPipeline(plan, controller=controller, compiled=compiled)
    engine = TickEngine(backend, pipeline, SafetySupervisor(plan.robot))
    backend.open()
    reading = backend.read(0.0)
    pipeline.begin(reading.q1_rad, reading.q2_rad)
    total = pipeline.total_ticks
    backend.top_up_noise(total + 1)
    costs = np.empty(total)
    for k in range(total):
        costs[k] = engine.step(k, (k + 1) * plan.period_s, 0.0, 0.0, False, False).compute_s
    backend.close()
    return costs


if __name__ == "__main__":
    main()
