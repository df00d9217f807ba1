"""EMG cleaning, the RMS envelope, normalisation and the loop's time base, against truth
and against pyemgpipeline 1.0.0."""

import math

import numpy as np
import pytest
from pyemgpipeline.processors import BandpassFilter, FullWaveRectifier, LinearEnvelope
from scipy import signal as sps

from core.emg.processing import (
    EmgSettings,
    Envelope,
    bandpass,
    clean,
    envelope,
    linear_envelope,
    normalise,
    notch,
    on_time_base,
    rectify,
    rms_envelope,
    window_samples,
)
from core.errors import ParameterError

FS = 2000.0


def _noise(n, seed=0, width=None, band=(20.0, 450.0)):
    rng = np.random.default_rng(seed)
    shape = (n,) if width is None else (n, width)
    sos = sps.butter(4, band, btype="bandpass", output="sos", fs=FS)
    x = sps.sosfilt(sos, rng.standard_normal(shape), axis=0)
    return x / x.std(axis=0)


def _gain(y, x, f, t):
    w = 2 * math.pi * f
    basis = np.column_stack((np.cos(w * t), np.sin(w * t)))
    cy = np.linalg.lstsq(basis, y, rcond=None)[0]
    cx = np.linalg.lstsq(basis, x, rcond=None)[0]
    return np.hypot(*cy) / np.hypot(*cx)


# ------------------------------------------------------------------ filters
def test_bandpass_passes_the_band_and_stops_drift_and_high_frequencies():
    t = np.arange(0, 4.0, 1 / FS)
    inner = slice(2000, -2000)
    for f, low, high in ((100.0, 0.95, 1.01), (2.0, 0.0, 1e-4), (800.0, 0.0, 0.02)):
        x = np.sin(2 * math.pi * f * t)
        y = bandpass(x, FS, (20.0, 450.0), 4)
        assert low <= _gain(y[inner], x[inner], f, t[inner]) <= high


def test_notch_removes_the_mains_and_keeps_the_rest():
    t = np.arange(0, 6.0, 1 / FS)
    inner = slice(4000, -4000)
    mains = np.sin(2 * math.pi * 50.0 * t)
    tone = np.sin(2 * math.pi * 80.0 * t)
    y = notch(mains + tone, FS, 50.0, 30.0)
    assert _gain(y[inner], mains[inner], 50.0, t[inner]) < 1e-3
    assert _gain(y[inner], tone[inner], 80.0, t[inner]) == pytest.approx(1.0, abs=0.01)


def test_clean_removes_offset_drift_and_mains_from_emg():
    x = 1e-3 * _noise(20000)
    t = np.arange(x.size) / FS
    dirty = x + 0.02 + 5e-3 * np.sin(2 * math.pi * 0.5 * t) + 2e-4 * np.sin(2 * math.pi * 60 * t)
    y = clean(dirty, FS, EmgSettings(mains_hz=60.0))
    inner = slice(2000, -2000)
    error = y[inner] - notch(bandpass(x, FS), FS, 60.0)[inner]
    assert np.sqrt(np.mean(error**2)) < 1e-3 * 1e-3


def test_bandpass_matches_pyemgpipeline():
    """pyemgpipeline's order is the effective (two-pass) order: its 4 is our 2."""
    x = _noise(8000, seed=3, band=(1.0, 900.0))
    ours = bandpass(x, FS, (20.0, 450.0), order=2)
    theirs = BandpassFilter(FS, bf_order=4, bf_cutoff_fq_lo=20, bf_cutoff_fq_hi=450).apply(x)
    inner = slice(1000, -1000)  # the padding differs at the ends
    np.testing.assert_allclose(ours[inner], theirs[inner], atol=1e-6 * np.abs(x).max())


def test_linear_envelope_matches_pyemgpipeline():
    x = _noise(8000, seed=4) * (1.0 + 0.8 * np.sin(2 * math.pi * 0.7 * np.arange(8000) / FS))
    ours = linear_envelope(x, FS, cutoff_hz=6.0, order=2)
    rectified = FullWaveRectifier().apply(x)
    np.testing.assert_array_equal(rectified, rectify(x))
    theirs = LinearEnvelope(FS, le_order=4, le_cutoff_fq=6).apply(rectified)
    inner = slice(1500, -1500)
    np.testing.assert_allclose(ours[inner], theirs[inner], atol=1e-4 * ours.max())


def test_rms_envelope_agrees_with_pyemgpipelines_linear_envelope():
    """Two envelopes of one amplitude-modulated noise: for Gaussian noise RMS = √(π/2)·mean|x|,
    so the RMS envelope is pyemgpipeline's linear envelope × √(π/2) up to their smoothing."""
    n = 40000
    t = np.arange(n) / FS
    amplitude = 1e-3 * (1.0 + 0.7 * np.sin(2 * math.pi * 0.3 * t))
    x = amplitude * _noise(n, seed=5)
    ours = rms_envelope(x, FS)
    theirs = LinearEnvelope(FS, le_order=4, le_cutoff_fq=2).apply(FullWaveRectifier().apply(x))
    at = np.interp(ours.t_s, t, theirs) * math.sqrt(math.pi / 2)
    inner = (ours.t_s > 1.0) & (ours.t_s < t[-1] - 1.0)
    relative = (ours.values[inner] - at[inner]) / at[inner]
    assert np.sqrt(np.mean(relative**2)) < 0.12
    assert np.corrcoef(ours.values[inner], at[inner])[0, 1] > 0.9
    # and both follow the true amplitude
    true = np.interp(ours.t_s, t, amplitude)
    assert np.sqrt(np.mean(((ours.values - true) / true)[inner] ** 2)) < 0.12


# ------------------------------------------------------------------ RMS envelope
def test_rms_envelope_is_the_windowed_rms_with_the_thesis_window():
    x = _noise(1000, seed=1, width=3)
    env = rms_envelope(x, FS)  # 0.125 s = 250 samples, step 125
    assert window_samples(FS, 0.125, 0.0625) == (250, 125)
    expected = [np.sqrt(np.mean(x[k:k + 250] ** 2, axis=0)) for k in range(0, 751, 125)]
    np.testing.assert_allclose(env.values, np.array(expected), rtol=1e-12)
    np.testing.assert_allclose(env.t_s, (np.arange(7) * 125 + 124.5) / FS)
    assert np.diff(env.t_s) == pytest.approx(0.0625)


def test_rms_envelope_window_and_overlap_are_configurable():
    x = _noise(2000)
    env = rms_envelope(x, FS, window_s=0.05, overlap_s=0.0, t0_s=10.0)
    assert env.values.shape == (20,)
    assert env.t_s[0] == pytest.approx(10.0 + 49.5 / FS)
    assert rms_envelope(x, FS, 0.2, 0.15).values.shape == (1 + (2000 - 400) // 100,)


def test_rms_of_a_sine_is_its_amplitude_over_root_two():
    t = np.arange(0, 2.0, 1 / FS)
    env = rms_envelope(3e-3 * np.sin(2 * math.pi * 80 * t), FS, 0.125, 0.0625)
    np.testing.assert_allclose(env.values, 3e-3 / math.sqrt(2), rtol=1e-3)


def test_envelope_chain_tracks_a_known_amplitude():
    n = 60000
    t = np.arange(n) / FS
    amplitude = 5e-4 + 4e-4 * (np.sin(2 * math.pi * 0.25 * t) > 0)
    x = amplitude * _noise(n, seed=2, band=(40.0, 300.0)) + 2e-4 * np.sin(2 * math.pi * 50 * t)
    env = envelope(x, FS)
    # the envelope of each window is the RMS of the amplitude over that window
    true = rms_envelope(amplitude, FS).values
    error = (env.values - true) / true
    # unbiased; the spread is that of an RMS of 0.125 s of noise (about 1/√(2·B·T), 9 %)
    assert abs(error.mean()) < 0.02
    assert error.std() < 0.12


# ------------------------------------------------------------------ normalise, time base
def test_normalise_per_channel_and_refuses_a_missing_mvc():
    values = np.array([[1e-4, 2e-4], [3e-4, 4e-4]])
    np.testing.assert_allclose(normalise(values, [1e-3, 4e-4]), [[0.1, 0.5], [0.3, 1.0]])
    for bad in ([1e-3, 0.0], [1e-3, np.nan], [1e-3]):
        with pytest.raises(ParameterError, match="mvc"):
            normalise(values, bad)


def test_on_time_base_interpolates_onto_ticks_and_leaves_nan_outside():
    env = Envelope(np.array([0.0625, 0.125, 0.1875]), np.array([[0.0, 1.0], [1.0, 3.0],
                                                                 [2.0, 5.0]]))
    ticks = np.arange(0.0, 0.25, 0.002)
    out = on_time_base(env, ticks)
    assert out.shape == (ticks.size, 2)
    inside = (ticks >= 0.0625) & (ticks <= 0.1875)
    assert np.isnan(out[~inside]).all()
    assert np.isfinite(out[inside]).all()
    k = np.flatnonzero(np.isclose(ticks, 0.094))[0]
    np.testing.assert_allclose(out[k], [0.504, 2.008], rtol=1e-9)
    assert on_time_base(Envelope(env.t_s, env.values[:, 0]), ticks).shape == ticks.shape


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize(("kwargs", "field"), [
    ({"band_hz": (450.0, 20.0)}, "band_hz"),
    ({"band_hz": (0.0, 450.0)}, "band_hz"),
    ({"band_order": 0}, "band_order"),
    ({"mains_hz": -50.0}, "mains_hz"),
    ({"window_s": 0.0}, "window_s"),
    ({"overlap_s": 0.125}, "overlap_s"),
    ({"overlap_s": -0.01}, "overlap_s"),
])
def test_settings_refuse_bad_values(kwargs, field):
    with pytest.raises(ParameterError, match=field):
        EmgSettings(**kwargs)


def test_bad_signals_are_refused_with_their_reason():
    x = _noise(4000)
    with pytest.raises(ParameterError, match="Nyquist"):
        bandpass(x, 800.0)  # 450 Hz is above 400 Hz
    with pytest.raises(ParameterError, match="sampling_rate_hz"):
        clean(x, 0.0)
    y = x.copy()
    y[10] = np.nan
    with pytest.raises(ParameterError, match="not finite at sample 10"):
        clean(y, FS)
    with pytest.raises(ParameterError, match="one window"):
        rms_envelope(x[:100], FS)
    with pytest.raises(ParameterError, match="samples"):
        bandpass(x[:20], FS)
    with pytest.raises(ParameterError, match="shape"):
        rms_envelope(np.zeros((10, 2, 2)), FS)
    with pytest.raises(ParameterError, match="mains_hz"):
        notch(x, FS, 1500.0)
