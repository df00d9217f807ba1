"""Z-scores of figures and a task's score, after Kinarm's published approach.

A figure's Z-score is its distance from what healthy people like the patient do, in the
controls' residual SDs, on the scale where they are normal (transforms.py, regression.py):

    Z = (t(x) − t̂(covariates)) / σ                                           (2)

Z keeps the figure's sign: a positive Z is a figure higher than the controls'. Which side
is worse comes from the figure (core.assessment.FIGURES' `better`): a `worse` direction of
"higher", "lower" or "both" (a figure worse either way, e.g. a speed ratio).

A task's score combines its figures' Z-scores (Simmatis et al. 2020, J NeuroEng Rehabil
17:86, doi 10.1186/s12984-020-00713-2, and its correction, 2023, doi
10.1186/s12984-022-01120-5; Kinarm Standard Tests Summary):

1. each figure contributes a non-negative deviation d: |Z| for a figure worse either way;
   for a figure worse on one side only, its Z turned so that positive is worse, Z_w, then
   mapped one-sided, d = H⁻¹(Φ(Z_w)) (eq. 4): a healthy person's d is then half-normal
   like |Z|, and a figure better than the controls' mean counts near 0, never as a
   deviation (ours: the papers say one-sided parameters are treated one-sided but do not
   write the map; we use the same map as the task score's, eq. 4);
2. the root-sum-square distance D = √(Σ d²) (eq. 3);
3. D transformed to normality in the controls (a Box-Cox transform fitted on the controls'
   D) and standardised by the controls' mean and SD: the Z-Task Score
   Z_task = (t(D) − mean_c)/SD_c;
4. mapped one-sided, so 0 is best and the controls' scores are half-normal (a score of 1
   has ~68.3 % of the controls below it, 1.96 has 95 %; Simmatis et al. 2020, Fig. 4):

    Task Score = H⁻¹(Φ(Z_task)),  H⁻¹(p) = Φ⁻¹((1 + p)/2)                    (4)

   computed as Φ⁻¹ of the upper tail in log space, −ndtri_exp(logsf(Z) − log 2), so a
   large Z keeps its precision and a Z of 1000 maps to ≈ 1000, not to infinity.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from scipy import special, stats

from core.errors import ParameterError

WORSE = ("higher", "lower", "both")
"""The side on which a figure is worse than healthy: `both` for a two-sided figure."""
BETTER_TO_WORSE = {"lower": "higher", "higher": "lower", "none": "both"}
"""core.assessment.FIGURES' `better` turned into the side that is worse."""


def z_score(t_value: float, expected: float, residual_sd: float) -> float:
    """Eq. (2) on the transformed scale."""
    if not residual_sd > 0.0:
        raise ParameterError("residual SD", residual_sd, "more than 0")
    return (float(t_value) - float(expected)) / float(residual_sd)


def one_sided(z):
    """Eq. (4): a standard normal Z mapped to the half-normal quantile of the same
    probability; 0 at Z → −∞, ≈ Z for a large Z, monotonic."""
    z = np.asarray(z, dtype=float)
    # Φ⁻¹ of the upper tail in log space: isf(sf(Z)/2) = −ndtri(exp(logsf(Z) − log 2));
    # sf(Z) itself underflows to 0 beyond Z ≈ 38 and gave an infinite score
    out = np.abs(-special.ndtri_exp(stats.norm.logsf(z) - math.log(2.0)))
    return float(out) if out.ndim == 0 else out


def worse_signed(z: float, worse: str) -> float:
    """Z turned so that positive is worse (a two-sided figure keeps its sign)."""
    if worse not in WORSE:
        raise ParameterError("worse", worse, " | ".join(WORSE))
    return -z if worse == "lower" else z


def deviation(z, worse: str):
    """A figure's contribution to the task's distance: |Z| two-sided, eq. (4) one-sided
    (Z a number or an array of them)."""
    z = np.asarray(z, dtype=float)
    d = np.abs(z) if worse == "both" else np.asarray(one_sided(worse_signed(z, worse)))
    return float(d) if d.ndim == 0 else d


def task_distances(z_scores: Mapping[str, np.ndarray], worse: Mapping[str, str],
                   figures: Sequence[str]) -> np.ndarray:
    """Eq. (3) for many people at once: D = √(Σ d²) over the task's figures, `z_scores`
    figure → one Z per person."""
    d = np.array([deviation(np.asarray(z_scores[f], dtype=float), worse[f]) for f in figures],
                 dtype=float).reshape(len(figures), -1)
    return np.sqrt(np.sum(d * d, axis=0))


def task_distance(z_scores: Mapping[str, float], worse: Mapping[str, str],
                  figures: Sequence[str]) -> float:
    """Eq. (3): D = √(Σ d²) over the task's figures; every figure must have its Z."""
    missing = [f for f in figures if f not in z_scores]
    if missing:
        raise ParameterError("task figures", ", ".join(missing), "a Z-score for every "
                             "figure the task combines", "the trial lacks them")
    distance = float(task_distances({f: [z_scores[f]] for f in figures}, worse, figures)[0])
    if not math.isfinite(distance):
        raise ParameterError("task figures' Z-scores", [z_scores[f] for f in figures],
                             "finite numbers")
    return distance


def task_z(t_distance: float, mean: float, sd: float) -> float:
    """Step 3: the Z-Task Score from the transformed distance."""
    return z_score(t_distance, mean, sd)


def task_score(z_task: float) -> float:
    """Step 4: the one-sided Task Score, eq. (4)."""
    return float(one_sided(z_task))
