"""The games' staircase in closed loop: virtual patients of three abilities play rounds on the
headless simulator, the staircase setting each round's difficulty from the last.

    .venv/bin/python bench/staircase.py [--rounds N] [--seed S] [--game reach|path|both]

For each game and each virtual patient (healthy: effort 1; weak: effort 0.4; passive: the
robot's help alone, device.sim.patients) it prints the rounds the staircase took to reach the
rung it settled at (the median rung of the run's second half), the success over every movement
from then on, the movements counted, the final rung with its values, and the run's time. The
reaching game is 8 targets in 12 s in the as-needed mode (help, time allowed, target size on
its ladder); the path game two laps of the D in 6 s each, in the as-needed and the transparent
modes (channel width and pace on its ladder; help too in as-needed).

Figures only; tests/app/games/test_staircase_loop.py holds the claim (±7 points of 70 %).
"""

from __future__ import annotations

import argparse
import time

from app.games.figures import staircase_text
from app.games.virtual import convergence, play_rounds
from core.games.staircase import TARGET_SUCCESS
from core.trial import TrialParameters

REACH = TrialParameters(game="reach", shape="targets", n_targets=8, duration_s=12.0,
                        repetitions=1, assist="as-needed", timing="minimum_jerk",
                        centre_m=(-0.3, 0.35), radius_m=0.08)
PATH = TrialParameters(game="path", shape="d", duration_s=6.0, repetitions=2,
                       timing="minimum_jerk")
PATIENTS = ("healthy", "weak", "passive")


def run(name: str, base: TrialParameters, rounds: int, seed: int) -> None:
    print(f"\n{name}: {rounds} rounds a patient, seeds {seed}…{seed + rounds - 1}, "
          f"target {100 * TARGET_SUCCESS:.0f} %")
    print(f"{'patient':<9}{'converged by':>13}{'settled rung':>13}{'success after':>14}"
          f"{'movements':>10}{'final rung':>11}{'s':>6}")
    for patient in PATIENTS:
        started = time.perf_counter()
        played = play_rounds(base, patient, rounds, seed=seed)
        c = convergence(played)
        elapsed = time.perf_counter() - started
        print(f"{patient:<9}{'round ' + str(c.rounds_to_converge):>13}{c.settled_rung:>13g}"
              f"{100 * c.success_after:>13.1f}%{c.movements_after:>10}{c.final_rung:>11}"
              f"{elapsed:>6.0f}")
        print(f"{'':<9}final: {staircase_text(played[-1].state.apply(base).staircase)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=60)
    parser.add_argument("--seed", type=int, default=100)
    parser.add_argument("--game", choices=("reach", "path", "both"), default="both")
    args = parser.parse_args()
    if args.game in ("reach", "both"):
        run("reaching game, as-needed", REACH, args.rounds, args.seed)
    if args.game in ("path", "both"):
        run("path game, as-needed", PATH.replace(assist="as-needed"), args.rounds, args.seed)
        run("path game, transparent", PATH.replace(assist="transparent"), args.rounds,
            args.seed)


if __name__ == "__main__":
    main()
