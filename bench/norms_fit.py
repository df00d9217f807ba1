"""What fitting a normative model costs at a population's size, and how well it recovers
what the controls were drawn from.

    .venv/bin/python bench/norms_fit.py [--subjects 500] [--folds 5] [--seed 0]

Constructed controls: every figure of core.assessment.FIGURES, each a Box-Cox variable of
known λ (drawn in [−1, 1.5] within the range the fit searches for the figure's worse side,
core.norms.transforms.lambda_range: [0, 1.5] when higher is worse, [−1, 0] when lower is,
0 when either is) with known coefficients on age, sex, handedness and the tested
side, residual SD 0.1 on the transformed scale, one robot. Fits them as `rehab norms fit`
does (app.norms.fitting.fit_norms: every figure, every task score, the k-fold
cross-validated calibration) and prints the time of the fit and of the calibration, and
the recovery: the median and worst |λ − λ_true| and |β_age − β_age,true|/SE, the held-out
Z-scores' SD and share beyond ±1.96 across figures, and each task score's share above 1.96.

Figures only; no assertion.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from app.norms.fitting import Controls, fit_norms
from core.assessment import FIGURES
from core.norms import fitting
from core.norms.regression import Covariates, spec_of
from core.norms.scores import BETTER_TO_WORSE
from core.norms.transforms import lambda_range

WORSE = {key: BETTER_TO_WORSE[spec.better] for key, spec in FIGURES.items()}
AT_LIMIT = {spec.bounded_by for spec in FIGURES.values() if spec.bounded_by}
"""Counts of pushes at the robot's limit: 0 in every constructed control (a robot that
holds more than they push), so that the fit norms the forces those counts bound (a count
above 0 in more than 5 % of the controls leaves them out, as no spread)."""

SIGMA = 0.1


def controls(n: int, seed: int):
    rng = np.random.default_rng(seed)
    people = tuple(Covariates(float(rng.uniform(20, 85)), str(rng.choice(["female", "male"])),
                              "left" if rng.random() < 0.12 else "right",
                              str(rng.choice(["right", "left"])), "simulator-realistic")
                   for _ in range(n))
    X = spec_of(people).design(people)
    truth, figures = {}, {}
    for key in FIGURES:
        if key in AT_LIMIT:
            figures[key] = np.zeros(n)
            continue
        low, high = lambda_range("box-cox", WORSE[key])
        lam = float(rng.uniform(max(low, -1.0), min(high, 1.5)))
        age = rng.uniform(-0.004, 0.004)
        # centred on t = 0, so that 1 + λt > 0 for every λ drawn (the inverse exists)
        beta = np.array([-52.5 * age, age, rng.uniform(-0.1, 0.1), rng.uniform(-0.05, 0.05),
                         rng.uniform(-0.05, 0.05)])
        t = X @ beta + rng.normal(0, SIGMA, n)
        figures[key] = np.exp(t) if abs(lam) < 1e-9 else (1 + lam * t) ** (1 / lam)
        truth[key] = (lam, beta)
    return Controls(tuple(f"C{i}" for i in range(n)), people, figures), truth, X


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=500)
    parser.add_argument("--folds", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    data, truth, X = controls(args.subjects, args.seed)
    start = time.perf_counter()
    model = fitting.fit_model({k: data.figures[k] for k in truth}, data.people, WORSE, {},
                              "box-cox")
    fit_s = time.perf_counter() - start
    start = time.perf_counter()
    report = fit_norms(data, "bench", simulated=True, transform="box-cox", folds=args.folds)
    whole_s = time.perf_counter() - start
    se_age = SIGMA * np.sqrt(np.linalg.inv(X.T @ X)[1, 1])
    lam_err = [abs(model.figures[k].transform.lam - truth[k][0]) for k in truth]
    age_err = [abs(model.figures[k].regression.coefficients["age_years"] - truth[k][1][1])
               / se_age for k in truth]
    held = report.calibration
    sds = [held[k].sd for k in truth]
    beyond = [held[k].beyond_1_96 for k in truth]
    print(f"{args.subjects} controls × {len(truth)} figures ({len(AT_LIMIT)} counts at the "
          f"robot's limit 0), {args.folds}-fold calibration")
    print(f"fit of the figures alone: {fit_s:.2f} s; the whole fit with task scores and "
          f"calibration: {whole_s:.2f} s")
    print(f"|λ − λ_true|: median {np.median(lam_err):.3f}, worst {max(lam_err):.3f}")
    print(f"|β_age − true|/SE: median {np.median(age_err):.2f}, worst {max(age_err):.2f}")
    print(f"held-out Z SD: {min(sds):.3f}–{max(sds):.3f}; share beyond ±1.96: "
          f"{100 * min(beyond):.1f}–{100 * max(beyond):.1f} %")
    for key, c in held.items():
        if key.startswith("task:"):
            print(f"{key}: held-out task scores above 1.96: {100 * c.beyond_1_96:.1f} % "
                  f"(n {c.n}), QQ max deviation {c.qq_max_deviation:.3f}")


if __name__ == "__main__":
    main()
