"""Does the progression between trials (app.trials.progression) bring a patient to the
difficulty it aims at? A course of headless trials in which each trial takes the
proposal made after the one before.

    .venv/bin/python bench/progression.py [--trials N] [--patients healthy,weak,...]
                                          [--assist as-needed|thesis]

For each virtual patient (default healthy, weak, tremor, wrong_way), `--trials` (default
15) trials of the thesis D in the `--assist` mode (default as-needed) on the realistic
plant, seed 0: per trial the share of the exercise the patient led (what the rule aims at
70 % of in the as-needed mode), the directional performance (% of the exercise inside the
cone, the thesis mode's aim), the robot's RMS torque over the exercise, and the assistance
level, time per traversal and tolerance that trial ran with. Figures only; no assertion.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from app.trials.analysis import analyse
from app.trials.headless import simulate
from app.trials.progression import TARGET_PCT, propose
from core.trial import THESIS_SUBJECT


def course(patient: str, trials: int, assist: str = "as-needed"):
    params = THESIS_SUBJECT.replace(assist=assist)
    rows = []
    proposal = None  # the proposal each trial ran with: it sets the next one's step
    for _ in range(trials):
        trial = simulate(params, patient=patient, seed=0)
        channels = {n: trial.records[n] for n in trial.records.dtype.names}
        metrics = analyse(channels, params).metrics.to_dict()
        torque = trial.records["torque_applied"][trial.records["phase"] == 2]
        rows.append((params, metrics["directional_performance_pct"], metrics["led_pct"],
                     trial.status, float(np.sqrt(np.mean(torque ** 2)))))
        proposal = propose(params, metrics, trial.status, proposal)
        params = proposal.applied_to(params)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=15)
    parser.add_argument("--patients", default="healthy,weak,tremor,wrong_way")
    parser.add_argument("--assist", choices=("as-needed", "thesis"), default="as-needed")
    args = parser.parse_args()
    aim = ("the share of the exercise the patient led" if args.assist == "as-needed"
           else "the time inside the cone")
    print(f"aim: about {TARGET_PCT:.0f} % success; in the {args.assist} mode {aim}")
    for patient in args.patients.split(","):
        rows = course(patient, args.trials, args.assist)
        print(f"\n{patient}")
        print(f"{'trial':>6}{'led %':>8}{'in cone %':>11}{'τ RMS N·m':>11}{'assist %':>10}"
              f"{'s/trav.':>9}{'tol °':>7}  status")
        for n, (p, pct, led, status, rms) in enumerate(rows, 1):
            print(f"{n:6d}{led:8.1f}{pct:11.1f}{rms:11.4f}{100 * p.assistance_level:10.0f}"
                  f"{p.duration_s:9.2f}"
                  f"{math.degrees(p.tolerance_rad):7.0f}  {status}")


if __name__ == "__main__":
    main()
