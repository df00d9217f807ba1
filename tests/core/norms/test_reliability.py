"""ICC, SEM and MDC95 on constructed test-retest data equal the formulas by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.errors import ParameterError
from core.norms import reliability

# 4 people × 2 sessions; by hand: grand mean 5, row means 2.5, 4.5, 5.5, 7.5,
# column means 4.75, 5.25
TABLE = [[2.0, 3.0], [4.0, 5.0], [6.0, 5.0], [7.0, 8.0]]


def test_mean_squares_by_hand():
    # SSR = 2·(6.25 + 0.25 + 0.25 + 6.25) = 26, MSR = 26/3
    # SSC = 4·(0.0625 + 0.0625) = 0.5, MSC = 0.5
    # SST = 9 + 4 + 1 + 0 + 1 + 0 + 4 + 9 = 28, SSE = 28 − 26 − 0.5 = 1.5, MSE = 0.5
    msr, msc, mse = reliability.mean_squares(TABLE)
    assert (msr, msc, mse) == pytest.approx((26 / 3, 0.5, 0.5))


def test_icc_forms_by_hand():
    msr, msc, mse, n, k = 26 / 3, 0.5, 0.5, 4, 2
    icc21 = (msr - mse) / (msr + (k - 1) * mse + k * (msc - mse) / n)
    icc31 = (msr - mse) / (msr + (k - 1) * mse)
    assert reliability.icc(TABLE, "2,1") == pytest.approx(icc21)
    assert reliability.icc(TABLE, "3,1") == pytest.approx(icc31)
    assert icc21 == pytest.approx((26 / 3 - 0.5) / (26 / 3 + 0.5))


def test_mdc_is_the_formula():
    sd = float(np.std(np.asarray(TABLE), ddof=1))  # all 8 values: SST/7 = 4
    assert sd == pytest.approx(2.0)
    icc = reliability.icc(TABLE)
    sem = sd * math.sqrt(1 - icc)
    assert reliability.sem(TABLE) == pytest.approx(sem)
    assert reliability.mdc95(TABLE) == pytest.approx(1.96 * math.sqrt(2) * sem)


def test_icc21_counts_a_systematic_shift_icc31_does_not():
    rng = np.random.default_rng(1)
    true = rng.normal(0, 1, 200)
    table = np.column_stack([true + rng.normal(0, 0.3, 200),
                             true + 1.0 + rng.normal(0, 0.3, 200)])  # learnt: +1
    assert reliability.icc(table, "3,1") > reliability.icc(table, "2,1") + 0.1


def test_is_real_change():
    assert reliability.is_real_change(1.0, 1.6, 0.5)
    assert not reliability.is_real_change(1.0, 1.5, 0.5)  # exactly the MDC: not beyond it
    assert reliability.is_real_change(1.0, 0.4, 0.5)
    with pytest.raises(ParameterError):
        reliability.is_real_change(1.0, math.nan, 0.5)
    with pytest.raises(ParameterError):
        reliability.is_real_change(1.0, 2.0, -0.1)


def test_refusals():
    with pytest.raises(ParameterError, match="2 people"):
        reliability.icc([[1.0, 2.0]])
    with pytest.raises(ParameterError, match="finite"):
        reliability.icc([[1.0, math.nan], [2.0, 3.0]])
    with pytest.raises(ParameterError, match="form"):
        reliability.icc(TABLE, "1,1")
    with pytest.raises(ParameterError, match="spread"):
        reliability.icc([[1.0, 1.0], [1.0, 1.0]])


def test_a_negative_icc_is_no_reliability_not_an_error_beyond_the_spread():
    """Each person's two sessions cross (one high, one low): the people's mean square is
    below the error's and the ICC estimate negative. It is reported as it is; the SEM
    counts it as 0 (Bartko 1976), the SD of all the measurements, never more (it was
    SD·√(1 − ICC), 1.63·SD here: ICC −1.65)."""
    table = [[1.0, 3.0], [3.0, 1.0], [1.5, 2.5], [2.5, 1.5], [2.0, 2.2]]
    msr, _, mse = reliability.mean_squares(table)
    assert mse > msr
    icc = reliability.icc(table)
    assert icc == pytest.approx(-1.649, abs=1e-3)
    sd = float(np.std(np.asarray(table), ddof=1))
    assert reliability.sem(table) == pytest.approx(sd)
    assert reliability.mdc95(table) == pytest.approx(1.96 * math.sqrt(2) * sd)
