"""Box-Cox and Yeo-Johnson: the formulas by hand, the inverse, and the ML λ recovered."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, strategies as st
from scipy import stats

from core.errors import ParameterError
from core.norms.transforms import (
    LAMBDA_RANGE,
    Transform,
    fit_transform,
    lambda_range,
    profile_log_likelihood,
)


def test_box_cox_by_hand():
    t = Transform("box-cox", 0.5, 1.0)
    # y = 3 + 1 = 4: (4^0.5 − 1)/0.5 = 2
    assert float(t.apply(3.0)) == pytest.approx(2.0, abs=1e-15)
    assert float(Transform("box-cox", 0.0).apply(math.e ** 2)) == pytest.approx(2.0)
    assert float(Transform("box-cox", -1.0).apply(2.0)) == pytest.approx(0.5)  # (1/2 − 1)/−1
    assert math.isnan(float(t.apply(-1.0)))  # y = 0: outside
    assert not t.in_domain(-1.0)
    assert t.in_domain(-0.5)


def test_yeo_johnson_by_hand():
    t = Transform("yeo-johnson", 0.5)
    assert float(t.apply(3.0)) == pytest.approx(2.0)  # ((3+1)^0.5 − 1)/0.5
    # x < 0: −((1 − x)^(2 − λ) − 1)/(2 − λ) = −((4)^1.5 − 1)/1.5 = −7/1.5
    assert float(t.apply(-3.0)) == pytest.approx(-7.0 / 1.5)
    assert float(Transform("yeo-johnson", 2.0).apply(-3.0)) == pytest.approx(-math.log(4.0))
    assert float(Transform("yeo-johnson", 0.0).apply(3.0)) == pytest.approx(math.log(4.0))


def test_scipy_agrees():
    x = np.linspace(0.1, 5.0, 40)
    for lam in (-1.3, 0.0, 0.4, 2.2):
        assert np.allclose(Transform("box-cox", lam).apply(x), stats.boxcox(x, lam))
        xs = np.linspace(-4, 4, 41)
        assert np.allclose(Transform("yeo-johnson", lam).apply(xs), stats.yeojohnson(xs, lam))


@example("box-cox", 1e-12, 0.0, 0.0)  # log(1 + λt) lost the digits a small λ needs
@example("yeo-johnson", 2.0 - 1e-12, -2.0, 0.0)
@given(st.sampled_from(["box-cox", "yeo-johnson"]), st.floats(-3, 3),
       st.floats(-3, 3), st.floats(0, 2))
def test_inverse_round_trip(kind, lam, x, shift):
    t = Transform(kind, lam, shift if kind == "box-cox" else 0.0)
    if kind == "box-cox":
        x = abs(x) + 0.05 - shift * 0.5
    if not t.in_domain(x):
        return
    assert float(t.invert(t.apply(x))) == pytest.approx(x, rel=1e-7, abs=1e-9)


def test_transform_refuses_its_own_nonsense():
    with pytest.raises(ParameterError, match="transform kind"):
        Transform("log")
    with pytest.raises(ParameterError, match="shift"):
        Transform("yeo-johnson", 1.0, 2.0)
    with pytest.raises(ParameterError, match="lambda"):
        Transform("box-cox", math.nan)


@pytest.mark.parametrize("lam", [-0.5, 0.0, 0.5])
def test_ml_lambda_recovered(lam):
    """Values whose Box-Cox λ is known (normal on the transformed scale) give back λ within
    four standard errors (from the likelihood's curvature: it shrinks as 1/√n), and the
    same λ as scipy's maximum-likelihood estimate."""
    rng = np.random.default_rng(3)
    t = rng.normal(0.5, 0.3, 2000)
    x = np.exp(t) if lam == 0.0 else (1.0 + lam * t) ** (1.0 / lam)
    fit = fit_transform("box-cox", x)
    found, h = fit.transform.lam, 1e-3
    design = np.ones((x.size, 1))
    ll = [profile_log_likelihood(Transform("box-cox", found + d), x, design)
          for d in (-h, 0.0, h)]
    se = 1.0 / math.sqrt(-(ll[0] - 2 * ll[1] + ll[2]) / h**2)
    assert se < 0.3
    assert abs(found - lam) < 4 * se
    assert found == pytest.approx(stats.boxcox_normmax(x, method="mle"), abs=1e-3)
    assert not fit.at_bound


def test_fit_refuses_what_it_cannot_fit():
    with pytest.raises(ParameterError, match="positive"):
        fit_transform("box-cox", [0.0, 1.0, 2.0])
    with pytest.raises(ParameterError, match="vary"):
        fit_transform("yeo-johnson", [1.0, 1.0, 1.0])
    with pytest.raises(ParameterError, match="at least 3"):
        fit_transform("yeo-johnson", [1.0, 2.0])


def _controls_of_lambda(lam: float, n: int = 500) -> np.ndarray:
    """Values normal on the Box-Cox scale of `lam`: the likelihood's λ is about `lam`."""
    t = np.random.default_rng(4).normal(0.0, 0.05, n)
    return (1.0 + lam * t) ** (1.0 / lam)


def _z(fit, x, controls) -> float:
    t = fit.transform.apply(controls)
    return float((fit.transform.apply(x) - t.mean()) / t.std(ddof=1))


@pytest.mark.parametrize("worse", ["higher", "lower"])
def test_the_worse_side_has_no_ceiling(worse):
    """Controls the likelihood would bend with λ = −4 (higher is worse) or +4 (lower is
    worse): with that λ (searched in ±5 before) a patient's Z-score stops growing on the
    worse side (Box-Cox tends to −1/λ): a patient at 100 times the worst control's excess,
    or at 0, scored about Z 5, as the shipped norms' path length ratio scored 3.99 against
    its worst control's 3.88. The search keeps λ on the side with no ceiling."""
    x = _controls_of_lambda(-4.0 if worse == "higher" else 4.0)
    fit = fit_transform("box-cox", x, shift=0.01, worse=worse)
    median, edge = float(np.median(x)), float(x.max() if worse == "higher" else x.min())
    far = median + 100 * (edge - median) if worse == "higher" else 0.0
    sign = 1.0 if worse == "higher" else -1.0
    assert sign * _z(fit, far, x) > 20.0
    assert fit.at_bound
    assert fit.transform.lam == 0.0


def test_lambda_range_by_worse_side():
    assert lambda_range("box-cox", None) == LAMBDA_RANGE == (-2.0, 2.0)
    assert lambda_range("box-cox", "higher") == (0.0, 2.0)
    assert lambda_range("box-cox", "lower") == (-2.0, 0.0)
    assert lambda_range("yeo-johnson", "lower") == (-2.0, 2.0)
    assert lambda_range("box-cox", "both") == (0.0, 0.0)
    assert lambda_range("yeo-johnson", "both") == (0.0, 2.0)
    with pytest.raises(ParameterError, match="worse side"):
        lambda_range("box-cox", "up")
    both = fit_transform("box-cox", _controls_of_lambda(1.0), worse="both")
    assert both.transform.lam == 0.0
    assert both.at_bound


def test_a_bound_is_noted_only_when_the_controls_reject_it():
    """25 controls, the shipped fit's worse-side bounds: a figure nearly normal and far from
    0 (a speed 0.3 ± 0.02 m/s, lower worse) is held at λ = 0, which its likelihood cannot
    tell from 1 (the ratio well under 3.84): no news. A long low tail on a figure where
    higher is worse (30 − e^(1.2z)) wants λ far above 2: rejected, and said."""
    rng = np.random.default_rng(0)
    near_normal = 0.3 + 0.02 * rng.standard_normal(25)
    held = fit_transform("box-cox", near_normal, worse="lower")
    assert held.at_bound
    assert held.transform.lam == 0.0
    assert held.bound_cost < 3.84
    assert not held.bound_rejected
    skewed = 30.0 - np.exp(1.2 * rng.standard_normal(80))
    rejected = fit_transform("box-cox", skewed, worse="higher")
    assert rejected.transform.lam == 2.0
    assert rejected.free_lam > 2.0
    assert rejected.bound_cost > 3.84
    assert rejected.bound_rejected
