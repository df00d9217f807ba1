"""Isometric strength: with the robot holding the hand still, the patient pushes in
8 directions; per direction the peak and the mean of the hand force's component
along it over the push's hold window, and the polar plot's data.

InMotion evaluation, shoulder strength (Bioelectronic Medicine 7:20, 2021,
Table 4, doi:10.1186/s42234-021-00081-9). Our reading of the figures:

* component along the push direction u = (cos θ, sin θ): F·u, F the force the
  hand applies to the handle in the robot's frame (N), so a push the right way
  is positive and a push the wrong way negative;
* *peak* of a direction: the highest component over its windows (the best of the
  tries, as in dynamometry); *mean*: the mean over its windows of each window's
  mean component (samples within [start, end], evenly sampled);
* `strength_peak_force_n` / `strength_mean_force_n`: the mean over the directions
  that have a window of their peaks / means;
* `strength_at_limit_count`: the directions in which any push reached the force
  the robot can hold (flagged by the robot's hold, `PushWindow.at_limit`): their
  figures are lower bounds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from core.assessment.figures import STRENGTH_DIRECTIONS_DEG, strength_key
from core.errors import ParameterError, check_finite
from core.signal import as_series, sample_interval

# A push direction must be one of the 8 to within this (its key names whole degrees).
DIRECTION_TOLERANCE_DEG = 0.5


@dataclass(frozen=True, slots=True)
class PushWindow:
    """One push: its direction (rad, counter-clockwise from the robot frame's +x),
    the hold window it is measured over (s), and whether the robot's hold reached
    its force limit during it."""

    direction_rad: float
    start_s: float
    end_s: float
    at_limit: bool = False

    def __post_init__(self) -> None:
        for name in ("direction_rad", "start_s", "end_s"):
            check_finite(name, getattr(self, name), "rad" if name == "direction_rad" else "s")
        if not self.end_s > self.start_s:
            raise ParameterError("end_s", self.end_s, f"> start_s = {self.start_s:g} s",
                                 "a push's window needs a duration")

    @property
    def direction_deg(self) -> int:
        """The push's direction as one of STRENGTH_DIRECTIONS_DEG (refuses others)."""
        degrees = math.degrees(self.direction_rad) % 360.0
        nearest = round(degrees / 45.0) % 8 * 45
        off = abs((degrees - nearest + 180.0) % 360.0 - 180.0)
        if off > DIRECTION_TOLERANCE_DEG:
            raise ParameterError("direction_rad", self.direction_rad,
                                 "a multiple of 45° (π/4 rad) to within 0.5°",
                                 "the battery pushes in 8 directions")
        return nearest


def strength_figures(t_s, force_n, windows: Sequence[PushWindow]) -> dict[str, float]:
    """The task's figures keyed as core.assessment.FIGURES from time stamps (N,) s,
    the hand force (N, 2) N and the push windows; a direction without a window (or
    whose windows hold no sample) has NaN figures."""
    t = np.asarray(t_s, dtype=float)
    sample_interval(t)
    force = as_series("force_n", force_n, t.size, 2)
    peaks: dict[int, list[float]] = {deg: [] for deg in STRENGTH_DIRECTIONS_DEG}
    means: dict[int, list[float]] = {deg: [] for deg in STRENGTH_DIRECTIONS_DEG}
    capped: set[int] = set()
    for window in windows:
        deg = window.direction_deg
        inside = (t >= window.start_s) & (t <= window.end_s)
        if window.at_limit:
            capped.add(deg)
        if not inside.any():
            continue
        along = force[inside] @ np.array([math.cos(window.direction_rad),
                                          math.sin(window.direction_rad)])
        peaks[deg].append(float(along.max()))
        means[deg].append(float(along.mean()))
    figures: dict[str, float] = {}
    for deg in STRENGTH_DIRECTIONS_DEG:
        figures[strength_key("peak", deg)] = max(peaks[deg]) if peaks[deg] else math.nan
        figures[strength_key("mean", deg)] = float(np.mean(means[deg])) if means[deg] \
            else math.nan
    for kind in ("peak", "mean"):
        values = [figures[strength_key(kind, deg)] for deg in STRENGTH_DIRECTIONS_DEG]
        finite = [v for v in values if math.isfinite(v)]
        figures[f"strength_{kind}_force_n"] = float(np.mean(finite)) if finite else math.nan
    figures["strength_at_limit_count"] = float(len(capped))
    return figures


def strength_polar(figures: dict[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The polar plot's data from the task's figures: the 8 directions (rad) and the
    peak and mean force along each (N, NaN where not measured)."""
    angles = np.radians(np.array(STRENGTH_DIRECTIONS_DEG, dtype=float))
    peak = np.array([figures.get(strength_key("peak", d), math.nan)
                     for d in STRENGTH_DIRECTIONS_DEG], dtype=float)
    mean = np.array([figures.get(strength_key("mean", d), math.nan)
                     for d in STRENGTH_DIRECTIONS_DEG], dtype=float)
    return angles, peak, mean
