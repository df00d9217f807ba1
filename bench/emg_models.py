"""EMG-to-joint-torque models on synthetic subjects, validated the thesis's way and harder.

    .venv/bin/python bench/emg_models.py [--muscles thesis|all] [--plot FILE.png]
                                         [--engine python|compiled]

Makes the thesis's data set (section 5.2.1) with synthetic subjects (app.emg.subjects): 4
subjects driven by virtual patients, two sessions (2 trials, then 1), an MVC per session,
subject 2's anterior deltoid MVC at 15 % of a maximal effort (its reach then reads near
90 % MVC, as the thesis's subject 2). Fits the linear baseline,
the thesis's feed-forward network and the muscle model (core.emg.models) from the
MVC-normalised envelopes to the shoulder and elbow torques, and prints RMSE (N·m) and R²:

* per trial: fitted and scored on the trial itself (what a model can describe);
* the thesis's split: trained on 11 trials, tested on subject 4's second session;
* leave one subject out: trained on three subjects, tested on the fourth;

with the linear baseline beside each, and whether the model may feed the assistance
(held-out R² ≥ core.emg.models.USABLE_R2 at both joints). `--plot` draws the activation
against torque scatter plots of the thesis's Figs. 5.1–5.2. Figures only.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from app.emg.subjects import model_data, thesis_design
from core.emg.models import (
    FeedForwardNetwork,
    LinearModel,
    MuscleModel,
    in_sample,
    leave_one_subject_out,
    validate,
)
from core.emg.synthetic import MUSCLES, THESIS_MUSCLES


def _cells(score):
    return (f"{score.rmse_Nm[0]:6.3f} {score.rmse_Nm[1]:6.3f}  "
            f"{score.r2[0]:6.2f} {score.r2[1]:6.2f}")


def plot(trials, muscles, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, len(muscles), figsize=(4 * len(muscles), 7), squeeze=False)
    for row, (joint, column) in enumerate((("elbow", 1), ("shoulder", 0))):
        for i, muscle in enumerate(muscles):
            ax = axes[row, i]
            for s in sorted({t.subject for t in trials}):
                u = np.concatenate([t.u[:, i] for t in trials if t.subject == s])
                y = np.concatenate([t.torques[:, column] for t in trials if t.subject == s])
                ax.scatter(100 * u, y, s=2, label=f"subject {s}")
            ax.set_xlabel(f"{muscle} (% MVC)")
            ax.set_ylabel(f"{joint} torque (N·m)")
    axes[0, 0].legend(markerscale=4)
    fig.suptitle("Joint torque against muscle activation (cf. thesis Figs. 5.1–5.2)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--muscles", choices=("thesis", "all"), default="thesis",
                        help="the thesis's three muscles, or with the posterior deltoid")
    parser.add_argument("--plot", type=Path, help="write the scatter plots to this PNG")
    parser.add_argument("--engine", choices=("python", "compiled"), default="compiled")
    args = parser.parse_args()
    muscles = THESIS_MUSCLES if args.muscles == "thesis" else MUSCLES
    with tempfile.TemporaryDirectory() as folder:
        design = thesis_design(folder, muscles=muscles, engine=args.engine)
        trials = [model_data(path, subject.number) for subject, _, path in design]
    makers = {"linear": LinearModel, "network": FeedForwardNetwork,
              "muscle model": lambda: MuscleModel(muscles)}
    print(f"{len(trials)} synthetic trials, 4 subjects, muscles: {', '.join(muscles)}; "
          f"{sum(len(t.u) for t in trials)} samples at 50 Hz")
    print("columns: RMSE shoulder, elbow (N·m); R² shoulder, elbow")
    print("\nper trial, fitted on the trial itself")
    print(f"{'trial':<22}" + "".join(f"{name:>30}" for name in makers))
    for t in trials:
        print(f"{t.name:<22}" + "".join(f"{_cells(in_sample(m, t)):>30}"
                                        for m in makers.values()))
    held_out = trials[-1].name  # subject 4, session 2: the thesis's test trial
    print(f"\nthe thesis's split: trained on {len(trials) - 1} trials, tested on {held_out}")
    for name, make in makers.items():
        v = validate(make, trials, {held_out}, "thesis split")
        print(f"{name:<14}{_cells(v.score)}   baseline {_cells(v.baseline)}   "
              f"{'usable' if v.usable else 'refused: ' + v.why_not}")
    print("\nleave one subject out")
    for name, make in makers.items():
        for v in leave_one_subject_out(make, trials):
            print(f"{name:<14}{v.split:<22}{_cells(v.score)}   baseline {_cells(v.baseline)}"
                  f"   {'usable' if v.usable else 'refused'}")
    if args.plot:
        plot(trials, muscles, args.plot)
        print(f"\nscatter plots: {args.plot}")


if __name__ == "__main__":
    main()
