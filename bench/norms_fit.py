"""What fitting a normative model costs at a population's size, and how well it recovers
what the controls were drawn from.

    .venv/bin/python bench/norms_fit.py [--subjects 500] [--folds 5] [--seed 0]

Constructed controls: every figure of core.assessment.FIGURES, each a Box-Cox variable of
known λ (drawn in [−1, 1.5]) with known coefficients on age, sex, handedness and the tested
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
        lam = float(rng.uniform(-1.0, 1.5))
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
    model = fitting.fit_model(data.figures, data.people,
                              {k: "higher" for k in data.figures}, {}, "box-cox")
    fit_s = time.perf_counter() - start
    start = time.perf_counter()
    report = fit_norms(data, "bench", simulated=True, transform="box-cox", folds=args.folds)
    whole_s = time.perf_counter() - start
    se_age = SIGMA * np.sqrt(np.linalg.inv(X.T @ X)[1, 1])
    lam_err = [abs(model.figures[k].transform.lam - truth[k][0]) for k in FIGURES]
    age_err = [abs(model.figures[k].regression.coefficients["age_years"] - truth[k][1][1])
               / se_age for k in FIGURES]
    held = report.calibration
    sds = [held[k].sd for k in FIGURES]
    beyond = [held[k].beyond_1_96 for k in FIGURES]
    print(f"{args.subjects} controls × {len(FIGURES)} figures, {args.folds}-fold calibration")
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
