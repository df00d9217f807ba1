"""Visually guided reaching: the 12 parameters of Coderre et al. 2010 and the
smoothness of each reach, as pure functions of a recording.

Coderre AM, Amr Abou Zeid, Dukelow SP et al., Neurorehabil Neural Repair
24(6):528-541, 2010, doi:10.1177/1545968309356091. The paper itself was not
available to us; the definitions below follow its parameter table as reprinted
by Little CE et al., J NeuroEng Rehabil 12:78, 2015, Table 1
(doi:10.1186/s12984-015-0070-0), and where that table leaves a choice open the
choice is ours and is said so ("our reading").

Per reach (a window from the target's appearance `on_s` to `end_s`, the cue of
the next movement or the end of the recording):

* *Posture speed*: mean hand speed over the 500 ms before the target appears.
* *Movement onset* (our reading of the threshold): the first time after the
  target appears that the speed rises through 10 % of the window's peak speed.
  Searching forwards (core.reaches searches back from the peak for exercise
  reaches) keeps a small first sub-movement, which the feed-forward parameters
  are meant to catch, as the movement's start. None when the peak is below
  0.01 m/s (the hand did not move) or the speed is already above the threshold
  when the target appears (anticipated or carried over): the reach then counts
  as *no reaction*.
* *Movement offset* (our reading): the first time after the peak when the speed
  falls through the same threshold *while the hand is on the target* (within
  `target_radius_m` of it); a hand that stops short and then corrects ends after
  the correction. None found: the reach counts as *no movement end* (so does a
  reach with no reaction, which never stopped on the target either).
* *Initial phase*: from movement onset to the first speed minimum after onset
  (Little Table 1), searched up to the offset (the window's end without one); a
  single-peaked reach has none, and its initial phase ends at the offset.
* *Reaction time* = onset − on_s; *movement time* = offset − onset.
* *Initial direction error*: the angle between the line (hand at onset ->
  target) and the hand's displacement over the initial phase
  (core.reaches.direction_error); the task's figure is the mean of the absolute
  angles.
* *Initial distance ratio*: path length of the initial phase / path length from
  onset to offset (to the window's end when the hand never stopped on the target,
  as Little's Table 1 says). *Initial speed ratio*: peak speed of the initial phase / the
  reach's peak speed.
* *Speed maxima count*: local maxima of the speed between onset and offset
  (plateaus count once). *Min-max speed difference* (our reading of "the
  differences between local speed peaks and minima"): the mean over each
  maximum after the first of (that maximum − the minimum before it); 0 with a
  single maximum.
* *Path length ratio*: path length from onset to offset / the straight distance
  from the reach's start to its target. *Max speed*: the window's peak speed.
* *SPARC* and *LDLJ* (core.smoothness) of the speed and the velocity from onset
  to offset (to the window's end without an offset).

Figures that need an onset are NaN without one; the speed maxima count, the
min-max speed difference, the movement time and the path length ratio are NaN
without an offset. The task's figure is the mean over the reaches where it is
defined, and the two counts say how many were not.

Speeds come from the velocity given, or from the positions low-passed at 10 Hz
(zero-lag Butterworth, core.signal.smoothed_derivatives) and differentiated:
local maxima are counted on that speed, so pass a smoothed velocity.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError, check_positive, check_range
from core.reaches import DEFAULT_MIN_PEAK_SPEED_M_S, Reach, crossing, direction_error
from core.signal import as_series, sample_interval, smoothed_derivatives
from core.smoothness import ldlj, sparc

ONSET_FRACTION = 0.1
POSTURE_WINDOW_S = 0.5
DEFAULT_TARGET_RADIUS_M = 0.01
SPEED_CUTOFF_HZ = 10.0


@dataclass(frozen=True, slots=True)
class VgrReach:
    """One reach's parameters (see the module docstring); times in s from the
    recording's clock, speeds m/s, angle rad (signed, counter-clockwise positive)."""

    on_s: float
    onset_s: float
    offset_s: float
    initial_end_s: float
    posture_speed_m_s: float
    reaction_time_s: float
    initial_direction_error_rad: float
    initial_distance_ratio: float
    initial_speed_ratio: float
    speed_maxima_count: float
    min_max_speed_difference_m_s: float
    movement_time_s: float
    path_length_ratio: float
    max_speed_m_s: float
    sparc: float
    ldlj: float

    @property
    def reacted(self) -> bool:
        return math.isfinite(self.onset_s)

    @property
    def ended(self) -> bool:
        return math.isfinite(self.offset_s)


def vgr_reaches(
    t_s,
    position_m,
    reaches: Sequence[Reach],
    *,
    ends_s: Sequence[float] | None = None,
    velocity_m_s=None,
    target_radius_m: float = DEFAULT_TARGET_RADIUS_M,
    onset_fraction: float = ONSET_FRACTION,
    min_peak_speed_m_s: float = DEFAULT_MIN_PEAK_SPEED_M_S,
    posture_window_s: float = POSTURE_WINDOW_S,
) -> tuple[VgrReach, ...]:
    """Each reach's parameters from a recording: time stamps (N,) s evenly sampled,
    hand positions (N, 2) m, the reaches in order of their targets' appearance
    (core.reaches.Reach: on time, start, target). `ends_s` ends each reach's window
    (default: the next reach's on time, the last one at the end of the recording).
    `velocity_m_s` (N, 2): the hand velocity; default: the positions' smoothed
    derivative."""
    t = np.asarray(t_s, dtype=float)
    dt_s = sample_interval(t)
    position = as_series("position_m", position_m, t.size, 2)
    if velocity_m_s is None:
        velocity = smoothed_derivatives(position, dt_s, SPEED_CUTOFF_HZ, name="position_m").rate
    else:
        velocity = as_series("velocity_m_s", velocity_m_s, t.size, 2)
    target_radius_m = check_positive("target_radius_m", target_radius_m, "m")
    check_range("onset_fraction", onset_fraction, 0.0, 1.0, low_open=True)
    min_peak_speed_m_s = check_positive("min_peak_speed_m_s", min_peak_speed_m_s, "m/s")
    posture_window_s = check_positive("posture_window_s", posture_window_s, "s")
    ons = [reach.onset_s for reach in reaches]
    if any(b <= a for a, b in itertools.pairwise(ons)):
        raise ParameterError("reaches", "on times out of order", "strictly increasing on times")
    if ends_s is None:
        ends = [*ons[1:], math.inf]
    else:
        ends = [float(end) for end in ends_s]
        if len(ends) != len(ons) or any(not end > on for on, end in zip(ons, ends, strict=True)):
            raise ParameterError("ends_s", f"{len(ends)} ends", f"{len(ons)} ends, each after "
                                 "its reach's on time", "one window end per reach")
    speed = np.hypot(velocity[:, 0], velocity[:, 1])
    recording = _Recording(t, dt_s, position, velocity, speed)
    return tuple(
        _one(recording, reach, on, end, target_radius_m, onset_fraction, min_peak_speed_m_s,
             posture_window_s)
        for reach, on, end in zip(reaches, ons, ends, strict=True))


def vgr_figures(reaches: Sequence[VgrReach]) -> dict[str, float]:
    """The task's figures, keyed as core.assessment.FIGURES: each the mean over the
    reaches where it is defined (the initial direction error's of the absolute
    angles), the two counts the number of reaches with no reaction / no end."""
    def mean(name, transform=float):
        values = [transform(getattr(r, name)) for r in reaches]
        finite = [v for v in values if math.isfinite(v)]
        return float(np.mean(finite)) if finite else math.nan

    return {
        "vgr_posture_speed_m_s": mean("posture_speed_m_s"),
        "vgr_reaction_time_s": mean("reaction_time_s"),
        "vgr_initial_direction_error_rad": mean("initial_direction_error_rad", abs),
        "vgr_initial_distance_ratio": mean("initial_distance_ratio"),
        "vgr_initial_speed_ratio": mean("initial_speed_ratio"),
        "vgr_speed_maxima_count": mean("speed_maxima_count"),
        "vgr_min_max_speed_difference_m_s": mean("min_max_speed_difference_m_s"),
        "vgr_movement_time_s": mean("movement_time_s"),
        "vgr_path_length_ratio": mean("path_length_ratio"),
        "vgr_max_speed_m_s": mean("max_speed_m_s"),
        "vgr_no_reaction_count": float(sum(not r.reacted for r in reaches)),
        "vgr_no_movement_end_count": float(sum(not r.ended for r in reaches)),
        "vgr_sparc": mean("sparc"),
        "vgr_ldlj": mean("ldlj"),
    }


@dataclass(frozen=True, slots=True)
class _Recording:
    t: np.ndarray
    dt_s: float
    position: np.ndarray
    velocity: np.ndarray
    speed: np.ndarray


def _one(rec: _Recording, reach, on_s, end_s, radius, fraction, min_peak,
         posture_s) -> VgrReach:
    t, speed, nan = rec.t, rec.speed, math.nan
    posture = nan
    before = (t >= on_s - posture_s) & (t < on_s)
    # the whole 500 ms recorded (a target after the recording's end has none of it)
    if t[0] <= on_s - posture_s + 0.5 * rec.dt_s and t[-1] >= on_s - 0.5 * rec.dt_s:
        posture = float(np.mean(speed[before]))
    start, stop = (int(i) for i in np.searchsorted(t, [on_s, end_s], side="left"))
    if not t[0] <= on_s < t[-1] or stop - start < 4:
        return _unmoved(on_s, posture, nan)
    peak_index = start + int(np.argmax(speed[start:stop]))
    peak = float(speed[peak_index])
    if peak < min_peak:
        return _unmoved(on_s, posture, peak)
    threshold = fraction * peak
    onset = _first_rise(t, speed, start, peak_index, threshold)
    offset = _offset_on_target(rec, reach.target_m, radius, peak_index, stop, threshold)
    # from the first sample at or after the onset (the window's start without one)
    # to the last one at or before the offset (the window's end without one)
    first = int(np.searchsorted(t, onset, side="left")) if math.isfinite(onset) else start
    last = int(np.searchsorted(t, offset, side="right")) - 1 if math.isfinite(offset) \
        else stop - 1
    maxima, minima = _extrema(speed[first:last + 1])
    initial_end = nan
    if math.isfinite(onset):
        after = [m for m in minima if maxima.size and m > maxima[0]]
        initial_end = float(t[first + after[0]]) if after else (
            offset if math.isfinite(offset) else float(t[last]))
    moved = _path_length(rec, onset, offset)
    # the initial distance ratio's whole runs to the window's end without an offset
    # (Little et al. 2015, Table 1)
    whole = moved if math.isfinite(offset) else _path_length(rec, onset, float(t[last]))
    initial = _path_length(rec, onset, initial_end)
    straight = math.dist(reach.start_m, reach.target_m)
    initial_peak = nan
    if math.isfinite(initial_end):
        k = int(np.searchsorted(t, initial_end, side="right"))
        initial_peak = float(speed[first:max(k, first + 1)].max())
    both = math.isfinite(onset) and math.isfinite(offset)
    return VgrReach(
        on_s=on_s, onset_s=onset, offset_s=offset, initial_end_s=initial_end,
        posture_speed_m_s=posture,
        reaction_time_s=onset - on_s,
        initial_direction_error_rad=direction_error(t, rec.position, reach.target_m, onset,
                                                    initial_end),
        initial_distance_ratio=initial / whole if whole > 0.0 else nan,
        initial_speed_ratio=initial_peak / peak,
        speed_maxima_count=float(maxima.size) if both else nan,
        min_max_speed_difference_m_s=_min_max(speed[first:last + 1], maxima, minima)
        if both else nan,
        movement_time_s=offset - onset,
        path_length_ratio=moved / straight if both else nan,
        max_speed_m_s=peak,
        sparc=sparc(speed[first:last + 1], rec.dt_s) if last - first >= 1 else nan,
        ldlj=ldlj(rec.velocity[first:last + 1], rec.dt_s) if last - first >= 3 else nan,
    )


def _offset_on_target(rec, target, radius, peak_index, stop, threshold) -> float:
    """First fall of the speed through `threshold` after the peak with the hand
    within `radius` of the target, interpolated; NaN when there is none."""
    speed, t = rec.speed, rec.t
    slow = speed[peak_index:stop] < threshold
    near = np.hypot(*(rec.position[peak_index:stop] - np.asarray(target)).T) <= radius
    stopped = np.flatnonzero(slow & near)
    if not stopped.size:
        return math.nan
    j = peak_index + int(stopped[0])  # > peak_index: the peak is not slow
    if speed[j - 1] < threshold:
        return float(t[j])  # crept onto the target already slow: it ends there
    return crossing(t, speed, j - 1, j, threshold)


def _first_rise(t, speed, start, peak_index, threshold) -> float:
    """First rise of the speed through `threshold` from sample `start` on (the target's
    appearance), interpolated; NaN when it is at or above it already there."""
    if speed[start] >= threshold:
        return math.nan
    j = start + int(np.argmax(speed[start:peak_index + 1] >= threshold))
    return crossing(t, speed, j - 1, j, threshold)


def _unmoved(on_s: float, posture: float, peak: float) -> VgrReach:
    """A reach with no movement found (or outside the recording): no reaction, no end."""
    nan = math.nan
    return VgrReach(on_s, nan, nan, nan, posture, nan, nan, nan, nan, nan, nan, nan, nan,
                    peak, nan, nan)


def _extrema(speed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the local maxima and minima of a profile; a plateau counts once,
    at its first sample; the ends are not extrema."""
    step = np.diff(speed)
    moving = np.flatnonzero(step != 0.0)
    signs = np.sign(step[moving])
    turns = np.flatnonzero(signs[:-1] != signs[1:])
    # the extremum is the sample after the last step of the run before the turn
    at = moving[turns] + 1
    rising = signs[turns] > 0
    return at[rising], at[~rising]


def _min_max(speed, maxima, minima) -> float:
    if maxima.size < 2:
        return 0.0
    rises = []
    for peak in maxima[1:]:
        dips = minima[minima < peak]
        rises.append(speed[peak] - speed[dips[-1]])
    return float(np.mean(rises))


def _path_length(rec: _Recording, t0: float, t1: float) -> float:
    """Length of the hand's path from t0 to t1 (positions interpolated at both ends)."""
    if not (math.isfinite(t0) and math.isfinite(t1)) or t1 < t0:
        return math.nan
    t = rec.t
    inside = (t > t0) & (t < t1)
    ends = [[np.interp(s, t, rec.position[:, i]) for i in range(2)] for s in (t0, t1)]
    points = np.vstack([ends[0], rec.position[inside], ends[1]])
    return float(np.sum(np.hypot(*np.diff(points, axis=0).T)))
