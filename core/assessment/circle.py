"""Circle drawing (InMotion shoulder-elbow evaluation): circle ratio, shoulder-elbow
joint independence, SPARC, LDLJ and mean speed of one circle, and the task's
figures over the clockwise and counter-clockwise circles.

* *Circle ratio* (InMotion evaluation, Bioelectronic Medicine 7:20, 2021, Table 4,
  doi:10.1186/s42234-021-00081-9; Krebs et al., Stroke 45:200, 2014,
  doi:10.1161/STROKEAHA.113.002296): minor axis / major axis. Our reading of the
  axes: the major axis is the drawn path's longest chord (the largest distance
  between two of its points), the minor axis the path's extent perpendicular to
  that chord. For an ellipse these are its two axes whatever the drawing speed
  (principal axes of the sampled points would weight the slow parts more); a
  line gives 0, a circle 1.
* *Joint independence* (Dipietro et al., J Neurophysiol 98:757, 2007,
  doi:10.1152/jn.01295.2006): the paper was not available to us. Our reading:
  1 − |r|, r the Pearson correlation of the shoulder and the elbow angle over the
  circle (core.metrics.pearson). A circle drawn with the joints out of phase
  (about 90°) gives r ≈ 0 and 1; joints locked together in one synergy give
  |r| ≈ 1 and 0. Any angle convention will do (offsets and signs do not change
  |r|). NaN when either joint did not move.
* *SPARC* of the hand speed and *LDLJ* of the hand velocity (vector form) over the
  circle and the rest after it (core.smoothness; Balasubramanian et al. 2015). A circle
  is not a discrete movement: compare these only with circles. NaN when the hand never
  reached 0.01 m/s (core.reaches' threshold of a movement): the smoothness of noise
  means nothing. Why the rest after it (ours): both measures are defined for a movement
  from rest to rest, and a speed cut while the hand still moves ends in a step whose
  spectrum decides SPARC. Over the 20 s of the dot's five laps alone, SPARC's adaptive
  cut-off fell at 0.5–0.7 Hz, set by the sinc of that step, for a healthy and a weak
  virtual patient alike, and the figure ranked the window's edges, not the drawing
  (docs/assessments.md, Submovements).
* *Mean speed*: the path's length (the sum of the distances between samples) over
  the time from the first sample to the last.

Give each circle's own samples (from its start cue to its end) and the rest after it,
with `drawing` marking the circle's: the battery cuts them by the trial's phases (the
exercise, then the hold where the dot rests).
"""

from __future__ import annotations

import math

import numpy as np

from core.assessment.figures import CIRCLE_BASE_KEYS, circle_key
from core.assessment.geometry import chord_and_width
from core.errors import ParameterError
from core.metrics import pearson
from core.reaches import DEFAULT_MIN_PEAK_SPEED_M_S
from core.signal import as_series, sample_interval, smoothed_derivatives
from core.smoothness import ldlj, sparc

SPEED_CUTOFF_HZ = 10.0


def circle_figures(t_s, position_m, joint_angles_rad, *, velocity_m_s=None,
                   drawing=None) -> dict[str, float]:
    """One circle's figures keyed by CIRCLE_BASE_KEYS: time stamps (N,) s evenly sampled, hand
    positions (N, 2) m, shoulder and elbow angles (N, 2) rad, the hand velocity (N, 2)
    m/s (default: the positions low-passed at 10 Hz and differentiated), and `drawing`
    (N,) true on the circle's samples, false on the rest after it (default: all the
    circle's). The smoothness is measured over all of them, the rest over the drawing."""
    t = np.asarray(t_s, dtype=float)
    dt_s = sample_interval(t)
    position = as_series("position_m", position_m, t.size, 2)
    angles = as_series("joint_angles_rad", joint_angles_rad, t.size, 2)
    if velocity_m_s is None:
        velocity = smoothed_derivatives(position, dt_s, SPEED_CUTOFF_HZ, name="position_m").rate
    else:
        velocity = as_series("velocity_m_s", velocity_m_s, t.size, 2)
    drawn = (np.ones(t.size, dtype=bool) if drawing is None
             else as_series("drawing", drawing, t.size) != 0.0)
    if not drawn.any():
        raise ParameterError("drawing", "no sample", "the circle's samples marked true")
    speed = np.hypot(velocity[:, 0], velocity[:, 1])
    circle = position[drawn]
    major, minor = chord_and_width(circle)
    correlation = pearson(angles[drawn, 0], angles[drawn, 1])
    path = float(np.sum(np.hypot(*np.diff(circle, axis=0).T)))
    moved = speed.max() >= DEFAULT_MIN_PEAK_SPEED_M_S  # below: rounding and encoder noise
    return {
        # a round set can come out a hair wider across than along its chord: rounding
        "circle_ratio": min(minor / major, 1.0) if major > 0.0 else math.nan,
        "circle_joint_independence": 1.0 - abs(correlation),
        "circle_sparc": sparc(speed, dt_s) if moved else math.nan,
        "circle_ldlj": ldlj(velocity, dt_s) if moved and t.size >= 4 else math.nan,
        "circle_mean_speed_m_s": path / float(t[drawn][-1] - t[drawn][0]),
    }


def circle_task_figures(cw: dict[str, float], ccw: dict[str, float]) -> dict[str, float]:
    """The task's figures from the two circles' (each as `circle_figures` gives them):
    each figure per way (core.assessment.figures.circle_key) and the mean of the two
    ways (the one defined when the other is NaN), keyed as core.assessment.FIGURES."""
    figures: dict[str, float] = {}
    for base in CIRCLE_BASE_KEYS:
        both = [float(cw[base]), float(ccw[base])]
        finite = [v for v in both if math.isfinite(v)]
        figures[base] = float(np.mean(finite)) if finite else math.nan
    for way, values in (("cw", cw), ("ccw", ccw)):
        for base in CIRCLE_BASE_KEYS:
            figures[circle_key(base, way)] = float(values[base])
    return figures
