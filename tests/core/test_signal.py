"""Zero-lag Butterworth, smoothed derivatives and the per-tick rate estimator."""

import math

import numpy as np
import pytest
from scipy import signal as sps

from core.errors import ParameterError
from core.signal import (
    PAD_PERIODS,
    RateEstimator,
    as_series,
    butterworth_sos,
    lowpass,
    min_samples,
    sample_interval,
    second_difference,
    smoothed_derivatives,
)

DT = 0.002  # 500 Hz, the loop's rate
T = np.arange(0.0, 4.0, DT)
ENCODER_STEP_RAD = 2.0 * math.pi / 4000.0


def _interior(cutoff_hz):
    """Samples further than PAD_PERIODS cutoff periods from either end."""
    margin = math.ceil(PAD_PERIODS / (cutoff_hz * DT))
    return slice(margin, -margin)


def _complex_gain(t, output, reference_frequency_hz):
    """Least-squares amplitude and phase of a sinusoid of known frequency."""
    w = 2.0 * math.pi * reference_frequency_hz
    basis = np.column_stack((np.cos(w * t), np.sin(w * t)))
    (c, s), *_ = np.linalg.lstsq(basis, output, rcond=None)
    return complex(c, -s)  # output = Re(G e^{jwt})


# ------------------------------------------------------------------ lowpass
def test_no_phase_shift_well_below_the_cutoff():
    cutoff = 10.0
    for f in (0.5, 1.0, 2.0):
        x = np.sin(2 * math.pi * f * T + 0.3)
        y = lowpass(x, DT, cutoff)
        inner = _interior(cutoff)
        gain = _complex_gain(T[inner], y[inner], f) / _complex_gain(T[inner], x[inner], f)
        assert abs(np.angle(gain)) < 1e-6
        assert abs(gain) == pytest.approx(1.0 / (1.0 + (f / cutoff) ** 8), abs=1e-6)


def test_gain_is_the_single_pass_response_squared():
    """|H|² = 1 / (1 + (w(f)/w(fc))^(2n)), w = tan(π f dt): 1/2 at the cutoff,
    tiny well above it."""
    cutoff, order = 10.0, 4
    for f in (cutoff, 2 * cutoff, 5 * cutoff):
        x = np.sin(2 * math.pi * f * T)
        y = lowpass(x, DT, cutoff, order)
        inner = _interior(cutoff)
        warped = math.tan(math.pi * f * DT) / math.tan(math.pi * cutoff * DT)
        expected = 1.0 / (1.0 + warped ** (2 * order))
        measured = abs(_complex_gain(T[inner], y[inner], f))
        assert measured == pytest.approx(expected, rel=2e-2, abs=1e-7)
    # a causal single pass of the same filter lags; the forward-backward one does not
    x = np.sin(2 * math.pi * 2.0 * T)
    causal = sps.sosfilt(butterworth_sos(DT, cutoff, order), x)
    inner = _interior(cutoff)
    assert np.angle(_complex_gain(T[inner], causal[inner], 2.0)) < -0.1


def test_polynomials_below_twice_the_order_pass_unchanged():
    poly = np.polynomial.Polynomial([0.1, -0.3, 0.5, 0.7])
    x = poly(T)
    y = lowpass(x, DT, 10.0, order=4)
    inner = _interior(10.0)
    np.testing.assert_allclose(y[inner], x[inner], atol=1e-4 * np.abs(x).max())


def test_input_is_left_untouched_and_channels_are_independent():
    x = np.column_stack((np.sin(2 * math.pi * T), np.cos(2 * math.pi * 3 * T)))
    kept = x.copy()
    y = lowpass(x, DT, 8.0)
    np.testing.assert_array_equal(x, kept)
    np.testing.assert_allclose(y[:, 0], lowpass(x[:, 0], DT, 8.0), atol=1e-12)
    np.testing.assert_allclose(y[:, 1], lowpass(x[:, 1], DT, 8.0), atol=1e-12)


def test_nan_is_refused_by_default_and_named():
    x = np.sin(T)
    x[123] = np.nan
    with pytest.raises(ParameterError, match=r"torque_Nm = 'NaN at sample 123'") as info:
        lowpass(x, DT, 10.0, name="torque_Nm")
    assert info.value.field == "torque_Nm"
    x[123] = np.inf
    with pytest.raises(ParameterError, match="infinite"):
        lowpass(x, DT, 10.0, nan_policy="interpolate")


def test_nan_interpolated_then_restored():
    x = np.sin(2 * math.pi * 0.5 * T)
    gappy = x.copy()
    gappy[1000:1005] = np.nan
    gappy[:3] = np.nan  # leading gap: held at the first finite value
    y = lowpass(gappy, DT, 10.0, nan_policy="interpolate")
    assert np.isnan(y[1000:1005]).all()
    assert np.isnan(y[:3]).all()
    finite = ~np.isnan(gappy)
    assert np.isfinite(y[finite]).all()
    inner = np.zeros(T.size, bool)
    inner[_interior(10.0)] = True
    np.testing.assert_allclose(y[finite & inner], x[finite & inner], atol=1e-4)
    with pytest.raises(ParameterError, match="all NaN"):
        lowpass(np.full(100, np.nan), DT, 10.0, nan_policy="interpolate")


def test_cutoff_must_lie_below_nyquist():
    x = np.sin(T)
    for bad in (250.0, 300.0, 0.0, -1.0, math.nan):
        with pytest.raises(ParameterError) as info:
            lowpass(x, DT, bad)
        assert info.value.field == "cutoff_hz"
    with pytest.raises(ParameterError, match=r"allowed: \(0, 250\) Hz"):
        lowpass(x, DT, 250.0)
    assert np.isfinite(lowpass(x, DT, 249.0)).all()


def test_too_short_signals_are_refused_with_the_minimum_length():
    for order in (1, 2, 3, 4, 5):
        shortest = min_samples(order)
        ok = np.linspace(0.0, 1.0, shortest)
        assert lowpass(ok, DT, 10.0, order).shape == ok.shape
        with pytest.raises(ParameterError, match=f"at least {shortest} samples") as info:
            lowpass(ok[:-1], DT, 10.0, order, name="force_N")
        assert info.value.field == "force_N"


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"dt_s": 0.0}, "dt_s"),
        ({"dt_s": -0.002}, "dt_s"),
        ({"order": 0}, "order"),
        ({"order": 9}, "order"),
        ({"order": 2.0}, "order"),
        ({"nan_policy": "drop"}, "nan_policy"),
    ],
)
def test_bad_filter_parameters_name_their_field(kwargs, field):
    arguments = {"dt_s": DT, "cutoff_hz": 10.0, "order": 4, "nan_policy": "raise"}
    arguments.update(kwargs)
    with pytest.raises(ParameterError) as info:
        lowpass(np.sin(T), **arguments)
    assert info.value.field == field


# ------------------------------------------------------------------ derivatives
def test_derivatives_of_a_sine():
    f = 2.0
    w = 2 * math.pi * f
    d = smoothed_derivatives(np.sin(w * T), DT, 10.0)
    inner = _interior(10.0)
    # central differences are low by sin(w·h)/(w·h); the filter by |H|² at f
    bias = 1.0 - math.sin(w * DT) / (w * DT) + (f / 10.0) ** 8
    np.testing.assert_allclose(d.rate[inner], w * np.cos(w * T[inner]), atol=w * (bias + 1e-4))
    np.testing.assert_allclose(
        d.acceleration[inner], -w * w * np.sin(w * T[inner]), atol=w * w * (2 * bias + 1e-4)
    )


def test_derivatives_of_a_cubic_without_filtering_are_exact_to_the_stencil_error():
    poly = np.polynomial.Polynomial([0.1, -0.3, 0.5, 0.7])
    d = smoothed_derivatives(poly(T), DT, None)
    third = poly.deriv(3)(0.0)
    # central difference error h²/6·f''' inside, one-sided (edge_order 2) h²/3·f'''
    np.testing.assert_allclose(d.rate, poly.deriv()(T), atol=third * DT * DT / 3 * 1.001)
    np.testing.assert_allclose(d.acceleration, poly.deriv(2)(T), atol=1e-6)
    np.testing.assert_array_equal(d.value, poly(T))


def test_filtered_derivatives_of_a_cubic_inside():
    poly = np.polynomial.Polynomial([0.1, -0.3, 0.5, 0.7])
    d = smoothed_derivatives(poly(T), DT, 10.0)
    inner = _interior(10.0)
    scale = np.abs(poly.deriv()(T)).max()
    np.testing.assert_allclose(d.rate[inner], poly.deriv()(T[inner]), atol=1e-5 * scale)
    np.testing.assert_allclose(
        d.acceleration[inner], poly.deriv(2)(T[inner]), atol=1e-3 * np.abs(poly.deriv(2)(T)).max()
    )


def test_derivatives_keep_nan_where_the_input_had_it():
    x = np.column_stack((np.sin(T), np.cos(T)))
    x[500, 1] = np.nan
    d = smoothed_derivatives(x, DT, 10.0, nan_policy="interpolate")
    for array in (d.value, d.rate, d.acceleration):
        assert np.isnan(array[500, 1])
        assert np.isfinite(array[500, 0])
        assert np.isfinite(np.delete(array, 500, axis=0)).all()
    with pytest.raises(ParameterError, match="NaN at sample 500"):
        smoothed_derivatives(x, DT, None)


def test_second_difference_sees_the_nyquist_frequency():
    alternating = (-1.0) ** np.arange(20)
    assert np.abs(second_difference(alternating, DT)[1:-1]).min() == pytest.approx(4 / DT**2)


# ------------------------------------------------------------------ recordings
def test_sample_interval_and_series_checks():
    assert sample_interval(T) == pytest.approx(DT)
    jitter = T.copy()
    jitter[100] += 0.0015  # one late tick
    assert sample_interval(jitter) == pytest.approx(DT)
    for bad, words in (
        (T[::-1], "not increasing"),
        (np.r_[T[:10], T[10:] + 1.0], "gap"),
        (np.r_[T[:5], np.nan], "not finite"),
        (T[:1], "at least 2"),
    ):
        with pytest.raises(ParameterError, match=words) as info:
            sample_interval(bad)
        assert info.value.field == "t_s"
    with pytest.raises(ParameterError, match=r"shape \(5, 2\)") as info:
        as_series("force_N", np.zeros((4, 2)), 5, 2)
    assert info.value.field == "force_N"


# ------------------------------------------------------------------ rate estimator
def _tracker_model(dt_s, cutoff_hz):
    """The documented α-β-γ tracker as a state-space model, built from its
    equations: state after tick k = A·(state before) + K·angle_k."""
    xi = math.exp(-2 * math.pi * cutoff_hz * dt_s)
    alpha, beta, gamma = 1 - xi**3, 1.5 * (1 - xi) ** 2 * (1 + xi), 0.5 * (1 - xi) ** 3
    predict = np.array([[1, dt_s, dt_s * dt_s / 2], [0, 1, dt_s], [0, 0, 1]])
    gain = np.array([[alpha], [beta / dt_s], [2 * gamma / dt_s**2]])
    a = (np.eye(3) - gain @ np.array([[1.0, 0.0, 0.0]])) @ predict
    return a, gain, xi


def _run(estimator, angles):
    return np.array([estimator.update(float(a)) for a in angles])


def _l1_gain(dt_s, cutoff_hz, row):
    a, gain, _ = _tracker_model(dt_s, cutoff_hz)
    impulse = np.zeros(6000)
    impulse[0] = 1.0
    _, response, _ = sps.dlsim(sps.dlti(a, gain, a, gain, dt=dt_s), impulse)
    return float(np.abs(response[:, row]).sum())


def test_estimator_is_the_documented_tracker():
    rng = np.random.default_rng(1)
    angles = np.cumsum(rng.normal(0, 0.01, 400))
    a, gain, xi = _tracker_model(DT, 20.0)
    np.testing.assert_allclose(np.linalg.eigvals(a), xi, atol=1e-4)  # triple pole at ξ
    _, model, _ = sps.dlsim(
        sps.dlti(a, gain, a, gain, dt=DT), angles[1:], x0=[angles[0], 0.0, 0.0]
    )
    out = _run(RateEstimator(DT, 20.0), angles)
    np.testing.assert_array_equal(out[0], [0.0, 0.0])
    np.testing.assert_allclose(out[1:], model[:, 1:], rtol=1e-9, atol=1e-9)


def test_constant_acceleration_is_tracked_without_lag():
    estimator = RateEstimator(DT, 20.0)
    tau = 1.0 / (2 * math.pi * 20.0)
    t = np.arange(0.0, 0.5, DT)
    out = _run(estimator, 0.1 + 0.5 * t + 1.5 * t * t)
    settled = t >= 25 * tau  # triple-pole transient (t/τ)² e^(−t/τ) has died out
    np.testing.assert_allclose(out[settled, 0], 0.5 + 3.0 * t[settled], atol=3e-6)
    np.testing.assert_allclose(out[settled, 1], 3.0, atol=3e-6)
    assert isinstance(out[0, 0], float)


@pytest.mark.parametrize("cutoff_hz", [10.0, 20.0])
@pytest.mark.parametrize("rate", [0.2, 0.8, 2.0])
def test_quantised_ramp_rate_within_the_quantisation_bound(cutoff_hz, rate):
    t = np.arange(0.0, 3.0, DT)
    angles = np.round((0.3 + rate * t) / ENCODER_STEP_RAD) * ENCODER_STEP_RAD
    out = _run(RateEstimator(DT, cutoff_hz), angles)
    settled = t >= 0.3
    error = out[settled, 0] - rate
    # a measurement error of at most q/2 moves the rate by at most (q/2)·‖h_v‖₁
    bound = 0.5 * ENCODER_STEP_RAD * _l1_gain(DT, cutoff_hz, 1)
    assert np.abs(error).max() <= bound
    raw = np.diff(angles)[settled[1:]] / DT - rate
    assert np.sqrt(np.mean(error**2)) < np.sqrt(np.mean(raw**2))
    if rate == 0.2:  # no aliasing of the count rate onto the tick rate: far better than raw
        assert np.sqrt(np.mean(error**2)) < 0.1 * np.sqrt(np.mean(raw**2))
    accel_bound = 0.5 * ENCODER_STEP_RAD * _l1_gain(DT, cutoff_hz, 2)
    assert np.abs(out[settled, 1]).max() <= accel_bound


def test_documented_bound_at_20_hz():
    bound = 0.5 * ENCODER_STEP_RAD * _l1_gain(DT, 20.0, 1)
    assert bound <= 0.17
    assert _l1_gain(DT, 20.0, 1) == pytest.approx(10.7 * 20.0, rel=0.02)


@pytest.mark.parametrize("cutoff_hz", [10.0, 20.0])
def test_quantised_sine_rate_within_stated_bounds(cutoff_hz):
    f, amplitude = 1.0, 0.5
    w = 2 * math.pi * f
    t = np.arange(0.0, 4.0, DT)
    angles = np.round(amplitude * np.sin(w * t) / ENCODER_STEP_RAD) * ENCODER_STEP_RAD
    out = _run(RateEstimator(DT, cutoff_hz), angles)
    settled = t >= 0.5
    bound = (3 * (f / cutoff_hz) ** 2 * amplitude * w
             + 0.5 * ENCODER_STEP_RAD * _l1_gain(DT, cutoff_hz, 1))
    assert np.abs(out[settled, 0] - amplitude * w * np.cos(w * t[settled])).max() <= bound


@pytest.mark.parametrize(("f", "cutoff_hz"), [(1.0, 20.0), (2.0, 10.0), (5.0, 20.0)])
def test_rate_gain_and_acceleration_lag_as_documented(f, cutoff_hz):
    w = 2 * math.pi * f
    t = np.arange(0.0, 4.0, DT)
    out = _run(RateEstimator(DT, cutoff_hz), np.sin(w * t))
    s = t >= 1.0
    rate_gain = _complex_gain(t[s], out[s, 0], f) / w  # true rate: w·cos
    assert abs(rate_gain - 1.0) <= 3 * (f / cutoff_hz) ** 2
    assert -8 * (f / cutoff_hz) ** 3 <= np.angle(rate_gain) <= 0.0  # lag only third order
    acc_gain = _complex_gain(t[s], out[s, 1], f) / (w * w * 1j)  # true: −w²·sin = Re(jw²e^{jwt})
    delay_s = -np.angle(acc_gain) / w
    assert delay_s == pytest.approx(3 / (2 * math.pi * cutoff_hz), abs=DT)


def test_reset_and_bad_parameters():
    estimator = RateEstimator(DT, 20.0)
    estimator.update(1.0)
    estimator.update(1.01)
    estimator.reset(2.0, rate=0.5)
    rate, _ = estimator.update(2.0 + 0.5 * DT)
    assert rate == pytest.approx(0.5)
    estimator.reset()
    assert estimator.update(5.0) == (0.0, 0.0)
    for cutoff in (0.0, 250.0, math.nan):
        with pytest.raises(ParameterError) as info:
            RateEstimator(DT, cutoff)
        assert info.value.field == "cutoff_hz"
    with pytest.raises(ParameterError) as info:
        RateEstimator(0.0, 20.0)
    assert info.value.field == "dt_s"
    alpha, beta, gamma = RateEstimator(DT, 20.0).gains
    xi = math.exp(-2 * math.pi * 20.0 * DT)
    assert (alpha, beta, gamma) == pytest.approx(
        (1 - xi**3, 1.5 * (1 - xi) ** 2 * (1 + xi), 0.5 * (1 - xi) ** 3)
    )
