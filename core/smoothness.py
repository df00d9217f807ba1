"""Movement smoothness: spectral arc length (SPARC) and log dimensionless jerk (LDLJ).

Both follow Balasubramanian, Melendez-Calderon, Roby-Brami & Burdet, "On the
analysis of movement smoothness", J NeuroEng Rehabil 12:112 (2015), which
recommends them as the two valid, dimensionless smoothness measures; SPARC
first appeared in Balasubramanian et al., IEEE TBME 59(8) (2012). Both are
negative, and the closer to zero the smoother.

SPARC is meant for discrete movements (one reach). On a whole rhythmic trial it
still ranks smoothness but its value is not comparable with reach values.
"""

from __future__ import annotations

import math

import numpy as np

from core.errors import ParameterError, check_positive, check_range
from core.signal import second_difference

SPARC_AMPLITUDE_THRESHOLD = 0.05
SPARC_CUTOFF_HZ = 10.0
SPARC_PAD_LEVEL = 4


def sparc(
    speed_m_s,
    dt_s: float,
    *,
    cutoff_hz: float = SPARC_CUTOFF_HZ,
    amplitude_threshold: float = SPARC_AMPLITUDE_THRESHOLD,
    pad_level: int = SPARC_PAD_LEVEL,
) -> float:
    """Spectral arc length of a speed profile (Balasubramanian et al. 2015).

        SPARC = −∫₀^ω_c √( (1/ω_c)² + (dV̂/dω)² ) dω,   V̂(ω) = |V(ω)| / |V(0)|

    V is the Fourier magnitude of the speed, zero-padded to
    2^(⌈log₂ N⌉ + pad_level) points so the spectrum is finely sampled; zero
    padding changes nothing else, so rest before or after a movement does not
    change its SPARC. The upper limit is adaptive: ω_c is the highest frequency
    at or below `cutoff_hz` (10 Hz, above human voluntary movement) where V̂ is
    still at least `amplitude_threshold` (0.05), and the arc runs over the bins
    from the first to the last one at or above the threshold, with frequency
    normalised by the band's width, as in the authors' reference code.

    The arc length is computed on the discrete spectrum as the sum of
    √(Δf̂² + ΔV̂²). Independent of the amplitude and the duration of the
    movement. Returns NaN for a profile that is zero everywhere (no movement).
    """
    speed = _profile("speed_m_s", speed_m_s)
    dt_s = _check_options(dt_s, cutoff_hz, amplitude_threshold, pad_level)
    n_fft = 2 ** (math.ceil(math.log2(speed.size)) + pad_level)
    magnitude = np.abs(np.fft.rfft(speed, n_fft))
    peak = magnitude.max()
    if peak == 0.0:
        return math.nan
    freq_hz = np.fft.rfftfreq(n_fft, dt_s)
    band = freq_hz <= cutoff_hz
    return _spectral_arc(freq_hz[band], magnitude[band], peak, amplitude_threshold)


def _check_options(dt_s, cutoff_hz, amplitude_threshold, pad_level) -> float:
    dt_s = check_positive("dt_s", dt_s, "s")
    check_range("cutoff_hz", cutoff_hz, 0.0, 0.5 / dt_s, "Hz",
                "the spectrum ends at the Nyquist frequency", low_open=True)
    check_range("amplitude_threshold", amplitude_threshold, 0.0, 1.0, low_open=True)
    if isinstance(pad_level, bool) or not isinstance(pad_level, int) or not 0 <= pad_level <= 8:
        raise ParameterError("pad_level", pad_level, "an integer in [0, 8]")
    return dt_s


def _spectral_arc(freq_hz: np.ndarray, magnitude: np.ndarray, peak: float,
                  amplitude_threshold: float, chunk: int | None = None) -> float:
    """SPARC's arc (`sparc`) on the band's spectrum V̂ = magnitude / peak: from the first to
    the last bin at or above the threshold, −Σ √(Δf̂² + ΔV̂²), frequency normalised by
    that stretch's width. `chunk` works that many bins at a time (a long trial's band has
    millions; the sum then differs from the one-piece sum by rounding)."""
    step = chunk or len(magnitude)
    first = last = -1
    for a in range(0, len(magnitude), step):
        above = np.flatnonzero(magnitude[a:a + step] / peak >= amplitude_threshold)
        if len(above):
            first = a + int(above[0]) if first < 0 else first
            last = a + int(above[-1])
    if last == first:
        return math.nan
    width = freq_hz[last] - freq_hz[first]
    step = chunk or (last - first + 1)
    total = 0.0
    for a in range(first, last, step):
        b = min(last + 1, a + step + 1)  # one bin shared with the next stretch
        df = np.diff(freq_hz[a:b]) / width
        total += float(np.sum(np.hypot(df, np.diff(magnitude[a:b] / peak))))
    return -total


FOLD = 2**18
"""Spectrum bins computed at once by `sparc_of_blocks` (4 MiB of complex numbers)."""


def sparc_of_blocks(
    blocks,
    n_samples: int,
    dt_s: float,
    *,
    cutoff_hz: float = SPARC_CUTOFF_HZ,
    amplitude_threshold: float = SPARC_AMPLITUDE_THRESHOLD,
    pad_level: int = SPARC_PAD_LEVEL,
    fold: int | None = None,
) -> float:
    """`sparc` of a speed profile of `n_samples` that is never held whole: `blocks()` gives
    its samples in order, a block at a time, each time it is called.

    The spectrum in the band is accumulated without the signal: with N the padded length
    and P = N / `fold`, bin P·m + c of the N-point transform is bin m of the `fold`-point
    transform of the signal modulated by e^(−2πi·c·n/N) and folded modulo `fold` (the
    transform's kernel repeats every `fold` samples), one pass over the blocks for each c
    (`fold` None: FOLD).
    The speed must not be negative (it is a speed): then the spectrum's peak is its bin 0,
    which lies in the band. Equal to `sparc` to rounding (the transforms' order of sums)."""
    dt_s = _check_options(dt_s, cutoff_hz, amplitude_threshold, pad_level)
    if n_samples < 2:
        raise ParameterError("speed_m_s", f"{n_samples} samples", "at least 2 samples")
    n_fft = 2 ** (math.ceil(math.log2(n_samples)) + pad_level)
    step_hz = 1.0 / (n_fft * dt_s)  # np.fft.rfftfreq's
    bins = min(n_fft // 2 + 1, int(cutoff_hz / step_hz) + 2)
    while bins and (bins - 1) * step_hz > cutoff_hz:
        bins -= 1
    size = min(fold or FOLD, n_fft)
    passes = n_fft // size
    magnitude = np.empty(bins)
    for c in range(passes):
        folded = np.zeros(size, dtype=complex)
        start = 0
        ramp = None  # e^(−2πi·c·j/N) for j within a block
        for block in blocks():
            values = np.asarray(block, dtype=float)
            if not (np.isfinite(values).all() and (values >= 0.0).all()):
                raise ParameterError("speed_m_s", "a negative or non-finite sample",
                                     "a speed: finite, ≥ 0")
            if ramp is None or len(ramp) < len(values):
                ramp = np.exp(-2j * math.pi * (c * np.arange(len(values)) / n_fft))
            turn = (c * start) % n_fft  # the block's first sample: whole turns dropped
            modulated = values * (ramp[:len(values)] * np.exp(-2j * math.pi * turn / n_fft))
            at = start % size
            while len(modulated):
                take = min(len(modulated), size - at)
                folded[at:at + take] += modulated[:take]
                modulated = modulated[take:]
                at = 0
            start += len(values)
        if start != n_samples:
            raise ParameterError("blocks", f"{start} samples", f"{n_samples} samples")
        taken = magnitude[c::passes]
        taken[:] = np.abs(np.fft.fft(folded)[:len(taken)])
    peak = float(magnitude[0])
    if peak == 0.0:
        return math.nan
    freq_hz = np.arange(bins) * step_hz
    return _spectral_arc(freq_hz, magnitude, peak, amplitude_threshold, chunk=1 << 16)


def ldlj(velocity, dt_s: float) -> float:
    """Log dimensionless jerk of a speed profile or a velocity (Balasubramanian
    et al. 2015; Hogan & Sternad 2009, J Mot Behav 41(6)):

        LDLJ = −ln( (t₂ − t₁)³ / v_peak² · ∫_{t₁}^{t₂} |d²v/dt²|² dt )

    over the whole profile given (t₂ − t₁ = (N − 1)·dt_s). `velocity` is either
    a speed profile, shape (N,), or velocity vectors, shape (N, k), in which case
    |d²v/dt²| is the norm of the jerk vector and v_peak the peak speed. The two
    agree for straight-line motion; the vector form is finite for a circle
    walked at constant speed, where the speed form is −ln 0.

    d²v/dt² is the three-point second difference (core.signal.second_difference)
    and the integral the trapezoidal rule, so pass a smoothed velocity.
    Returns NaN when the peak speed is zero and +inf when the jerk is exactly
    zero everywhere (constant or linearly changing velocity; rounding usually
    leaves a trace, giving a large finite value instead).
    """
    v = np.asarray(velocity, dtype=float)
    if v.ndim not in (1, 2):
        raise ParameterError("velocity", f"an array of shape {v.shape}", "shape (N,) or (N, k)")
    if v.shape[0] < 4:
        raise ParameterError("velocity", f"{v.shape[0]} samples", "at least 4 samples",
                             "the second difference needs 4 points")
    if not np.isfinite(v).all():
        raise ParameterError("velocity", "NaN or infinite samples", "finite numbers")
    dt_s = check_positive("dt_s", dt_s, "s")
    speed = np.abs(v) if v.ndim == 1 else np.linalg.norm(v, axis=1)
    peak = float(speed.max())
    if peak == 0.0:
        return math.nan
    jerk = second_difference(v, dt_s)
    squared = jerk * jerk if v.ndim == 1 else np.sum(jerk * jerk, axis=1)
    integral = float(np.trapezoid(squared, dx=dt_s))
    return ldlj_value((v.shape[0] - 1) * dt_s, peak, integral)


def ldlj_value(duration_s: float, peak: float, integral: float) -> float:
    """`ldlj` from its parts: −ln(duration³ / v_peak² · ∫|d²v/dt²|² dt); +inf for no jerk,
    NaN for no movement."""
    if peak == 0.0:
        return math.nan
    if integral == 0.0:
        return math.inf
    return -math.log(duration_s**3 / (peak * peak) * integral)


def _profile(name: str, value) -> np.ndarray:
    profile = np.asarray(value, dtype=float)
    if profile.ndim != 1:
        raise ParameterError(name, f"an array of shape {profile.shape}", "shape (N,)")
    if profile.size < 2:
        raise ParameterError(name, f"{profile.size} samples", "at least 2 samples")
    if not np.isfinite(profile).all():
        index = int(np.flatnonzero(~np.isfinite(profile))[0])
        raise ParameterError(name, f"not finite at sample {index}", "finite numbers")
    return profile
