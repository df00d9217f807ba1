"""The maximum voluntary contraction (MVC) of one muscle in one session, and its quality.

Section 5.2.1: each session starts with an isometric MVC per muscle; the MVC is the
maximum of the RMS envelope (window 0.125 s, overlap 0.0625 s) over the
contraction, and the session's trials are divided by it. Section 5.2.2 then met
subject 2, whose deltoid reached about 90 % MVC while moving the handle along the D
without assistance or resistance: the MVC was most likely not a maximal effort.
Such an MVC passes silently through a plain max(); `check_mvc` refuses to pass it.

A contraction is flagged when it is

* too short: the envelope stays within `hold_fraction` of its peak for less than
  `min_hold_s` in one stretch (a flick or an artefact, not a held maximal effort);
  MVC protocols ask for 3–5 s, of which a good effort holds a second or more;
* saturated: raw samples sit at the amplifier's full scale (given), or the same
  extreme value repeats (the flat tops of clipping, when the range is unknown);
  the true maximum is then unknown;
* no effort above rest (given the rest before the push, as the guided protocol and `rehab
  emg record --muscle` record it): the push's median envelope stays within the resting
  envelope's median + `onset_sd` robust standard deviations (1.4826 × its median absolute
  deviation, so that a few samples of the push stamped into the rest do not raise it; the
  rest's first third left out, the patient settling), the threshold by which a muscle's
  onset is detected against its baseline (Hodges & Bui 1996, Electroencephalogr Clin
  Neurophysiol 101:511, k = 3). A push of resting noise (a sensor off the skin or on
  the wrong muscle, a patient who did not push) otherwise passed as an MVC of, say, 15 µV
  held for 8 s, and every trial normalised by it read as thousands of % MVC;
* lower than the trial's own activity: the trial's envelope reaches the MVC
  (`trial_peak_fraction`), or its 95th percentile reaches `trial_typical_fraction`
  of it (a planar reach without load holds 10–40 % MVC; 90 % says the MVC was not
  maximal). This is the check that would have caught subject 2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.emg.processing import EmgSettings, Envelope, envelope
from core.errors import ParameterError, check_positive, check_range

TOO_SHORT = "too_short"
SATURATED = "saturated"
NO_EFFORT = "no_effort_above_rest"
BELOW_TRIAL = "below_trial_activity"
FLAGS = (TOO_SHORT, SATURATED, NO_EFFORT, BELOW_TRIAL)
REST_SETTLING = 3
"""The rest's first 1/REST_SETTLING is not its resting level (`_above_rest`)."""


@dataclass(frozen=True, slots=True)
class MvcCriteria:
    """Where a contraction stops being trusted (module docstring)."""

    min_hold_s: float = 1.0
    hold_fraction: float = 0.7
    full_scale_margin: float = 0.995  # |x| ≥ this × full scale counts as clipped
    max_clipped_share: float = 0.001  # of the contraction's samples
    repeated_extreme_samples: int = 4  # the same |max| this many times: flat tops
    trial_peak_fraction: float = 1.0
    trial_typical_fraction: float = 0.6
    onset_sd: float = 3.0  # Hodges & Bui 1996: baseline + 3 SD (here its robust form)

    def __post_init__(self) -> None:
        check_positive("min_hold_s", self.min_hold_s, "s")
        check_positive("onset_sd", self.onset_sd)
        check_range("hold_fraction", self.hold_fraction, 0.0, 1.0, low_open=True)
        check_range("trial_typical_fraction", self.trial_typical_fraction, 0.0, 1.0,
                    low_open=True)
        check_positive("trial_peak_fraction", self.trial_peak_fraction)


@dataclass(frozen=True, slots=True)
class Mvc:
    """One muscle's MVC from one contraction recording."""

    muscle: str
    value_V: float  # max of the RMS envelope
    peak_time_s: float  # where in the contraction recording
    hold_s: float  # longest stretch within hold_fraction of the peak
    clipped_share: float  # share of raw samples at full scale (or at a repeated extreme)
    flags: tuple[str, ...]
    reasons: tuple[str, ...]  # one sentence per flag, for people

    @property
    def ok(self) -> bool:
        return not self.flags

    def to_dict(self) -> dict:
        return {"muscle": self.muscle, "value_V": self.value_V, "peak_time_s": self.peak_time_s,
                "hold_s": self.hold_s, "clipped_share": self.clipped_share,
                "flags": list(self.flags), "reasons": list(self.reasons)}


def mvc_from_contraction(
    emg,
    fs_hz: float,
    muscle: str,
    *,
    settings: EmgSettings | None = None,
    full_scale_V: float | None = None,
    criteria: MvcCriteria | None = None,
    rest=None,
) -> Mvc:
    """The MVC of one muscle from its raw contraction recording `emg` (N,) in V: the
    maximum of its RMS envelope, with the too-short and saturated checks, and with
    `rest` (the same channel's raw EMG while the patient rested just before, V) the
    no-effort-above-rest check. The check against a trial's activity needs the trial:
    `check_against_trial`."""
    criteria = criteria or MvcCriteria()
    raw = np.asarray(emg, dtype=float)
    if raw.ndim != 1:
        raise ParameterError("emg", f"an array of shape {raw.shape}", "one muscle: shape (N,)")
    env = envelope(raw, fs_hz, settings)
    values = env.values
    peak = int(np.argmax(values))
    value = float(values[peak])
    if not value > 0.0:
        raise ParameterError("emg", "a flat recording", "a contraction",
                             f"{muscle}: the recording has no EMG at all; check the sensor")
    step_s = float(env.t_s[1] - env.t_s[0]) if env.t_s.size > 1 else 0.0
    hold_s = _longest_run(values >= criteria.hold_fraction * value) * step_s
    clipped = _clipped_share(raw, full_scale_V, criteria)
    flags, reasons = [], []
    if hold_s < criteria.min_hold_s:
        flags.append(TOO_SHORT)
        reasons.append(f"{muscle}: the contraction held within "
                       f"{100 * criteria.hold_fraction:.0f} % of its peak for {hold_s:.2f} s, "
                       f"less than {criteria.min_hold_s:g} s; ask for a 3–5 s maximal effort")
    if clipped > criteria.max_clipped_share:
        flags.append(SATURATED)
        reasons.append(f"{muscle}: {100 * clipped:.2f} % of the samples are at the "
                       "amplifier's limit, so the true maximum is unknown; lower the gain "
                       "or check the electrode contact, and record again")
    above = _above_rest(values, rest, fs_hz, settings, criteria)
    if above is not None:
        flags.append(NO_EFFORT)
        reasons.append(f"{muscle}: no effort above rest: the push's EMG ({1e6 * above[0]:.1f} "
                       f"µV, its median) stays within the resting level ({1e6 * above[1]:.1f} "
                       f"µV, median + {criteria.onset_sd:g} SD); check that the electrode is on "
                       "the muscle and on the skin, and that the patient pushes, then record "
                       "again (a muscle with no voluntary EMG has no MVC to normalise by)")
    return Mvc(muscle, value, float(env.t_s[peak]), hold_s, clipped, tuple(flags),
               tuple(reasons))


def _above_rest(push_envelope, rest, fs_hz: float, settings: EmgSettings | None,
                criteria: MvcCriteria) -> tuple[float, float] | None:
    """(push median, rest threshold) in V when the push does not rise above the rest's
    onset threshold (module docstring); None when it does, or with no usable rest."""
    if rest is None:
        return None
    quiet = np.asarray(rest, dtype=float)
    if quiet.ndim != 1 or quiet.size < 2:
        return None
    # its first third left out: the patient still settling after being told to rest, and
    # samples from before the word stamped into it by the source's latency (a window test
    # under load: the push's level read as the rest's, the push then not above it)
    quiet = quiet[quiet.size // REST_SETTLING:]
    try:
        resting = envelope(quiet, fs_hz, settings).values
    except ParameterError:  # shorter than one envelope window: nothing to compare with
        return None
    if resting.size < 2:
        return None
    # the robust form of mean + k SD (median, and the MAD scaled to a normal SD): a patient
    # who starts the push before the word, or samples stamped across the boundary, are a
    # few outliers that blew the SD up to the push's level (a whole check under load)
    centre = float(np.median(resting))
    spread = 1.4826 * float(np.median(np.abs(resting - centre)))
    threshold = centre + criteria.onset_sd * spread
    level = float(np.median(push_envelope))
    return (level, threshold) if level <= threshold else None


def check_against_trial(mvc: Mvc, trial_envelope_V, criteria: MvcCriteria | None = None) -> Mvc:
    """The MVC with the below-trial-activity flag added when the trial's own RMS
    envelope of that muscle (V, same settings) reaches it (module docstring)."""
    criteria = criteria or MvcCriteria()
    env = np.asarray(trial_envelope_V, dtype=float)
    env = env[np.isfinite(env)]
    if env.size == 0:
        return mvc
    peak = float(env.max()) / mvc.value_V
    typical = float(np.percentile(env, 95.0)) / mvc.value_V
    if peak < criteria.trial_peak_fraction and typical < criteria.trial_typical_fraction:
        return mvc
    reason = (f"{mvc.muscle}: the trial reaches {100 * peak:.0f} % MVC (95th percentile "
              f"{100 * typical:.0f} %), more than a maximal contraction should allow; the MVC "
              "was probably not maximal: record it again")
    flags = (*tuple(f for f in mvc.flags if f != BELOW_TRIAL), BELOW_TRIAL)
    reasons = tuple(r for f, r in zip(mvc.flags, mvc.reasons, strict=True) if f != BELOW_TRIAL)
    return Mvc(mvc.muscle, mvc.value_V, mvc.peak_time_s, mvc.hold_s, mvc.clipped_share, flags,
               (*reasons, reason))


def trial_envelope_of(env: Envelope, channel: int) -> np.ndarray:
    """One channel of an envelope, for `check_against_trial`."""
    values = np.asarray(env.values)
    return values if values.ndim == 1 else values[:, channel]


def _longest_run(mask: np.ndarray) -> int:
    if not mask.any():
        return 0
    padded = np.concatenate(([0], mask.astype(np.int8), [0]))
    edges = np.flatnonzero(np.diff(padded))
    return int((edges[1::2] - edges[::2]).max())


def _clipped_share(raw: np.ndarray, full_scale_V: float | None, criteria: MvcCriteria) -> float:
    magnitude = np.abs(raw)
    if full_scale_V is not None:
        limit = check_positive("full_scale_V", full_scale_V, "V") * criteria.full_scale_margin
        return float(np.count_nonzero(magnitude >= limit)) / raw.size
    # no range known: clipping shows as the same extreme value again and again
    extreme = magnitude.max()
    repeated = int(np.count_nonzero(magnitude == extreme))
    if repeated < criteria.repeated_extreme_samples:
        return 0.0
    return repeated / raw.size
