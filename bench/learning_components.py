"""The DeLaN's torque components against the pendulum's own (thesis Figs. 2.16–2.18): the
inertial H q̈, Coriolis and centrifugal, gravitational and dissipative forces along the
held-out 5 rad/s cycle, learned and analytic (eq. 2.36, 2.39), on both generalised forces.

Run: .venv/bin/python bench/learning_components.py --model delan.json
     [--output docs/figures/learning-delan-components.png]
(train the model first: `rehab learn pendulum --output p.h5`,
`rehab learn train --model delan --data p.h5 --output delan.json`). Prints each
component's RMSE against the analytic one and the total's.
"""

from __future__ import annotations

import argparse

import numpy as np

from app.learning.modelfile import read_model
from core.learning import inference, pendulum as pd


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", required=True)
    parser.add_argument("--output", default="docs/figures/learning-delan-components.png")
    args = parser.parse_args()
    model = read_model(args.model)
    if model.spec["kind"] != "delan":
        raise SystemExit(f"{args.model} is a {model.spec['kind']}, not a DeLaN")
    p = pd.Pendulum()
    d = pd.generate([pd.HELD_OUT_SPEED_RAD_S])
    terms = inference.delan_terms(model.spec, model.params, d.q, d.qd, d.qdd)
    theta, rate = d.q[:, 1], d.qd[:, 1]
    truth = {
        "inertial H q̈": np.einsum("nij,nj->ni", p.mass_matrix(theta), d.qdd),
        "Coriolis, centrifugal": p.coriolis(theta, rate),
        "gravitational ∂V/∂q": p.gravity(theta),
        # eq. 2.36 has no such term: the data's f is the generalised force, which the
        # DeLaN's d(q, q̇) would be zero for on an exact decomposition
        "dissipative d(q, q̇)": np.zeros_like(d.tau),
    }
    learned = {"inertial H q̈": terms.inertial, "Coriolis, centrifugal": terms.coriolis,
               "gravitational ∂V/∂q": terms.gravity,
               "dissipative d(q, q̇)": terms.dissipative}
    print(f"{'component':<28} {'RMSE f (N)':>11} {'RMSE τ (N·m)':>13}")
    for name in truth:
        e = np.sqrt(np.mean((learned[name] - truth[name]) ** 2, axis=0))
        print(f"{name:<28} {e[0]:>11.3f} {e[1]:>13.3f}")
    e = np.sqrt(np.mean((terms.total - d.tau) ** 2, axis=0))
    print(f"{'total (f, τ)':<28} {e[0]:>11.4f} {e[1]:>13.4f}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(4, 2, figsize=(9, 9), sharex=True)
    deg = np.degrees(theta)
    for row, name in enumerate(truth):
        for col, force in enumerate(("f (N)", "τ (N·m)")):
            ax = axes[row, col]
            ax.plot(deg, truth[name][:, col], color="black", label="analytic (eq. 2.36)")
            ax.plot(deg, learned[name][:, col], color="tab:orange", linestyle="--",
                    label="DeLaN")
            ax.set_title(f"{name}: {force}", fontsize=9)
    axes[0, 0].legend(fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("θ2 (°), 5 rad/s cycle")
    fig.tight_layout()
    fig.savefig(args.output, dpi=110)
    print(f"figure: {args.output}")


if __name__ == "__main__":
    main()
