"""Plane geometry of hand paths: convex hull, polygon area, a polygon clipped by a
convex one, and a point set's longest chord and its width across it.

Points are (N, 2) arrays in m. Polygons are vertex lists in order (either way
round), closed implicitly (the last vertex joins the first).
"""

from __future__ import annotations

import math

import numpy as np

from core.arrays import as_pairs
from core.errors import ParameterError

# Distances below a nanometre are rounding, not geometry (the robot resolves ~10 µm).
_EPS_M = 1e-9


def points(name: str, value) -> np.ndarray:
    """`value` as a finite (N, 2) float array, or a ParameterError naming it."""
    array = as_pairs(name, value)
    if array.ndim != 2:
        raise ParameterError(name, f"an array of shape {array.shape}", "shape (N, 2)")
    if not np.isfinite(array).all():
        index = int(np.argwhere(~np.isfinite(array))[0][0])
        raise ParameterError(name, f"not finite at row {index}", "finite positions in m")
    return array


def convex_hull(pts: np.ndarray) -> np.ndarray:
    """Vertices of the convex hull, counter-clockwise, without collinear points
    (Andrew's monotone chain, Inf Process Lett 9(5), 1979). Fewer than 3 vertices
    when the points are all on one line (2) or one point (1)."""
    unique = np.unique(np.asarray(pts, dtype=float), axis=0)  # sorted by x, then y
    if len(unique) < 3:
        return unique
    ordered = [(float(x), float(y)) for x, y in unique]

    def half(order):
        chain: list[tuple[float, float]] = []
        for p in order:
            while len(chain) >= 2 and _cross(chain[-2], chain[-1], p) <= 0.0:
                chain.pop()
            chain.append(p)
        return chain

    lower, upper = half(ordered), half(ordered[::-1])
    return np.array(lower[:-1] + upper[:-1])


def _cross(o, a, b) -> float:
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def signed_area(polygon: np.ndarray) -> float:
    """Shoelace area: positive counter-clockwise, negative clockwise (m²)."""
    poly = np.asarray(polygon, dtype=float)
    if len(poly) < 3:
        return 0.0
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def clip_by_convex(subject: np.ndarray, window: np.ndarray) -> np.ndarray:
    """The part of polygon `subject` (any simple polygon) inside the convex polygon
    `window` (counter-clockwise), by Sutherland & Hodgman (Commun ACM 17(1), 1974).
    With a concave subject the result may hold zero-width bridges along the window's
    edges; they add no area."""
    output = [np.asarray(p, dtype=float) for p in subject]
    n = len(window)
    for k in range(n):
        a, b = window[k], window[(k + 1) % n]
        inputs, output = output, []
        if not inputs:
            break
        previous = inputs[-1]
        for current in inputs:
            inside_now = _cross(a, b, current) >= 0.0
            inside_before = _cross(a, b, previous) >= 0.0
            if inside_now:
                if not inside_before:
                    output.append(_meet(previous, current, a, b))
                output.append(current)
            elif inside_before:
                output.append(_meet(previous, current, a, b))
            previous = current
    return np.array(output).reshape(-1, 2)


def _meet(p, q, a, b) -> np.ndarray:
    """Where segment p–q crosses the line through a and b."""
    d1, d2 = _cross(a, b, p), _cross(a, b, q)
    return p + (q - p) * (d1 / (d1 - d2))


def chord_and_width(pts: np.ndarray) -> tuple[float, float]:
    """The longest distance between two of the points (the major axis) and the
    points' extent perpendicular to that chord (the minor axis), m. The chord joins
    two hull vertices that are antipodal, found by rotating calipers (Shamos 1978)."""
    hull = convex_hull(pts)
    if len(hull) < 2:
        return 0.0, 0.0
    ring = [(float(x), float(y)) for x, y in hull]
    n = len(ring)
    best, ends = 0.0, (0, 1)
    k = 1
    for i in range(n):
        j = (i + 1) % n
        # advance k while it moves away from the edge i-j (the caliper turns with it)
        while n > 2 and abs(_cross(ring[i], ring[j], ring[(k + 1) % n])) > abs(
                _cross(ring[i], ring[j], ring[k])):
            k = (k + 1) % n
        for a in (i, j):
            d = math.dist(ring[a], ring[k])
            if d > best:
                best, ends = d, (a, k)
    if best < _EPS_M:
        return 0.0, 0.0
    axis = (hull[ends[1]] - hull[ends[0]]) / best
    across = hull @ np.array([-axis[1], axis[0]])
    return best, float(across.max() - across.min())
