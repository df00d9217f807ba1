"""The thesis's healthy-subject experiment (section 3.6) simulated, beside the thesis's figures,
and the same table for every virtual patient. Prints a markdown table for docs/validation.md.

Run: .venv/bin/python scripts/validate_thesis.py [--repetitions 5] [--seed 0]
     [--plant ideal|realistic] [--assist thesis|as-needed]
"""

from __future__ import annotations

import argparse
import math

from app.trials.analysis import analyse
from app.trials.headless import simulate
from core.trial import THESIS_SUBJECT
from device.sim.patient_parameters import PATIENT_KINDS

ROWS = (
    # (label, metric key, display scale, unit, thesis value)
    ("RMSE x", "rmse_x_m", 1000.0, "mm", 8.68),
    ("RMSE y", "rmse_y_m", 1000.0, "mm", 7.02),
    ("directional performance", "directional_performance_pct", 1.0, "%", 78.0),
    ("force range x", "force_range_x_N", 1.0, "N", 0.835),
    ("force range y", "force_range_y_N", 1.0, "N", 2.528),
    ("shoulder ROM (ISB)", "shoulder_rom_rad", 180.0 / math.pi, "°", 42.17),
    ("elbow ROM (ISB)", "elbow_rom_rad", 180.0 / math.pi, "°", 30.65),
    ("shoulder torque range (raw)", "shoulder_torque_range_Nm", 1.0, "N·m", 4.79),
    ("elbow torque range (raw)", "elbow_torque_range_Nm", 1.0, "N·m", 0.817),
    ("shoulder torque range (10 Hz)", "shoulder_torque_range_smoothed_Nm", 1.0, "N·m", math.nan),
    ("elbow torque range (10 Hz)", "elbow_torque_range_smoothed_Nm", 1.0, "N·m", math.nan),
    ("path length ratio", "path_length_ratio", 1.0, "", math.nan),
    ("SPARC", "sparc", 1.0, "", math.nan),
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repetitions", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--plant", choices=("ideal", "realistic"), default="ideal",
                        help="the simulated robot (device.sim.plant; default ideal, as in "
                             "docs/validation.md's table)")
    parser.add_argument("--assist", choices=("thesis", "as-needed"), default="thesis",
                        help="the assistance mode (default thesis: the thesis's scheme)")
    args = parser.parse_args()
    params = THESIS_SUBJECT.replace(repetitions=args.repetitions, assist=args.assist)
    results = {}
    for kind in PATIENT_KINDS:
        trial = simulate(params, patient=kind, seed=args.seed, plant=args.plant)
        channels = {n: trial.records[n] for n in trial.records.dtype.names}
        results[kind] = (trial.status, analyse(channels, params).metrics.to_dict())
    kinds = list(PATIENT_KINDS)
    print(f"Thesis D (line centred at (−0.30, 0.30) m, r = 0.10 m, 4 s per traversal, constant "
          f"speed), {args.repetitions} traversals, SMC, 20° tolerance, assistance 100 %, "
          f"91 kg subject with 12 in segments, shoulder (−0.12, 0.73) m, seed {args.seed}, "
          f"{args.plant} plant, {args.assist} assistance.\n")
    print("| figure | thesis | " + " | ".join(kinds) + " |")
    print("|---|---|" + "---|" * len(kinds))
    for label, key, scale, unit, thesis in ROWS:
        cells = [_cell(results[k][1][key] * scale) for k in kinds]
        unit_text = f" ({unit})" if unit else ""
        print(f"| {label}{unit_text} | {_cell(thesis)} | " + " | ".join(cells) + " |")
    print("| trial status | completed | " + " | ".join(results[k][0] for k in kinds) + " |")


def _cell(value: float) -> str:
    if not math.isfinite(value):
        return "–"
    return f"{value:.3g}" if abs(value) < 10 else f"{value:.1f}"


if __name__ == "__main__":
    main()
