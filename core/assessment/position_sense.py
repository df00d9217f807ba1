"""Position sense: the robot takes the hand passively to a target (the patient's
screen blank), back, and the patient reproduces the position; the errors of the
reproductions.

The three errors of Schutz & Roy, J Mot Behav 5(3):141-153, 1973
(doi:10.1080/00222895.1973.10734959), in the plane (our reading of the pooling):

* *Absolute error*: the mean over trials of |reproduced − target| (m).
* *Constant error*: per target, the distance from the target to the mean of its
  reproductions; the mean over targets (m). Signed constant errors cancel over
  directions in the plane, so the figure is the bias's size.
* *Variable error*: the spread of the reproductions about their own mean, pooled
  over targets: √( Σ_k Σ_i |r_ki − r̄_k|² / Σ_k (n_k − 1) ), r̄_k the mean
  reproduction of target k and n_k its trials (the pooled standard deviation of
  the 2-D positions, as the root of the sum of both axes' variances). Targets
  with a single trial add nothing; NaN when no target has two.

Targets are grouped by position (to a nanometre). A trial whose reproduction is
NaN (the patient did not reproduce it) is left out of all three.
"""

from __future__ import annotations

import math

import numpy as np

from core.assessment.geometry import points
from core.errors import ParameterError

_GROUP_M = 1e-9  # targets closer than a nanometre are the same target


def position_figures(targets_m, reproduced_m) -> dict[str, float]:
    """The task's figures keyed as core.assessment.FIGURES: one row per trial, the
    target (K, 2) m and the reproduced position (K, 2) m (NaN row: not reproduced, left out
    of the errors and counted)."""
    targets = points("targets_m", targets_m)
    reproduced = np.asarray(reproduced_m, dtype=float)
    if reproduced.shape != targets.shape:
        raise ParameterError("reproduced_m", f"an array of shape {reproduced.shape}",
                             f"shape {targets.shape}: one row per target in targets_m")
    done = np.isfinite(reproduced).all(axis=1)
    if (np.isfinite(reproduced).any(axis=1) & ~done).any():
        raise ParameterError("reproduced_m", "a row with one coordinate NaN",
                             "both coordinates or neither (not reproduced)")
    not_reproduced = float((~done).sum())
    targets, reproduced = targets[done], reproduced[done]
    nan = math.nan
    if not len(targets):
        return {"position_absolute_error_m": nan, "position_variable_error_m": nan,
                "position_constant_error_m": nan,
                "position_not_reproduced_count": not_reproduced}
    absolute = float(np.mean(np.hypot(*(reproduced - targets).T)))
    _, group = np.unique(np.round(targets / _GROUP_M), axis=0, return_inverse=True)
    group = group.ravel()
    constant, squares, dof = [], 0.0, 0
    for k in range(int(group.max()) + 1):
        mine = reproduced[group == k]
        centre = mine.mean(axis=0)
        constant.append(math.dist(centre, targets[group == k][0]))
        squares += float(np.sum((mine - centre) ** 2))
        dof += len(mine) - 1
    return {
        "position_absolute_error_m": absolute,
        "position_variable_error_m": math.sqrt(squares / dof) if dof else nan,
        "position_constant_error_m": float(np.mean(constant)),
        "position_not_reproduced_count": not_reproduced,
    }
