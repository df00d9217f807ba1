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
    dt_s = check_positive("dt_s", dt_s, "s")
    nyquist_hz = 0.5 / dt_s
    check_range("cutoff_hz", cutoff_hz, 0.0, nyquist_hz, "Hz",
                "the spectrum ends at the Nyquist frequency", low_open=True)
    check_range("amplitude_threshold", amplitude_threshold, 0.0, 1.0, low_open=True)
    if isinstance(pad_level, bool) or not isinstance(pad_level, int) or not 0 <= pad_level <= 8:
        raise ParameterError("pad_level", pad_level, "an integer in [0, 8]")
    n_fft = 2 ** (math.ceil(math.log2(speed.size)) + pad_level)
    magnitude = np.abs(np.fft.rfft(speed, n_fft))
    peak = magnitude.max()
    if peak == 0.0:
        return math.nan
    freq_hz = np.fft.rfftfreq(n_fft, dt_s)
    band = freq_hz <= cutoff_hz
    freq_hz, spectrum = freq_hz[band], magnitude[band] / peak
    above = np.flatnonzero(spectrum >= amplitude_threshold)
    first, last = above[0], above[-1]
    if last == first:
        return math.nan
    freq_hz, spectrum = freq_hz[first:last + 1], spectrum[first:last + 1]
    df = np.diff(freq_hz) / (freq_hz[-1] - freq_hz[0])
    return -float(np.sum(np.hypot(df, np.diff(spectrum))))


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
    if integral == 0.0:
        return math.inf
    duration_s = (v.shape[0] - 1) * dt_s
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
