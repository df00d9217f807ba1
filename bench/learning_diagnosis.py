"""Section 4.4.1's diagnosis on simulated trials with a patient who pushes and the thesis's
assistance: does the recorded torque satisfy the Lagrangian structure of eq. 4.9, and what
does a model learn from it with and without the hand's J_Rᵀ F?

    .venv/bin/python bench/learning_diagnosis.py [--patient weak] [--epochs 60]

The unknown robot and the trials are app.learning.closedloop's (the realistic plant drawn
by seed 15; six training trials, three held out), run by the sliding-mode controller in the
thesis's assistance mode (Fig. 3.6: the torque reduced while the patient pushes along the
path) with a virtual patient who pushes (`--patient`, default weak).

1. **The structure.** Because the simulator knows the plant's own parameters, eq. 4.9 can
   be checked directly: the RMS of τ − τ_plant(θ, θ̇, θ̈), τ_plant the plant's own inverse
   dynamics (friction and stiffness included; drive gain applied), for the torque as
   recorded (the hand's force and the assistance in it) and with J_Rᵀ F added back, with
   the loop's estimated θ̈ and with the reference's θ̈_d (the thesis's input), each beside
   the torque's spread.
2. **What is learned.** An FNN and a DeLaN trained on each torque (estimated θ̈), their RMSE
   on the training trials' validation split and on the held-out trials, beside the spread.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from app.learning import closedloop as cl
from core.learning import inference
from core.learning.training import TrainingOptions, train
from core.robot import RobotModel


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--patient", default="weak", help="virtual patient (default weak)")
    parser.add_argument("--epochs", type=int, default=60)
    args = parser.parse_args()
    nominal = RobotModel()
    plant = cl.unknown_plant(nominal)
    started = time.perf_counter()
    sets = {name: cl.training_runs(plant, trials, robot=nominal, patient=args.patient)
            for name, trials in (("training", cl.TRAINING_TRIALS),
                                 ("held out", cl.HELD_OUT_TRIALS))}
    print(f"{args.patient} patient, thesis assistance, sliding-mode controller; "
          f"{len(cl.TRAINING_TRIALS)} training and {len(cl.HELD_OUT_TRIALS)} held-out trials "
          f"simulated in {time.perf_counter() - started:.1f} s")
    gain = np.asarray(plant.torque_gain)
    print("\n1. eq. 4.9 with the plant's own parameters: RMS residual τ − τ_plant (N·m, "
          "joint 1 / 2) against the torque's spread")
    print(f"{'torque':<26}{'θ̈':<11}{'residual':>16}{'spread':>16}")
    for without, label in ((False, "as recorded"), (True, "with J_Rᵀ F added back")):
        for acceleration in ("estimated", "desired"):
            q, qd, qdd, tau, _ = cl.samples_of(sets["training"], nominal,
                                               without_hand_force=without,
                                               acceleration=acceleration)
            # the drives apply gain × the command (device.sim.plant)
            plant_tau = np.stack(plant.robot.inverse_dynamics_terms(*q.T, *qd.T, *qdd.T),
                                 axis=-1) / gain
            residual = np.sqrt(np.mean((tau - plant_tau) ** 2, axis=0))
            spread = tau.std(axis=0)
            print(f"{label:<26}{acceleration:<11}{residual[0]:>8.3f} / {residual[1]:.3f}"
                  f"{spread[0]:>8.3f} / {spread[1]:.3f}")
            if without and acceleration == "estimated":
                # the loop's θ̈ estimate lags (a filtered difference): the residual against
                # the torque some ticks before (within each trial's samples)
                for lag in (4, 8, 12):
                    cycle = cl.samples_of(sets["training"], nominal, without_hand_force=True)[4]
                    same = cycle[lag:] == cycle[:-lag]
                    late = (tau[:-lag] - plant_tau[lag:])[same]
                    residual = np.sqrt(np.mean(late ** 2, axis=0))
                    print(f"{'  τ ' + str(lag) + ' ticks before θ̈':<37}{residual[0]:>8.3f} / "
                          f"{residual[1]:.3f}")
    print("\n2. models trained on each torque (estimated θ̈): RMSE (N·m, joint 1 / 2)")
    print(f"{'torque':<26}{'model':<7}{'validation':>16}{'held out':>16}{'spread':>16}")
    for without, label in ((False, "as recorded"), (True, "with J_Rᵀ F added back")):
        data = {k: cl.samples_of(runs, nominal, without_hand_force=without)
                for k, runs in sets.items()}
        q, qd, qdd, tau, _ = data["held out"]
        for kind in ("fnn", "delan"):
            result = train(*data["training"],
                           TrainingOptions(kind=kind, epochs=args.epochs, folds=1, seed=0,
                                           mass_scale=0.5))
            val = result.metrics["cross_validation_rmse"]
            held = np.sqrt(np.mean((inference.predict(result.spec, result.params, q, qd, qdd)
                                    - tau) ** 2, axis=0))
            spread = tau.std(axis=0)
            print(f"{label:<26}{kind:<7}{val[0]:>8.3f} / {val[1]:.3f}"
                  f"{held[0]:>8.3f} / {held[1]:.3f}{spread[0]:>8.3f} / {spread[1]:.3f}")
    print(f"\ntotal {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
