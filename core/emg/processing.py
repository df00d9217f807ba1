"""From raw surface EMG to MVC-normalised envelopes on the loop's time base (section 5.2.1).

The chain, each step a function of its own so a researcher can stop anywhere:

1. `clean`: remove the DC offset, band-pass (zero-lag Butterworth, 20–450 Hz by
   default: below 20 Hz is movement artefact and electrode drift, above 450 Hz
   surface EMG has almost no power; the usual SENIAM / De Luca band), and notch the
   mains frequency (50 Hz, or 60 Hz in the Americas), all zero-lag through
   core.signal.zero_lag, so no filter delays the envelope against the torques.
2. `rectify`: full-wave rectification |x|, the input of a linear envelope.
3. `rms_envelope`: the moving-window root mean square the thesis used for its
   MVC and its normalisation: window 0.125 s, overlap 0.0625 s (so one value
   every 0.0625 s), stamped at each window's centre. RMS squares the signal, so it
   needs no rectification. `linear_envelope` (rectify, then a low-pass) is the
   other conventional envelope, the one pyemgpipeline computes.
4. `normalise`: divide by each muscle's MVC (mvc.py): 1.0 = 100 % MVC.
5. `on_time_base`: the envelope interpolated onto other time stamps, e.g. the
   loop's 2 ms ticks, NaN where the EMG does not cover them.

Time runs along axis 0; channels (muscles) along axis 1. Volts in, volts or
fractions of MVC out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError, check_positive
from core.signal import PAD_PERIODS, lowpass, zero_lag

# The thesis's RMS settings (section 5.2.1).
THESIS_WINDOW_S = 0.125
THESIS_OVERLAP_S = 0.0625
DEFAULT_BAND_HZ = (20.0, 450.0)
MAINS_HZ = (50.0, 60.0)


@dataclass(frozen=True, slots=True)
class EmgSettings:
    """How raw EMG becomes an envelope. `mains_hz` None skips the notch (a battery
    system far from the mains, or data already notched)."""

    band_hz: tuple[float, float] = DEFAULT_BAND_HZ
    band_order: int = 4
    mains_hz: float | None = 50.0
    notch_quality: float = 30.0  # f0 / bandwidth: 1.7 Hz wide at 50 Hz
    window_s: float = THESIS_WINDOW_S
    overlap_s: float = THESIS_OVERLAP_S

    def __post_init__(self) -> None:
        low, high = (float(v) for v in self.band_hz)
        if not (0.0 < low < high) or not math.isfinite(high):
            raise ParameterError("band_hz", self.band_hz, "0 < low < high, in Hz")
        object.__setattr__(self, "band_hz", (low, high))
        if isinstance(self.band_order, bool) or not isinstance(self.band_order, int) \
                or not 1 <= self.band_order <= 8:
            raise ParameterError("band_order", self.band_order, "an integer in [1, 8]")
        if self.mains_hz is not None:
            check_positive("mains_hz", self.mains_hz, "Hz")
        check_positive("notch_quality", self.notch_quality)
        window = check_positive("window_s", self.window_s, "s")
        overlap = float(self.overlap_s)
        if not (0.0 <= overlap < window):
            raise ParameterError("overlap_s", self.overlap_s, f"[0, {window:g}) s",
                                 "the overlap must be shorter than the window")

    @property
    def step_s(self) -> float:
        """Time between two envelope values: window less overlap (0.0625 s)."""
        return self.window_s - self.overlap_s

    def to_dict(self) -> dict:
        return {"band_hz": list(self.band_hz), "band_order": self.band_order,
                "mains_hz": self.mains_hz, "notch_quality": self.notch_quality,
                "window_s": self.window_s, "overlap_s": self.overlap_s}

    @classmethod
    def from_dict(cls, d: dict | None) -> EmgSettings:
        """`to_dict`'s settings, the defaults for what a dictionary leaves out (an MVC
        stored before a setting existed)."""
        d = d or {}
        return cls(band_hz=tuple(d.get("band_hz", DEFAULT_BAND_HZ)),
                   band_order=int(d.get("band_order", 4)), mains_hz=d.get("mains_hz", 50.0),
                   notch_quality=float(d.get("notch_quality", 30.0)),
                   window_s=float(d.get("window_s", THESIS_WINDOW_S)),
                   overlap_s=float(d.get("overlap_s", THESIS_OVERLAP_S)))


@dataclass(frozen=True, slots=True, eq=False)
class Envelope:
    """An envelope: `values` (K, C) at times `t_s` (K,), each the centre of its window.
    Units: those of the signal (V), or 1 once normalised to MVC."""

    t_s: np.ndarray
    values: np.ndarray

    def normalised(self, mvc) -> Envelope:
        return Envelope(self.t_s, normalise(self.values, mvc))


# ------------------------------------------------------------------ cleaning
def _samples(emg, name: str = "emg") -> np.ndarray:
    x = np.asarray(emg, dtype=float)
    if x.ndim not in (1, 2):
        raise ParameterError(name, f"an array of shape {x.shape}",
                             "shape (N,) or (N, channels)")
    if not np.isfinite(x).all():
        index = int(np.argwhere(~np.isfinite(x))[0][0])
        raise ParameterError(name, f"not finite at sample {index}", "finite volts",
                             "a dropped sample must be removed or filled before filtering")
    return x


def _rate(fs_hz: float) -> float:
    return check_positive("sampling_rate_hz", fs_hz, "Hz")


def bandpass(emg, fs_hz: float, band_hz=DEFAULT_BAND_HZ, order: int = 4) -> np.ndarray:
    """Zero-lag Butterworth band-pass of `order` (run twice, so the edges are at −6 dB)."""
    from scipy.signal import butter

    fs = _rate(fs_hz)
    low, high = (float(v) for v in band_hz)
    if not (0.0 < low < high < 0.5 * fs):
        raise ParameterError(
            "band_hz", (low, high), f"0 < low < high < {0.5 * fs:g} Hz (the Nyquist frequency)",
            "at this sampling rate lower the band's top, or record faster")
    sos = butter(order, (low, high), btype="bandpass", output="sos", fs=fs)
    return zero_lag(_samples(emg), sos, PAD_PERIODS * fs / low, name="emg",
                    what=f"an order-{order} band-pass")


def notch(emg, fs_hz: float, mains_hz: float = 50.0, quality: float = 30.0) -> np.ndarray:
    """Zero-lag IIR notch at the mains frequency (scipy.signal.iirnotch), −3 dB
    bandwidth mains_hz / quality per pass."""
    from scipy.signal import iirnotch, tf2sos

    fs = _rate(fs_hz)
    f0 = check_positive("mains_hz", mains_hz, "Hz")
    if f0 >= 0.5 * fs:
        raise ParameterError("mains_hz", f0, f"below {0.5 * fs:g} Hz (the Nyquist frequency)")
    b, a = iirnotch(f0, check_positive("notch_quality", quality), fs=fs)
    # the notch rings for about quality / (π f0) s; pad a few of those
    pad = PAD_PERIODS * quality / (math.pi * f0) * fs
    return zero_lag(_samples(emg), tf2sos(b, a), pad, name="emg", what="the mains notch")


def clean(emg, fs_hz: float, settings: EmgSettings | None = None) -> np.ndarray:
    """DC offset removed, band-passed and mains-notched EMG (V)."""
    settings = settings or EmgSettings()
    x = _samples(emg)
    x = x - x.mean(axis=0)
    x = bandpass(x, fs_hz, settings.band_hz, settings.band_order)
    if settings.mains_hz is not None:
        x = notch(x, fs_hz, settings.mains_hz, settings.notch_quality)
    return x


def rectify(emg) -> np.ndarray:
    """Full-wave rectification."""
    return np.abs(_samples(emg))


# ------------------------------------------------------------------ envelopes
def window_samples(fs_hz: float, window_s: float, overlap_s: float) -> tuple[int, int]:
    """(window, step) in samples: round(window_s·fs) and that less round(overlap_s·fs),
    step at least one sample."""
    fs = _rate(fs_hz)
    window = round(check_positive("window_s", window_s, "s") * fs)
    if window < 2:
        raise ParameterError("window_s", window_s, f"at least 2 samples ({2 / fs:g} s)")
    overlap = round(float(overlap_s) * fs)
    if not 0 <= overlap < window:
        raise ParameterError("overlap_s", overlap_s, f"[0, {window_s:g}) s")
    return window, window - overlap


def rms_envelope(
    emg,
    fs_hz: float,
    window_s: float = THESIS_WINDOW_S,
    overlap_s: float = THESIS_OVERLAP_S,
    t0_s: float = 0.0,
) -> Envelope:
    """Moving-window RMS, sqrt(mean(x²)) over each window, windows `step` samples apart;
    stamped at the window's centre t0 + (k·step + (window − 1)/2)/fs. The last
    samples that do not fill a window are not used."""
    x = _samples(emg)
    window, step = window_samples(fs_hz, window_s, overlap_s)
    n = x.shape[0]
    if n < window:
        raise ParameterError("emg", f"{n} samples", f"at least one window ({window} samples)",
                             f"the RMS window is {window_s:g} s")
    from numpy.lib.stride_tricks import sliding_window_view

    windows = sliding_window_view(x * x, window, axis=0)[::step]  # (K, [C,] window)
    values = np.sqrt(windows.mean(axis=-1))
    k = np.arange(values.shape[0])
    t = float(t0_s) + (k * step + 0.5 * (window - 1)) / float(fs_hz)
    return Envelope(t, values)


def linear_envelope(emg, fs_hz: float, cutoff_hz: float = 6.0, order: int = 2) -> np.ndarray:
    """Full-wave rectified EMG low-passed (zero-lag Butterworth, core.signal.lowpass), one
    value per sample: the conventional linear envelope (pyemgpipeline's default
    6 Hz, order 2)."""
    return lowpass(rectify(emg), 1.0 / _rate(fs_hz), cutoff_hz, order, name="emg")


def envelope(emg, fs_hz: float, settings: EmgSettings | None = None,
             t0_s: float = 0.0) -> Envelope:
    """The whole chain up to the RMS envelope in volts: `clean`, then `rms_envelope`."""
    settings = settings or EmgSettings()
    return rms_envelope(clean(emg, fs_hz, settings), fs_hz, settings.window_s,
                        settings.overlap_s, t0_s)


def as_known(envelope: Envelope, fs_hz: float, settings: EmgSettings | None = None) -> Envelope:
    """The envelope stamped when it is known, at the end of its window rather than its
    centre: what a live estimate has at each moment (half a window, 0.062 s with the
    thesis's settings, later than the centred stamp)."""
    settings = settings or EmgSettings()
    window, _ = window_samples(fs_hz, settings.window_s, settings.overlap_s)
    return Envelope(envelope.t_s + 0.5 * (window - 1) / float(fs_hz), envelope.values)


# ------------------------------------------------------------------ normalising and time base
def normalise(values, mvc) -> np.ndarray:
    """Envelope values divided by each channel's MVC (same units): 1.0 = 100 % MVC."""
    v = np.asarray(values, dtype=float)
    m = np.asarray(mvc, dtype=float)
    width = 1 if v.ndim == 1 else v.shape[1]
    if m.shape not in ((), (width,)):
        raise ParameterError("mvc", f"an array of shape {m.shape}",
                             f"one value per channel ({width})")
    if not (np.isfinite(m) & (m > 0.0)).all():
        raise ParameterError("mvc", m.tolist(), "finite values > 0 V",
                             "record the MVC again: a muscle without one cannot be normalised")
    return v / m


def on_time_base(envelope: Envelope, t_s) -> np.ndarray:
    """The envelope linearly interpolated at the times `t_s` (e.g. the trial's 2 ms
    ticks), NaN outside the envelope's first and last stamp: EMG that was not
    recorded is never invented."""
    t = np.asarray(t_s, dtype=float)
    values = envelope.values
    flat = values.reshape(values.shape[0], -1)
    out = np.full((t.shape[0], flat.shape[1]), np.nan)
    if envelope.t_s.size:
        inside = (t >= envelope.t_s[0]) & (t <= envelope.t_s[-1])
        for c in range(flat.shape[1]):
            out[inside, c] = np.interp(t[inside], envelope.t_s, flat[:, c])
    return out.reshape((t.shape[0], *values.shape[1:]))
