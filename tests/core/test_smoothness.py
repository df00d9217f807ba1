"""SPARC and LDLJ against closed forms derived from their definitions."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from core.errors import ParameterError
from core.smoothness import SPARC_AMPLITUDE_THRESHOLD, ldlj, sparc

DT = 0.002


def _min_jerk_speed(t, duration_s, distance_m):
    u = np.clip(t / duration_s, 0.0, 1.0)
    return distance_m / duration_s * 30.0 * u**2 * (1.0 - u) ** 2


def _gaussian(sigma_s, span=12.0):
    t = np.arange(-span * sigma_s, span * sigma_s, DT)
    return np.exp(-t * t / (2 * sigma_s * sigma_s))


def test_sparc_of_a_gaussian_speed_profile():
    """|V(f)| of a Gaussian is the Gaussian exp(−2π²σ²f²). Normalised, it falls to
    the threshold a at f_c with (f/f_c)² = ln(1/a)/…, so on x = f/f_c it is
    V̂(x) = exp(−ln(1/a)·x²) whatever σ, and SPARC = −∫₀¹ √(1 + V̂'(x)²) dx."""
    k = math.log(1.0 / SPARC_AMPLITUDE_THRESHOLD)
    expected = -quad(lambda x: math.sqrt(1.0 + (2 * k * x * math.exp(-k * x * x)) ** 2), 0, 1)[0]
    assert expected == pytest.approx(-1.41, abs=0.01)  # the value quoted in the literature
    for sigma in (0.05, 0.1, 0.2):
        assert sparc(_gaussian(sigma), DT) == pytest.approx(expected, abs=2e-3)


def test_sparc_is_independent_of_amplitude_duration_and_rest():
    t = np.arange(0.0, 1.0, DT)
    reference = sparc(_min_jerk_speed(t, 1.0, 0.2), DT)
    assert sparc(3.0 * _min_jerk_speed(t, 1.0, 0.2), DT) == pytest.approx(reference, abs=1e-9)
    rested = np.concatenate((np.zeros(300), _min_jerk_speed(t, 1.0, 0.2), np.zeros(700)))
    assert sparc(rested, DT) == pytest.approx(reference, abs=5e-3)
    slow = np.arange(0.0, 2.0, DT)
    assert sparc(_min_jerk_speed(slow, 2.0, 0.2), DT) == pytest.approx(reference, abs=5e-3)


def test_smoother_profiles_score_higher():
    t = np.arange(0.0, 2.0, DT)
    smooth = _min_jerk_speed(t, 2.0, 0.2)
    # the same distance in two sub-movements, and one with a 6 Hz tremor
    two = _min_jerk_speed(t, 1.1, 0.1) + _min_jerk_speed(t - 0.9, 1.1, 0.1)
    tremor = smooth * (1.0 + 0.2 * np.sin(2 * math.pi * 6.0 * t))
    for jerky in (two, tremor):
        assert sparc(smooth, DT) > sparc(jerky, DT)
        assert ldlj(smooth, DT) > ldlj(jerky, DT)


def test_ldlj_of_a_minimum_jerk_reach():
    """v(u) = (A/T)·30u²(1−u)²: v_peak = v(½), d²v/dt² = (A/T³)·p''(u) with
    p = 30u²(1−u)², so DLJ = T³/v_peak²·∫|d²v/dt²|²dt = ∫₀¹ p''(u)² du / p(½)²."""
    p = np.polynomial.Polynomial([0, 0, 30, -60, 30])
    integral = (p.deriv(2) ** 2).integ()(1.0)
    expected = -math.log(integral / p(0.5) ** 2)
    for duration_s, distance_m in ((1.0, 0.2), (0.6, 0.05), (2.0, 0.3)):
        t = np.linspace(0.0, duration_s, round(duration_s / DT) + 1)
        speed = _min_jerk_speed(t, duration_s, distance_m)
        assert ldlj(speed, DT) == pytest.approx(expected, abs=1e-3)
        # along a straight line the vector form is the speed form
        direction = np.array([math.cos(0.7), math.sin(0.7)])
        assert ldlj(speed[:, None] * direction, DT) == pytest.approx(expected, abs=1e-3)


def test_ldlj_of_a_circle_at_constant_speed():
    """v(t) turns at ω: |d²v/dt²| = ω²|v|, so DLJ = T³/v²·ω⁴v²T = (ωT)⁴."""
    for turns, period_s in ((1.0, 4.0), (0.5, 2.0)):
        w = 2 * math.pi / period_s
        t = np.arange(0.0, turns * period_s + DT / 2, DT)
        velocity = 0.15 * np.column_stack((-np.sin(w * t), np.cos(w * t)))
        duration_s = t[-1] - t[0]
        assert ldlj(velocity, DT) == pytest.approx(-4 * math.log(w * duration_s), abs=1e-4)
        assert ldlj(np.hypot(*velocity.T), DT) > 30.0  # the speed form sees no jerk
    assert ldlj(np.full(100, 0.25), DT) == math.inf  # exactly no jerk


def test_no_movement_and_bad_inputs():
    assert math.isnan(sparc(np.zeros(100), DT))
    assert math.isnan(ldlj(np.zeros(100), DT))
    speed = _min_jerk_speed(np.arange(0.0, 1.0, DT), 1.0, 0.2)
    for kwargs, field in (
        ({"cutoff_hz": 300.0}, "cutoff_hz"),
        ({"amplitude_threshold": 0.0}, "amplitude_threshold"),
        ({"pad_level": -1}, "pad_level"),
    ):
        with pytest.raises(ParameterError) as info:
            sparc(speed, DT, **kwargs)
        assert info.value.field == field
    bad = speed.copy()
    bad[10] = np.nan
    with pytest.raises(ParameterError, match="sample 10") as info:
        sparc(bad, DT)
    assert info.value.field == "speed_m_s"
    with pytest.raises(ParameterError) as info:
        ldlj(bad, DT)
    assert info.value.field == "velocity"
    with pytest.raises(ParameterError) as info:
        ldlj(speed[:3], DT)
    assert info.value.field == "velocity"
