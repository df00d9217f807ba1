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

The polar plot (`strength_polar`, `closed_outline`) draws each direction's peak and mean
as two closed polygons, in the robot frame's directions named from the patient's seat
(`DIRECTION_NAMES`, `StrengthPolar`'s convention).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
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


# The directions as the patient sees them from the seat: the subject sits on the +y side
# facing −y, so the patient's left is +x (docs/frames.md, core.trajectory.toward_side).
DIRECTION_NAMES: dict[int, str] = {
    0: "left", 45: "toward-left", 90: "toward", 135: "toward-right",
    180: "right", 225: "away-right", 270: "away", 315: "away-left",
}
"""Each push direction (STRENGTH_DIRECTIONS_DEG) named from the patient's seat: toward
the patient's body or away from it (toward the robot), to the patient's left or right."""

SEEN_FROM_SEAT_RAD = math.pi
"""The turn from the robot's frame to the patient's view of the table: the patient faces
−y, so their view is the frame turned half a turn (both axes reversed, as the report's
page for the patient and the patient's screen draw it: docs/frames.md). Half a turn keeps
the sense of rotation: angles still grow counter-clockwise as the patient looks down."""


@dataclass(frozen=True, slots=True)
class StrengthPolar:
    """The isometric strength task's polar plot: per push direction its angle and the
    peak and mean force along it (`strength_figures`), and the line the patient was
    shown there (the robot's limit) when known.

    Directions are the robot frame's: 0 rad along +x, which is the patient's left, and
    angles growing counter-clockwise seen from above, so π/2 points toward the patient,
    π to their right and 3π/2 away from them, toward the robot (DIRECTION_NAMES)."""

    directions_deg: tuple[int, ...]
    angles_rad: np.ndarray
    peak_n: np.ndarray
    """N per direction; NaN where the direction was not measured."""
    mean_n: np.ndarray
    """N per direction; NaN where the direction was not measured."""
    line_n: np.ndarray | None = None
    """The line each direction's push was shown, N (NaN where unknown), or None."""

    def labels(self, between: str = " ") -> tuple[str, ...]:
        """Each direction's name and degrees ("left 0°"), the table's degrees with the
        patient's words, `between` them."""
        return tuple(f"{DIRECTION_NAMES[d]}{between}{d}°" for d in self.directions_deg)

    @property
    def not_measured(self) -> tuple[int, ...]:
        """The directions (degrees) with neither a peak nor a mean force."""
        return tuple(d for d, p, m in zip(self.directions_deg, self.peak_n, self.mean_n,
                                          strict=True) if math.isnan(p) and math.isnan(m))

    def largest_n(self) -> float:
        """The largest force the plot draws, N (0 when it draws none): its radial extent."""
        drawn = [closed_outline(self.angles_rad, v)[1] for v in self.drawn()]
        finite = np.concatenate(drawn)
        finite = finite[np.isfinite(finite)]
        return float(finite.max()) if finite.size else 0.0

    def drawn(self) -> tuple[np.ndarray, ...]:
        """The series the plot draws, in the order peak, mean and the line when known."""
        return (self.peak_n, self.mean_n) + (() if self.line_n is None else (self.line_n,))


def strength_polar(figures: Mapping[str, float],
                   lines_n: Mapping[int, float] | None = None) -> StrengthPolar:
    """The polar plot's data from the task's figures (a trial's metrics, keyed by
    `strength_key`): the 8 directions (rad, StrengthPolar's convention) and the peak and
    mean force along each (N, NaN where not measured: not in the metrics, or NaN there);
    `lines_n` the line each direction was shown by whole degrees
    (app.assessments.strength.lines_N), when the trial's parameters are known."""
    angles = np.radians(np.array(STRENGTH_DIRECTIONS_DEG, dtype=float))

    def per_direction(value) -> np.ndarray:
        return np.array([value(d) for d in STRENGTH_DIRECTIONS_DEG], dtype=float)

    def figure(kind: str):
        return lambda d: figures.get(strength_key(kind, d), math.nan)

    line = None if lines_n is None else per_direction(lambda d: lines_n.get(d, math.nan))
    return StrengthPolar(STRENGTH_DIRECTIONS_DEG, angles, per_direction(figure("peak")),
                         per_direction(figure("mean")), line)


def closed_outline(angles_rad, force_n) -> tuple[np.ndarray, np.ndarray]:
    """A polygon through each direction's force, closed back to the first direction
    (angle + 2π): (angles rad, radii N), one more than the directions.

    A direction not measured (NaN) stays NaN, so a plot leaves a gap there: the two
    edges meeting at it are not drawn. A clinician reads an edge straight across a
    missing direction as a force measured there, and a point at the centre as no force;
    neither was measured. A push the wrong way (a negative force, which the table
    prints signed) is drawn at the centre: no force in that direction."""
    angles = np.asarray(angles_rad, dtype=float)
    force = np.asarray(force_n, dtype=float)
    radii = np.where(np.isnan(force), math.nan, np.maximum(force, 0.0))
    return np.append(angles, angles[0] + 2.0 * math.pi), np.append(radii, radii[:1])
