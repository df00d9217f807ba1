"""Test-retest reliability: the intraclass correlation, the standard error of measurement
and the minimal detectable change.

From n people each measured k times (k = 2 for a test-retest pair), the two-way ANOVA mean
squares: rows (people) MSR, columns (sessions) MSC, error MSE (Shrout & Fleiss 1979,
Psychol Bull 86:420; McGraw & Wong 1996, Psychol Methods 1:30; Koo & Li 2016, J Chiropr
Med 15:155):

    ICC(2,1) = (MSR − MSE) / (MSR + (k−1)·MSE + k·(MSC − MSE)/n)              (5)
    ICC(3,1) = (MSR − MSE) / (MSR + (k−1)·MSE)                                (6)

    SEM = SD·√(1 − max(ICC, 0)),   MDC95 = 1.96·√2·SEM                         (7)

(Weir 2005, J Strength Cond Res 19:231; Haley & Fragala-Pinkham 2006, Phys Ther 86:735),
SD the standard deviation of all n·k measurements (ddof 1).

A negative ICC is read as no reliability: SEM = SD. The ICC estimated from the mean
squares is negative when the error's mean square exceeds the people's (MSE > MSR: the
sessions of one person differ more than people do), while the ICC it estimates, a
ratio of variances, is at least 0 (Giraudeau 1996, J Clin Epidemiol 49:1205); a negative
estimate is taken as 0 (Bartko 1976, Psychol Bull 83:762), i.e. all the measurements'
spread is measurement error, poor reliability in Koo & Li 2016's grading (below 0.5). The
ICC itself is reported as estimated. Without the max, SD·√(1 − ICC) made the error larger
than the whole spread it is a part of (an ICC of −0.5 gave SEM = 1.22·SD).

The console uses ICC(2,1), absolute agreement: a clinician compares a patient's figure
with the same patient's figure of another day, so a systematic shift between sessions (a
learning effect, a robot recalibrated) is part of what a change must exceed. Simmatis et
al. 2020 report ICC(3,1) (consistency), which ignores that shift; `icc(..., form="3,1")`
gives it for comparison.
"""

from __future__ import annotations

import math

import numpy as np

from core.errors import ParameterError

FORMS = ("2,1", "3,1")
MDC_Z = 1.96
"""The two-sided 95 % normal quantile of eq. (7)."""


def _table(measurements) -> np.ndarray:
    table = np.asarray(measurements, dtype=float)
    if table.ndim != 2 or table.shape[0] < 2 or table.shape[1] < 2:
        raise ParameterError("test-retest measurements", f"shape {table.shape}",
                             "a table of at least 2 people × 2 sessions")
    if not np.all(np.isfinite(table)):
        raise ParameterError("test-retest measurements", "a NaN or infinity",
                             "finite numbers")
    return table


def mean_squares(measurements) -> tuple[float, float, float]:
    """(MSR, MSC, MSE) of the n × k table (rows people, columns sessions)."""
    table = _table(measurements)
    n, k = table.shape
    grand = table.mean()
    ss_rows = k * float(np.sum((table.mean(axis=1) - grand) ** 2))
    ss_cols = n * float(np.sum((table.mean(axis=0) - grand) ** 2))
    ss_total = float(np.sum((table - grand) ** 2))
    ss_error = ss_total - ss_rows - ss_cols
    return ss_rows / (n - 1), ss_cols / (k - 1), max(ss_error, 0.0) / ((n - 1) * (k - 1))


def icc(measurements, form: str = "2,1") -> float:
    """Eq. (5) or (6)."""
    if form not in FORMS:
        raise ParameterError("ICC form", form, " | ".join(FORMS))
    table = _table(measurements)
    n, k = table.shape
    msr, msc, mse = mean_squares(table)
    if form == "2,1":
        denominator = msr + (k - 1) * mse + k * (msc - mse) / n
    else:
        denominator = msr + (k - 1) * mse
    if not denominator > 0.0:
        raise ParameterError("test-retest measurements", "no spread",
                             "measurements that vary between people or sessions")
    return (msr - mse) / denominator


def sem(measurements, form: str = "2,1") -> float:
    """Eq. (7)'s standard error of measurement; a negative ICC counts as 0 (SEM = SD)."""
    table = _table(measurements)
    sd = float(np.std(table, ddof=1))
    return sd * math.sqrt(1.0 - max(icc(table, form), 0.0))


def mdc95(measurements, form: str = "2,1") -> float:
    """Eq. (7): the smallest change beyond measurement error with 95 % confidence."""
    return MDC_Z * math.sqrt(2.0) * sem(measurements, form)


def is_real_change(before: float, after: float, mdc: float) -> bool:
    """True when |after − before| exceeds the MDC95 (a change of exactly the MDC is not)."""
    for name, value in (("before", before), ("after", after), ("MDC95", mdc)):
        if not math.isfinite(value):
            raise ParameterError(name, value, "a finite number")
    if mdc < 0.0:
        raise ParameterError("MDC95", mdc, "0 or more")
    return abs(after - before) > mdc
