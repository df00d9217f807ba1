"""Z, the one-sided map and the task distance against hand computations (statistics.NormalDist,
not scipy, so the reference is independent of the code under test)."""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np
import pytest
from hypothesis import given, strategies as st

from core.errors import ParameterError
from core.norms import scores

N = NormalDist()


def half_normal_quantile(z: float) -> float:
    return N.inv_cdf((1.0 + N.cdf(z)) / 2.0)


@pytest.mark.parametrize("z", [-3.0, -1.0, 0.0, 0.5, 1.0, 1.96, 3.0])
def test_one_sided_is_the_half_normal_quantile(z):
    assert scores.one_sided(z) == pytest.approx(half_normal_quantile(z), abs=1e-9)


def test_one_sided_keeps_precision_far_out():
    # Φ(10) rounds to 1 in double precision; the upper-tail form does not
    assert scores.one_sided(10.0) == pytest.approx(10.0, abs=0.1)
    assert math.isfinite(scores.one_sided(30.0))
    assert scores.one_sided(-40.0) == pytest.approx(0.0, abs=1e-12)


@given(st.floats(-8, 8), st.floats(-8, 8))
def test_one_sided_is_monotonic_and_non_negative(a, b):
    lo, hi = sorted((a, b))
    assert 0.0 <= scores.one_sided(lo) <= scores.one_sided(hi) + 1e-12


def test_controls_map_to_half_normal():
    z = np.random.default_rng(0).standard_normal(20000)
    s = scores.one_sided(z)
    assert np.mean(s < 1.0) == pytest.approx(0.683, abs=0.01)
    assert np.mean(s > 1.96) == pytest.approx(0.05, abs=0.005)


def test_task_distance_by_hand():
    z = {"a": -2.7, "b": -1.6, "c": 0.8}
    worse = {"a": "higher", "b": "lower", "c": "both"}
    d = [half_normal_quantile(-2.7), half_normal_quantile(1.6), 0.8]
    assert scores.task_distance(z, worse, ["a", "b", "c"]) == pytest.approx(
        math.sqrt(sum(v * v for v in d)), abs=1e-9)
    with pytest.raises(ParameterError, match="b"):
        scores.task_distance({"a": 1.0}, worse, ["a", "b"])


def test_z_and_worse_side():
    assert scores.z_score(-0.6, -0.33, 0.1) == pytest.approx(-2.7)
    assert scores.worse_signed(-1.6, "lower") == 1.6
    assert scores.worse_signed(-1.6, "both") == -1.6
    with pytest.raises(ParameterError):
        scores.z_score(1.0, 0.0, 0.0)
    with pytest.raises(ParameterError):
        scores.worse_signed(1.0, "up")


def test_one_sided_far_beyond_the_controls_stays_finite():
    """sf(Z) underflows to 0 beyond Z ≈ 38: the map is computed in log space (a patient at
    0 area had Z −1008 on a figure worse lower, and the task score was refused as not
    finite)."""
    assert scores.one_sided(40.0) == pytest.approx(40.0, abs=0.05)
    assert scores.one_sided(1007.0) == pytest.approx(1007.0, abs=0.01)
    assert scores.deviation(-1007.0, "lower") == pytest.approx(1007.0, abs=0.01)
