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

from app.learning.components import plot_components, torque_components
from app.learning.dataset import pendulum_dataset
from app.learning.modelfile import read_model
from core.learning import pendulum as pd


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", required=True)
    parser.add_argument("--output", default="docs/figures/learning-delan-components.png")
    args = parser.parse_args()
    model = read_model(args.model)
    p = pd.Pendulum()
    data = pendulum_dataset(pd.generate([pd.HELD_OUT_SPEED_RAD_S], p), p)
    c = torque_components(model, data)
    print(f"{'component':<28} {'RMSE f (N)':>11} {'RMSE τ (N·m)':>13}")
    for name, e in c.rmse().items():
        print(f"{name:<28} {e[0]:>11.4f} {e[1]:>13.4f}")
    plot_components(c, args.output, title=f"{args.model}: the 5 rad/s cycle")
    print(f"figure: {args.output}  (rehab learn components does the same for any file)")



if __name__ == "__main__":
    main()
