"""Smoothing and differentiation of recorded signals, and a per-tick rate estimator.

Section 3.6.3 of the thesis shows joint torques made noisy by raw numerical
differentiation of encoder angles and suggests Butterworth filtering. This module
gives the three tools the console needs for that:

* `lowpass`: a zero-lag (forward–backward) Butterworth low-pass for whole
  recordings, for display and for metrics.
* `smoothed_derivatives`: that filter followed by central differences, giving a
  signal's smoothed value, rate and acceleration.
* `RateEstimator`: a causal tracker for the 2 ms loop, turning quantised encoder
  angles into rates and accelerations one tick at a time on plain floats.

Time runs along axis 0 of every array; the samples are taken as equally spaced
`dt_s` apart. Smoothing never modifies its input: callers keep the raw signal and
get new arrays back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError, check_positive
from core.kernels import kernel

NAN_POLICIES = ("raise", "interpolate")
ORDER_RANGE = (1, 8)
PAD_PERIODS = 3.0


# ------------------------------------------------------------------ zero-lag low-pass
def butterworth_sos(dt_s: float, cutoff_hz: float, order: int = 4) -> np.ndarray:
    """Second-order sections of a digital Butterworth low-pass (scipy.signal.butter).

    Refuses a cutoff at or above the Nyquist frequency 1/(2·dt_s), where a
    low-pass has no meaning, and orders outside ORDER_RANGE (higher orders ring
    and need long padding for no benefit on movement data).
    """
    from scipy.signal import butter  # imported on first use: 0.7 s at start-up otherwise

    dt_s = check_positive("dt_s", dt_s, "s")
    nyquist_hz = 0.5 / dt_s
    _check_cutoff(cutoff_hz, nyquist_hz)
    _check_order(order)
    return butter(order, cutoff_hz, btype="low", output="sos", fs=1.0 / dt_s)


def min_samples(order: int = 4) -> int:
    """The fewest samples `lowpass` accepts for a filter of `order`.

    The padding is never shorter than sosfiltfilt's default, 3·(2·sections + 1 − z)
    samples (z: sections whose last numerator and denominator taps are both
    zero, i.e. the first-order section of an odd order), and sosfiltfilt needs
    strictly more samples than its padding.
    """
    _check_order(order)
    from scipy.signal import butter

    sos = butter(order, 0.25, output="sos")
    return _padlen(sos) + 1


def lowpass(
    signal,
    dt_s: float,
    cutoff_hz: float,
    order: int = 4,
    *,
    nan_policy: str = "raise",
    name: str = "signal",
) -> np.ndarray:
    """Zero-lag Butterworth low-pass along axis 0 (Winter 2009, section 3.4.4).

    The filter of `order` runs forwards then backwards (scipy.signal.sosfiltfilt),
    so there is no phase shift at any frequency and the magnitude response is the
    single-pass one squared: 1 / (1 + (w(f)/w(cutoff_hz))^(2·order)) with
    w(f) = tan(π f dt_s) (the bilinear transform's warping; w(f)/w(f_c) ≈ f/f_c
    well below Nyquist). At `cutoff_hz`
    the gain is therefore 1/2 (−6 dB), not the single pass's −3 dB; below it a
    polynomial of degree < 2·order passes unchanged (the response is flat to that
    order at 0 Hz). Each end is padded by odd reflection (which keeps the value
    and the slope) over PAD_PERIODS / cutoff_hz seconds, or as much of the signal
    as there is, so the filter's start-up transient dies out in the padding.

    `signal` has shape (N,) or (N, ...). `name` is the field named in errors.

    NaN handling (`nan_policy`):
    * "raise" (default): any NaN or infinity is a ParameterError naming the
      field and the first bad sample, since a single NaN would otherwise spread
      through the whole filtered signal.
    * "interpolate": NaN samples of each channel are filled by linear
      interpolation between their finite neighbours (held constant before the
      first and after the last finite sample), the whole channel is filtered, and
      NaN is put back where the input had it, so no filled value is mistaken for
      data. Infinities are still refused. A channel with no finite sample is
      refused.

    Raises ParameterError for dt_s ≤ 0, cutoff outside (0, Nyquist), an order
    outside ORDER_RANGE, an unknown nan_policy, or a signal too short for the
    filter's padding (see `min_samples`).
    """
    sos = butterworth_sos(dt_s, cutoff_hz, order)
    # scipy's default padding (a few samples) is far shorter than the filter's
    # memory, so a steep signal end leaves a start-up transient (0.5 on a cubic
    # of slope 36/s at 10 Hz). PAD_PERIODS cutoff periods let it die out.
    return zero_lag(signal, sos, PAD_PERIODS / (float(cutoff_hz) * dt_s),
                    nan_policy=nan_policy, name=name, what=f"an order-{order} filter")


def zero_lag(
    signal,
    sos: np.ndarray,
    pad_samples: float,
    *,
    nan_policy: str = "raise",
    name: str = "signal",
    what: str = "the filter",
) -> np.ndarray:
    """Any digital filter `sos` (second-order sections) run forwards then backwards along
    axis 0 (scipy.signal.sosfiltfilt): no phase shift, the single pass's magnitude
    squared. Each end is padded by odd reflection over `pad_samples` (at least
    sosfiltfilt's default, at most the signal less one sample), with the NaN policy
    and the checks of `lowpass`, which is this with a Butterworth low-pass. The EMG
    band-pass and mains notch (core.emg.processing) run through here too."""
    values, missing = _prepare(signal, name, nan_policy)
    n = values.shape[0]
    least = _padlen(sos)
    if n <= least:
        raise ParameterError(
            name,
            f"{n} samples",
            f"at least {least + 1} samples for {what}",
            f"the zero-lag filter pads each end with at least {least} samples; "
            "record longer or lower the order",
        )
    padlen = min(n - 1, max(least, math.ceil(pad_samples)))
    from scipy.signal import sosfiltfilt

    filtered = sosfiltfilt(sos, values, axis=0, padlen=padlen)
    if missing is not None:
        filtered[missing] = np.nan
    return filtered


# ------------------------------------------------------------------ derivatives
@dataclass(frozen=True, slots=True, eq=False)
class Derivatives:
    """A signal's smoothed value and its first two time derivatives, each the
    shape of the input. Units: the signal's, per second, per second squared."""

    value: np.ndarray
    rate: np.ndarray
    acceleration: np.ndarray


def smoothed_derivatives(
    signal,
    dt_s: float,
    cutoff_hz: float | None,
    order: int = 4,
    *,
    nan_policy: str = "raise",
    name: str = "signal",
) -> Derivatives:
    """Smoothed value, rate and acceleration of a whole recording.

    The signal is low-passed with the zero-lag Butterworth of `lowpass` (skipped
    when `cutoff_hz` is None, for signals known to be clean), then
    differentiated with second-order finite differences: the central first
    difference (x[k+1] − x[k−1]) / (2·dt) and the three-point second difference
    (x[k+1] − 2x[k] + x[k−1]) / dt², with second-order one-sided stencils at the
    two ends. Filtering before differencing is the usual order for movement data
    (Winter 2009, ch. 3): differencing multiplies noise at frequency f by about
    2πf, so it must be removed first. A central difference of a sine of
    frequency f is low by the factor sin(2πf·dt)/(2πf·dt), 1 − 2.6·10⁻⁵ at
    5 Hz and 2 ms.

    Ends: the odd reflection keeps value and slope but mirrors the curvature,
    so within about 1/cutoff_hz of either end the acceleration is pulled towards
    zero (and the rate slightly off); trim those parts when they matter.

    With nan_policy "interpolate", samples that were NaN are NaN in all three
    outputs; their neighbours' derivatives use the filled values.
    """
    if cutoff_hz is None:
        dt_s = check_positive("dt_s", dt_s, "s")
        value, missing = _prepare(signal, name, nan_policy)
    else:
        value = lowpass(signal, dt_s, cutoff_hz, order, nan_policy=nan_policy, name=name)
        missing = np.isnan(value)
        if missing.any():
            value = _fill_nan(value, name)
        else:
            missing = None
    if value.shape[0] < 4:
        raise ParameterError(
            name, f"{value.shape[0]} samples", "at least 4 samples",
            "the one-sided second difference at the ends needs 4 points",
        )
    rate = np.gradient(value, dt_s, axis=0, edge_order=2)
    acceleration = second_difference(value, dt_s)
    if missing is not None:
        for array in (value, rate, acceleration):
            array[missing] = np.nan
    return Derivatives(value, rate, acceleration)


def second_difference(values, dt_s: float) -> np.ndarray:
    """d²x/dt² by the three-point central difference along axis 0, with the
    second-order one-sided stencil (2x₀ − 5x₁ + 4x₂ − x₃)/dt² at each end.

    Unlike differencing twice with np.gradient (a 5-point stencil blind to the
    Nyquist frequency), this keeps alternating noise visible to jerk metrics.
    """
    x = np.asarray(values, dtype=float)
    if x.shape[0] < 4:
        raise ParameterError("values", f"{x.shape[0]} samples", "at least 4 samples")
    out = np.empty_like(x)
    h2 = dt_s * dt_s
    out[1:-1] = (x[2:] - 2.0 * x[1:-1] + x[:-2]) / h2
    out[0] = (2.0 * x[0] - 5.0 * x[1] + 4.0 * x[2] - x[3]) / h2
    out[-1] = (2.0 * x[-1] - 5.0 * x[-2] + 4.0 * x[-3] - x[-4]) / h2
    return out


# ------------------------------------------------------------------ causal, per tick
class RateEstimator:
    """Rate and acceleration of one quantised angle, one 2 ms tick at a time.

    Choice: a critically damped α-β-γ tracker (Kalata 1984; the fading-memory
    filter of Morrison 1969), i.e. a third-order tracking observer. Each tick
    predicts with constant acceleration,

        x⁻ = x + v·dt + a·dt²/2,   v⁻ = v + a·dt,   r = angle − x⁻,

    and corrects x = x⁻ + α r, v = v⁻ + (β/dt) r, a = a + (2γ/dt²) r with

        α = 1 − ξ³,  β = 1.5 (1 − ξ)² (1 + ξ),  γ = 0.5 (1 − ξ)³,  ξ = exp(−2π f_c dt),

    which puts all three poles of the tracking error at z = ξ: the discrete
    image of a triple pole at −2π·f_c (no overshoot of the error, no ringing).
    Why this and not a low-pass on the backward difference: the tracker is
    type 3, so on a ramp or constant-acceleration motion its rate and
    acceleration converge to the exact values with no steady-state lag, whereas a
    low-pass on differences always delays the rate by its group delay.

    Lag and bandwidth (f ≪ f_c, continuous approximation, checked in the tests):
    * rate: H_v(s) = (3ω²s + ω³)/(s + ω)³ times the true rate, ω = 2π f_c,
      ≈ 1 + 3 (f/f_c)² − 8j (f/f_c)³. Its phase vanishes to first order: the lag
      is 8 (f/f_c)³ rad, a delay of 8 (f/f_c)²/(2π f_c) (0.16 ms for 1 Hz
      motion at f_c = 20 Hz), and the gain rises as 1 + 3 (f/f_c)²
      (|H_v − 1| ≤ 3 (f/f_c)² for f ≤ f_c/4).
    * acceleration: ω³/(s + ω)³ times the true acceleration, a third-order
      low-pass with a delay of about 3/(2π f_c) (24 ms at 20 Hz).

    Start-up: the error decays like (t/τ)² e^(−t/τ), τ = 1/(2π f_c); after
    about 25 τ (0.2 s at 20 Hz) it is below 10⁻⁶ of its initial value.

    Quantisation: with an encoder step q the measurement error is at most q/2,
    so the rate error it causes is at most (q/2)·‖h_v‖₁, ‖h_v‖₁ being the ℓ1
    norm of the impulse response from angle to rate (about 10.7·f_c per second
    at 2 ms). For 4000 counts/rev and f_c = 20 Hz that is 0.17 rad/s worst case
    (the acceleration's bound is 7.7 rad/s²), against steps of 0.79 rad/s in the
    raw backward difference. The RMS error is typically 0.03–0.04 rad/s; it is
    closest to the raw one when the count rate is near a multiple of the tick
    rate (joint speeds near k·0.785 rad/s), where the quantisation error beats
    slowly and lies inside the tracker's band. A lower f_c trades acceleration
    lag for noise.

    The first `update` initialises the angle and returns zero rate and
    acceleration. Plain floats only: no numpy in the tick.

    The formula is the kernel `track` below (compiled in the loop, core.kernels);
    this class validates the cutoff, holds the constants and the state, and primes.
    """

    __slots__ = ("_constants", "_primed", "_state", "cutoff_hz", "dt_s")

    def __init__(self, dt_s: float, cutoff_hz: float) -> None:
        self.dt_s = check_positive("dt_s", dt_s, "s")
        self.cutoff_hz = _check_cutoff(cutoff_hz, 0.5 / self.dt_s)
        xi = math.exp(-2.0 * math.pi * self.cutoff_hz * self.dt_s)
        self._constants = (
            self.dt_s,
            0.5 * self.dt_s * self.dt_s,
            1.0 - xi**3,
            1.5 * (1.0 - xi) ** 2 * (1.0 + xi) / self.dt_s,
            (1.0 - xi) ** 3 / (self.dt_s * self.dt_s),
        )
        self._state = [0.0, 0.0, 0.0]
        self.reset()

    def reset(self, angle: float | None = None, rate: float = 0.0,
              acceleration: float = 0.0) -> None:
        """Forget the past. With `angle` given, start from that state; otherwise
        the next `update` initialises from its angle."""
        self._primed = angle is not None
        self._state[:] = (0.0 if angle is None else float(angle), float(rate),
                          float(acceleration))

    @property
    def primed(self) -> bool:
        """Whether the tracker has its first angle (after `reset(angle)` or one `update`)."""
        return self._primed

    @property
    def angle(self) -> float:
        """The tracked angle (rad)."""
        return self._state[0]

    @property
    def rate(self) -> float:
        """The rate estimate (rad/s)."""
        return self._state[1]

    @property
    def acceleration(self) -> float:
        """The acceleration estimate (rad/s²)."""
        return self._state[2]

    def update(self, angle: float) -> tuple[float, float]:
        """Take one measured angle (rad); return (rate rad/s, acceleration rad/s²)."""
        state = self._state
        if not self._primed:
            self._primed = True
            state[0] = angle
        else:
            track(self._constants, state, 0, angle)
        return (state[1], state[2])

    @property
    def coefficients(self) -> tuple[float, float, float, float, float]:
        """(dt, dt²/2, α, β/dt, 2γ/dt²): the constants vector of `track`."""
        return self._constants

    @property
    def gains(self) -> tuple[float, float, float]:
        """(α, β, γ) of the tracker, for reports and tests."""
        dt = self.dt_s
        _, _, alpha, beta_dt, gamma_dt2 = self._constants
        return (alpha, beta_dt * dt, 0.5 * gamma_dt2 * dt * dt)


# The constants of `track` (RateEstimator.coefficients).
T_DT, T_HALF_DT2, T_ALPHA, T_BETA_DT, T_GAMMA_DT2, T_SIZE = range(6)


@kernel
def track(c, z, i, angle):
    """One tick of the α-β-γ tracker (RateEstimator) whose state (angle, rate,
    acceleration) is z[i], z[i + 1], z[i + 2]: predict with constant acceleration,
    correct by the residual, in place."""
    dt = c[T_DT]
    predicted = z[i] + z[i + 1] * dt + z[i + 2] * c[T_HALF_DT2]
    rate = z[i + 1] + z[i + 2] * dt
    residual = angle - predicted
    z[i] = predicted + c[T_ALPHA] * residual
    z[i + 1] = rate + c[T_BETA_DT] * residual
    z[i + 2] += c[T_GAMMA_DT2] * residual


# ------------------------------------------------------------------ recordings
MAX_GAP_RATIO = 5.0


def sample_interval(t_s) -> float:
    """The sampling interval of a recording's time stamps, in s.

    `t_s` must be one-dimensional, finite and strictly increasing. The interval
    is the median step, so a late tick or two (the loop's stamps jitter) does not
    move it; a step longer than MAX_GAP_RATIO times the median is refused as a
    gap in the recording, because the filters and spectra here assume even
    sampling.
    """
    t = np.asarray(t_s, dtype=float)
    if t.ndim != 1:
        raise ParameterError("t_s", f"an array of shape {t.shape}", "shape (N,)")
    if t.size < 2:
        raise ParameterError("t_s", f"{t.size} samples", "at least 2 samples")
    if not np.isfinite(t).all():
        index = int(np.flatnonzero(~np.isfinite(t))[0])
        raise ParameterError("t_s", f"not finite at sample {index}", "finite times in s")
    step = np.diff(t)
    if (step <= 0.0).any():
        index = int(np.flatnonzero(step <= 0.0)[0]) + 1
        raise ParameterError("t_s", f"not increasing at sample {index}",
                             "strictly increasing times in s")
    dt_s = float(np.median(step))
    worst = int(np.argmax(step))
    if step[worst] > MAX_GAP_RATIO * dt_s:
        raise ParameterError(
            "t_s", f"a gap of {step[worst]:g} s after sample {worst}",
            f"steps of at most {MAX_GAP_RATIO:g} × the median step {dt_s:g} s",
            "filters and spectra assume even sampling; analyse the parts separately",
        )
    return dt_s


def as_series(name: str, value, n_samples: int, width: int | None = None) -> np.ndarray:
    """`value` as a finite float array of shape (n_samples,) or (n_samples, width),
    or a ParameterError naming the field, the shape it has and the one it needs."""
    array = np.asarray(value, dtype=float)
    shape = (n_samples,) if width is None else (n_samples, width)
    if array.shape != shape:
        wanted = f"shape {shape}: one row per time stamp in t_s"
        raise ParameterError(name, f"an array of shape {array.shape}", wanted)
    if not np.isfinite(array).all():
        index = int(np.argwhere(~np.isfinite(array))[0][0])
        raise ParameterError(name, f"not finite at sample {index}", "finite numbers")
    return array


# ------------------------------------------------------------------ helpers
def _check_cutoff(cutoff_hz: float, nyquist_hz: float) -> float:
    try:
        value = float(cutoff_hz)
    except (TypeError, ValueError):
        raise ParameterError("cutoff_hz", cutoff_hz, f"(0, {nyquist_hz:g}) Hz") from None
    if not (0.0 < value < nyquist_hz):  # also refuses NaN
        raise ParameterError(
            "cutoff_hz", value, f"(0, {nyquist_hz:g}) Hz",
            "a low-pass cutoff must lie above 0 and below the Nyquist frequency 1/(2·dt_s)",
        )
    return value


def _check_order(order: int) -> None:
    if isinstance(order, bool) or not isinstance(order, int | np.integer) \
            or not ORDER_RANGE[0] <= order <= ORDER_RANGE[1]:
        raise ParameterError("order", order, f"an integer in [{ORDER_RANGE[0]}, {ORDER_RANGE[1]}]")


def _padlen(sos: np.ndarray) -> int:
    # The same padding sosfiltfilt uses by default, so our length check matches it.
    trivial = min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
    return 3 * (2 * len(sos) + 1 - trivial)


def _prepare(signal, name: str, nan_policy: str) -> tuple[np.ndarray, np.ndarray | None]:
    """A float copy of `signal` and the mask of its NaN samples (None if none)."""
    if nan_policy not in NAN_POLICIES:
        raise ParameterError("nan_policy", nan_policy, ", ".join(NAN_POLICIES))
    values = np.array(signal, dtype=float)
    if values.ndim == 0:
        raise ParameterError(name, "a scalar", "an array of shape (N,) or (N, ...)")
    if np.isinf(values).any():
        index = int(np.argwhere(np.isinf(values))[0][0])
        raise ParameterError(name, f"infinite at sample {index}", "finite numbers")
    missing = np.isnan(values)
    if not missing.any():
        return values, None
    if nan_policy == "raise":
        index = int(np.argwhere(missing)[0][0])
        raise ParameterError(
            name, f"NaN at sample {index}", "finite numbers",
            "pass nan_policy='interpolate' to filter across gaps",
        )
    return _fill_nan(values, name), missing


def _fill_nan(values: np.ndarray, name: str) -> np.ndarray:
    """Linear interpolation over NaN along axis 0, each channel on its own."""
    flat = values.reshape(values.shape[0], -1)
    index = np.arange(flat.shape[0])
    for k in range(flat.shape[1]):
        column = flat[:, k]
        good = ~np.isnan(column)
        if not good.any():
            raise ParameterError(name, f"channel {k} all NaN", "at least one finite sample")
        column[~good] = np.interp(index[~good], index[good], column[good])
    return flat.reshape(values.shape)
