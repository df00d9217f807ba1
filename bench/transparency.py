"""How much of the robot the patient feels: the transparent mode against the as-needed mode
at level 0 and against the robot with its motors off.

    .venv/bin/python bench/transparency.py [--plant realistic] [--robot-seed 0] [--seed 0]
                                           [--gains "transparent.inertia=0.9"]

A virtual patient moves the handle round a circle of 8 cm at 0.1 to 0.5 m/s (device.sim.
mover: a firm healthy arm with no push along the path, the robot moving none of it); the
handle's force sensor says what the hand felt over the laps after the first: RMS and peak
magnitude (N), and the speed the handle kept round the circle (m/s); below the table, how
much the transparent mode's torque changes from tick to tick (its chatter: a compensation
that amplified the encoders' noise, or went unstable, would show there). One headless compiled
trial of three laps per speed and column, on the realistic plant by default (the robot's
own masses, friction, stiffness and drive gains drawn around the model: device.sim.plant):

* transparent: the transparent mode with its default shares (core.control.transparent);
* as-needed 0: the as-needed mode at level 0 (its channel, stiffness and 0.8 of the
  friction compensated, no help along the path: core.control.guidance);
* motors off: the transparent mode with every share 0, which commands exactly 0 N·m in
  the exercise (checked below the table from the records): the floor to beat.

The approach to the circle's start runs the controller in every column, as in a trial;
only the exercise is measured. Figures only; no assertion.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from app.trials.headless import simulate
from core.control.gains import built
from core.trial import THESIS_SUBJECT
from device.sim.mover import MOVER, MOVER_OPTIONS, circle_at_speed, felt_force

SPEEDS_M_S = (0.1, 0.2, 0.3, 0.4, 0.5)
MOTORS_OFF = "transparent.inertia=0; transparent.friction=0; transparent.stiffness=0"
COLUMNS = (
    ("transparent", THESIS_SUBJECT.replace(assist="transparent")),
    ("as-needed 0", THESIS_SUBJECT.replace(assist="as-needed", assistance_level=0.0)),
    ("motors off", THESIS_SUBJECT.replace(assist="transparent", gains=MOTORS_OFF)),
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plant", choices=("realistic", "ideal"), default="realistic")
    parser.add_argument("--robot-seed", type=int, default=0,
                        help="the simulated robot of a realistic plant (default 0, the "
                             "console's)")
    parser.add_argument("--seed", type=int, default=0, help="the trial's seed (sensor noise)")
    parser.add_argument("--gains", default="",
                        help="the transparent column's gains line, e.g. "
                             "\"transparent.inertia=0.9\" (default: its defaults)")
    args = parser.parse_args()
    columns = ((COLUMNS[0][0], COLUMNS[0][1].replace(gains=args.gains)), *COLUMNS[1:])
    shares = built("transparent", columns[0][1].gains)
    started = time.perf_counter()
    print(f"felt force, RMS / peak N (speed kept, m/s); {args.plant} plant, robot seed "
          f"{args.robot_seed}, seed {args.seed}; circle r = 8 cm, laps 2-3 of 3")
    print(f"transparent shares: {shares}")
    print(f"{'speed m/s':<10}" + "".join(f"{name:>24}" for name, _ in columns))
    motors_off_torque = 0.0
    chatter = []
    for speed in SPEEDS_M_S:
        cells = []
        for name, base in columns:
            params = circle_at_speed(base, speed)
            trial = simulate(params, patient=MOVER, seed=args.seed, plant=args.plant,
                             robot_seed=args.robot_seed, patient_options=MOVER_OPTIONS)
            felt = felt_force(trial.records, params)
            cell = f"{felt.rms_N:.2f} / {felt.peak_N:.2f} ({felt.speed_m_s:.2f})"
            if trial.status != "complete":
                cell += f" {trial.status}"
            cells.append(cell)
            if name == "transparent":
                torque = trial.records["torque_applied"][trial.records["phase"] == 2]
                chatter.append(100.0 * float(np.sqrt(np.mean(np.diff(torque, axis=0) ** 2))
                                             / np.sqrt(np.mean(torque ** 2))))
            if name == "motors off":
                exercise = trial.records["phase"] == 2
                motors_off_torque = max(motors_off_torque, float(
                    np.abs(trial.records["torque_applied"][exercise]).max()))
        print(f"{speed:<10.1f}" + "".join(f"{cell:>24}" for cell in cells))
    print("transparent: the torque's RMS change per tick, % of its RMS (chatter), by speed: "
          + ", ".join(f"{c:.1f}" for c in chatter))
    print(f"motors off: largest torque applied in the exercise {motors_off_torque:g} N·m")
    print(f"{len(SPEEDS_M_S) * len(COLUMNS)} trials in {time.perf_counter() - started:.1f} s")


if __name__ == "__main__":
    main()
