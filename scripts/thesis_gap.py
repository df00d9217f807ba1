"""Why the virtual healthy patient differs from the thesis's subject (section 3.6): the
experiment of section 3.6 run headless with one part of the model changed at a time.

Run: .venv/bin/python scripts/thesis_gap.py [--repetitions 5] [--seed 0] [--plant realistic]

Each row is the thesis's D (THESIS_SUBJECT: SMC, the thesis mode at 100 %, 4 s constant-
speed laps, 20° cone) with the healthy virtual patient; a variant changes one thing (the
controller's gains, the patient's impedance, drive or reaction, the robot). Besides the
figures of section 3.6 it splits the force range into the samples near the D's two corners
(±0.15 s of a turn of the path's direction) and the rest, so a range set by the corners'
transients shows as such.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from app.trials.analysis import analyse, exercise_mask
from app.trials.headless import simulate
from core.trial import THESIS_SMC_GAINS, THESIS_SUBJECT
from device.sim.patient_parameters import HEALTHY_IMPEDANCE
from device.sim.population import GUIDED_IMPEDANCE_SCALE

THESIS = {"rmse_x_mm": 8.68, "rmse_y_mm": 7.02, "dir_pct": 78.0, "frange_x_N": 0.835,
          "frange_y_N": 2.528, "sh_rom_deg": 42.17, "el_rom_deg": 30.65}
CORNER_S = 0.15


def figures(params, *, plant="realistic", seed=0, options=None) -> dict:
    """Section 3.6's figures of one headless trial, and the force range away from the
    corners."""
    trial = simulate(params, patient="healthy", seed=seed, plant=plant,
                     patient_options=options or {})
    ch = {n: trial.records[n] for n in trial.records.dtype.names}
    m = analyse(ch, params).metrics.to_dict()
    t = np.asarray(ch["time"])
    force = np.asarray(ch["force"])
    direction = np.asarray(ch["direction_desired"])
    mask = np.asarray(exercise_mask(ch))
    t, force, direction = t[mask], force[mask], direction[mask]
    turn = np.abs(np.sum(direction[1:] * direction[:-1], axis=1)) < math.cos(math.radians(10))
    turn_t = t[1:][turn]
    near = np.zeros(len(t), bool)
    for tc in turn_t:
        near |= np.abs(t - tc) <= CORNER_S
    away = force[~near]
    return {
        "rmse_x_mm": 1e3 * m["rmse_x_m"], "rmse_y_mm": 1e3 * m["rmse_y_m"],
        "dir_pct": m["directional_performance_pct"],
        "frange_x_N": m["force_range_x_N"], "frange_y_N": m["force_range_y_N"],
        "away_x_N": float(np.ptp(away[:, 0])), "away_y_N": float(np.ptp(away[:, 1])),
        "sh_rom_deg": math.degrees(m["shoulder_rom_rad"]),
        "el_rom_deg": math.degrees(m["elbow_rom_rad"]),
    }


GUIDED = {name: tuple(GUIDED_IMPEDANCE_SCALE * v for v in getattr(HEALTHY_IMPEDANCE, field))
          for name, field in (("stiffness_Nm_rad", "stiffness_Nm_rad"),
                              ("damping_Nms_rad", "damping_Nms_rad"))}
VARIANTS = (
    ("as is", {}, {}),
    ("ideal plant", {"plant": "ideal"}, {}),
    ("no push (drive 0)", {}, {"drive_N": 0.0}),
    ("guided impedance (x0.25)", {}, GUIDED),
    ("impedance ×0 (feed-forward + push only)", {},
     {"stiffness_Nm_rad": (0.0, 0.0, 0.0), "damping_Nms_rad": (0.0, 0.0, 0.0)}),
    ("SMC soft: Λ 5, K_D 0.5, K 0.05", {"gains": "smc.lambda_1_s=5; smc.k_d_Nms_rad=0.5; "
                                                  "smc.k_robust_Nm=0.05"}, {}),
    ("motors off-ish (transparent mode)", {"assist": "transparent"}, {}),
    ("minimum-jerk timing", {"timing": "minimum_jerk"}, {}),
    ("the thesis's SMC (THESIS_SMC_GAINS)", {"gains": THESIS_SMC_GAINS}, {}),
    ("the thesis's SMC + guided impedance (the population's centre)",
     {"gains": THESIS_SMC_GAINS}, GUIDED),
)


def _cell(value: float) -> str:
    return "–" if not math.isfinite(value) else f"{value:.3g}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repetitions", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--plant", default="realistic")
    parser.add_argument("--only", default="", help="run only variants whose name has this")
    args = parser.parse_args()
    keys = ("rmse_x_mm", "rmse_y_mm", "dir_pct", "frange_x_N", "frange_y_N", "away_x_N",
            "away_y_N", "sh_rom_deg", "el_rom_deg")
    print("| variant | " + " | ".join(keys) + " |")
    print("|---|" + "---|" * len(keys))
    print("| thesis | " + " | ".join(_cell(THESIS.get(k, math.nan)) for k in keys) + " |")
    for name, change, options in VARIANTS:
        if args.only and args.only not in name:
            continue
        change = dict(change)
        plant = change.pop("plant", args.plant)
        params = THESIS_SUBJECT.replace(repetitions=args.repetitions, **change)
        f = figures(params, plant=plant, seed=args.seed, options=options)
        print(f"| {name} | " + " | ".join(_cell(f[k]) for k in keys) + " |", flush=True)


if __name__ == "__main__":
    main()
