"""Power transforms to normality: Box-Cox and Yeo-Johnson, with the maximum-likelihood λ.

A healthy population's figure is seldom normal (a reaction time or a path length ratio is
skewed to the worse side); a Z-score means what it says only on a scale where the controls
are normal. Each figure's scale is found once, from the controls, as a power transform:

- Box-Cox (Box & Cox 1964, J R Stat Soc B 26:211), on y = x + shift > 0:
  t(y) = (y^λ − 1)/λ for λ ≠ 0, log y for λ = 0;
- Yeo-Johnson (Yeo & Johnson 2000, Biometrika 87:954), on any real x:
  ((x+1)^λ − 1)/λ for x ≥ 0, λ ≠ 0;  log(x+1) for x ≥ 0, λ = 0;
  −((1−x)^(2−λ) − 1)/(2−λ) for x < 0, λ ≠ 2;  −log(1−x) for x < 0, λ = 2;
- identity ("none"), for a figure normal as it is.

λ is the maximum of the profile log-likelihood of the normal linear model on the
transformed scale (Box & Cox 1964, eq. 8): with the regression on the covariates fitted by
least squares for each λ, ℓ(λ) = −n/2·log(RSS(λ)/n) + log J(λ), J the Jacobian of the
transform (Box-Cox: (λ−1)·Σ log y; Yeo-Johnson: (λ−1)·Σ sign(x)·log(|x|+1)). With only an
intercept this is the usual marginal maximum-likelihood λ (scipy.stats.boxcox_normmax
'mle'); with covariates, the λ that makes the residuals, not the raw figures, normal: an
age effect must not be mistaken for skew.

The search is bounded (lambda_range), twice:
- to LAMBDA_RANGE = [−2, 2], the range of powers R's MASS::boxcox profiles by default
  (Venables & Ripley, lambda = seq(−2, 2, 1/10)) and scipy's boxcox_normmax brackets its
  search with; scipy and sklearn's PowerTransformer (which calls scipy) bound λ only
  against overflow (boxcox_normmax's `ymax`), not for meaning;
- to the side where the transform has no ceiling toward the figure's worse side (ours).
  Box-Cox's (y^λ − 1)/λ tends to −1/λ as y → ∞ when λ < 0, and to −1/λ as y → 0 when
  λ > 0; Yeo-Johnson's negative branch tends to 1/(2 − λ) as x → −∞ when λ > 2. A Z-score
  on such a side stops growing: with λ = −5 (the search's former bound) the shipped
  simulated norms scored a reach path 100× the controls' excess Z 3.99, their worst
  control 3.88, and capped the speed maxima count at Z 2.34 — the more impaired, the
  less it showed. So λ ≥ 0 when higher is worse, λ ≤ 0 (Box-Cox) or ≤ 2 (Yeo-Johnson)
  when lower is worse, both when either side is. The likelihood then settles at the
  bound for a figure it would bend further (a bounded figure such as a ratio near 1):
  its calibration shows what that costs (the shipped norms': held-out SDs 1.00–1.05).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize, stats

from core.errors import ParameterError

KINDS = ("box-cox", "yeo-johnson", "none")
LAMBDA_RANGE = (-2.0, 2.0)
"""The λ searched (module docstring): a λ that stops at a bound says so (`at_bound`), and
whether the controls reject it (`TransformFit.bound_rejected`)."""
FREE_RANGE = (-10.0, 10.0)
"""Where the likelihood is asked which λ it would take without the bounds (the λ a norms
file may hold)."""
REJECTED = float(stats.chi2.ppf(0.95, 1))
"""The likelihood-ratio statistic beyond which the controls reject a λ held at a bound:
χ²₁'s 95th percentile, 3.84 (the profile likelihood's 95 % interval for λ; Box & Cox 1964,
section 4)."""
WORSE_SIDES = ("higher", "lower", "both")


def lambda_range(kind: str, worse: str | None) -> tuple[float, float]:
    """The λ searched for a figure of `kind` whose `worse` side is given (None: no side,
    LAMBDA_RANGE whole): the part of LAMBDA_RANGE where the transform has no ceiling
    toward the worse side (module docstring)."""
    low, high = LAMBDA_RANGE
    if worse is None:
        return low, high
    if worse not in WORSE_SIDES:
        raise ParameterError("worse side", worse, " | ".join(WORSE_SIDES))
    if worse in ("higher", "both"):
        low = max(low, 0.0)
    if worse in ("lower", "both"):
        high = min(high, 0.0 if kind == "box-cox" else 2.0)
    return low, high


@dataclass(frozen=True)
class Transform:
    """One figure's transform: its kind, λ and (Box-Cox only) the shift added first."""

    kind: str
    lam: float = 1.0
    shift: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ParameterError("transform kind", self.kind, " | ".join(KINDS))
        for name, value in (("lambda", self.lam), ("shift", self.shift)):
            if not math.isfinite(value):
                raise ParameterError(f"transform {name}", value, "a finite number")
        if self.kind != "box-cox" and self.shift != 0.0:
            raise ParameterError("transform shift", self.shift, "0 for " + self.kind,
                                 "only Box-Cox shifts a figure to make it positive")

    def in_domain(self, x) -> np.ndarray:
        """Where the transform is defined: everywhere but Box-Cox's x + shift ≤ 0."""
        x = np.asarray(x, dtype=float)
        if self.kind == "box-cox":
            return np.isfinite(x) & (x + self.shift > 0.0)
        return np.isfinite(x)

    def apply(self, x) -> np.ndarray:
        """t(x); NaN where the transform is not defined (in_domain says where)."""
        x = np.asarray(x, dtype=float)
        if self.kind == "none":
            return x.copy()
        if self.kind == "box-cox":
            return box_cox(x + self.shift, self.lam)
        return yeo_johnson(x, self.lam)

    def invert(self, t) -> np.ndarray:
        """x from t(x): the figure's value at a given point of the normal scale."""
        t = np.asarray(t, dtype=float)
        if self.kind == "none":
            return t.copy()
        if self.kind == "box-cox":
            return box_cox_inverse(t, self.lam) - self.shift
        return yeo_johnson_inverse(t, self.lam)

    def log_jacobian(self, x) -> float:
        """log |dt/dx| summed over x (the likelihood's change of variables)."""
        x = np.asarray(x, dtype=float)
        if self.kind == "none":
            return 0.0
        if self.kind == "box-cox":
            return float((self.lam - 1.0) * np.sum(np.log(x + self.shift)))
        return float((self.lam - 1.0) * np.sum(np.sign(x) * np.log1p(np.abs(x))))


def box_cox(y, lam: float) -> np.ndarray:
    y = np.asarray(y, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(y > 0.0, y, np.nan)
        if abs(lam) < 1e-12:
            return np.log(out)
        # expm1(λ·log y)/λ is (y^λ − 1)/λ without the cancellation near λ = 0
        return np.expm1(lam * np.log(out)) / lam


def box_cox_inverse(t, lam: float) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        if abs(lam) < 1e-12:
            return np.exp(t)
        lt = lam * t
        # beyond the transform's range (λ·t ≤ −1) no y maps there; log1p keeps a small λ's
        # precision (log(1 + λt) for λ = 1e-12 loses most digits)
        return np.where(lt > -1.0, np.exp(np.log1p(np.where(lt > -1.0, lt, 0.0)) / lam),
                        np.nan)


def yeo_johnson(x, lam: float) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    out = np.full_like(x, np.nan)
    pos = x >= 0.0
    neg = x < 0.0
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        lp = np.log1p(np.where(pos, x, 0.0))
        out = np.where(pos, lp if abs(lam) < 1e-12 else np.expm1(lam * lp) / lam, out)
        ln = np.log1p(np.where(neg, -x, 0.0))
        two = 2.0 - lam
        out = np.where(neg, -ln if abs(two) < 1e-12 else -np.expm1(two * ln) / two, out)
    return out


def yeo_johnson_inverse(t, lam: float) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    out = np.full_like(t, np.nan)
    pos = t >= 0.0
    neg = t < 0.0
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        if abs(lam) < 1e-12:
            xp = np.expm1(np.where(pos, t, 0.0))
        else:
            lt = lam * np.where(pos, t, 0.0)
            xp = np.where(lt > -1.0, np.expm1(np.log1p(np.where(lt > -1.0, lt, 0.0)) / lam),
                          np.nan)
        two = 2.0 - lam
        if abs(two) < 1e-12:
            xn = -np.expm1(-np.where(neg, t, 0.0))
        else:
            lt = -two * np.where(neg, t, 0.0)
            xn = np.where(lt > -1.0, -np.expm1(np.log1p(np.where(lt > -1.0, lt, 0.0)) / two),
                          np.nan)
    return np.where(pos, xp, np.where(neg, xn, out))


@dataclass(frozen=True)
class TransformFit:
    """The fitted transform, its profile log-likelihood, and whether λ stopped at a bound
    of its search (lambda_range); then the λ the likelihood would take in FREE_RANGE and
    the likelihood-ratio statistic 2·(ℓ(free) − ℓ(bound)) of holding it there."""

    transform: Transform
    log_likelihood: float
    at_bound: bool
    free_lam: float | None = None
    bound_cost: float = 0.0

    @property
    def bound_rejected(self) -> bool:
        """The bound is outside the likelihood's 95 % interval for λ: the controls say the
        transform leaves them skewed (with few controls the interval is wide and a bound
        inside it is no news: 25 virtual controls had 35 of 39 figures noted, none rejected)."""
        return self.at_bound and self.bound_cost > REJECTED


def profile_log_likelihood(transform: Transform, x, design) -> float:
    """ℓ(λ) = −n/2·log(RSS/n) + log J: the normal linear model's log-likelihood, up to a
    constant, on the transformed scale, maximised over the coefficients and σ."""
    x = np.asarray(x, dtype=float)
    t = transform.apply(x)
    if not np.all(np.isfinite(t)):
        return -math.inf
    coefficients, *_ = np.linalg.lstsq(design, t, rcond=None)
    rss = float(np.sum((t - design @ coefficients) ** 2))
    n = x.size
    if rss <= 0.0 or not math.isfinite(rss):
        return -math.inf
    return -0.5 * n * math.log(rss / n) + transform.log_jacobian(x)


def fit_transform(kind: str, x, design=None, shift: float = 0.0, worse: str | None = None
                  ) -> TransformFit:
    """The maximum-likelihood λ of `kind` for the figure's values `x` (the controls'),
    given the regression's design matrix (None: an intercept only), searched in
    lambda_range(kind, worse)."""
    x = np.asarray(x, dtype=float).reshape(-1)
    if x.size < 3 or not np.all(np.isfinite(x)):
        raise ParameterError("values to fit a transform to", f"{x.size} values",
                             "at least 3 finite values")
    design = np.ones((x.size, 1)) if design is None else np.asarray(design, dtype=float)
    if kind == "none":
        t = Transform("none")
        return TransformFit(t, profile_log_likelihood(t, x, design), False)
    if kind == "box-cox" and np.any(x + shift <= 0.0):
        raise ParameterError("Box-Cox shift", shift, f"more than {-float(np.min(x)):g}",
                             "every value plus the shift must be positive")
    if np.ptp(x) == 0.0:
        raise ParameterError("values to fit a transform to", "all equal",
                             "values that vary", "a constant figure has no spread to norm")

    def negative(lam: float) -> float:
        value = profile_log_likelihood(Transform(kind, lam, shift), x, design)
        return -value if math.isfinite(value) else 1e300

    def best_in(low: float, high: float) -> float:
        result = optimize.minimize_scalar(negative, bounds=(low, high), method="bounded",
                                          options={"xatol": 1e-6})
        lam = float(result.x)
        if min(lam - low, high - lam) < 1e-3:
            # the bounded search stops within its tolerance of a bound, not on it
            lam = low if lam - low < high - lam else high
        return lam

    low, high = lambda_range(kind, worse)
    # Box-Cox worse on both sides: the log alone has no ceiling either way
    lam = low if low == high else best_in(low, high)
    log_likelihood = -negative(lam)
    if lam not in (low, high):
        return TransformFit(Transform(kind, lam, shift), log_likelihood, False)
    free = best_in(*FREE_RANGE)
    cost = max(0.0, 2.0 * (-negative(free) - log_likelihood))
    return TransformFit(Transform(kind, lam, shift), log_likelihood, True, free, cost)
