"""Plane geometry of hand paths: convex hull, polygon area, a polygon clipped by a
convex one, and a point set's longest chord and its width across it.

Points are (N, 2) arrays in m. Polygons are vertex lists in order (either way
round), closed implicitly (the last vertex joins the first).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import ConvexHull, QhullError

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
    """Vertices of the convex hull, counter-clockwise, without collinear points. Fewer
    than 3 vertices when the points are all on one line (its two ends) or one point.

    Qhull (scipy.spatial.ConvexHull; Barber, Dobkin & Huhdanpaa, ACM TOMS 22(4), 1996)
    for speed: a minute of a hand's path is 30,000 points. Where Qhull refuses a set
    as too flat for its precision, Andrew's monotone chain (`monotone_chain`) decides."""
    array = np.asarray(pts, dtype=float)
    if len(array) < 3:
        return np.unique(array, axis=0)
    centred = array - array.mean(axis=0)
    spread, axes = np.linalg.eigh(centred.T @ centred)  # ascending
    if spread[0] <= 1e-24 * spread[1]:  # on one line (to rounding): its two ends
        along = centred @ axes[:, 1]
        ends = array[[int(np.argmin(along)), int(np.argmax(along))]]
        return ends[:1] if np.array_equal(ends[0], ends[1]) else ends
    try:
        return array[ConvexHull(array).vertices]  # counter-clockwise in 2-D
    except QhullError:
        return monotone_chain(np.unique(array, axis=0))


def monotone_chain(unique: np.ndarray) -> np.ndarray:
    """`convex_hull` of distinct points sorted by x then y, by Andrew's monotone chain
    (Inf Process Lett 9(5), 1979): exact but a Python loop over every point."""
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
    """Shoelace area: positive counter-clockwise, negative clockwise (m²), summed as the
    triangles of the first vertex with each edge (the same sum, moved to that vertex): the
    plain sum's products of coordinates far from the origin cancel and lose a small area
    (a hull 5e-278 m wide at y = 0.625 m came out 0, hypothesis found)."""
    poly = np.asarray(polygon, dtype=float)
    if len(poly) < 3:
        return 0.0
    d = poly[1:] - poly[0]
    return 0.5 * float(np.sum(d[:-1, 0] * d[1:, 1] - d[:-1, 1] * d[1:, 0]))


def clip_by_convex(subject: np.ndarray, window: np.ndarray) -> np.ndarray:
    """The part of polygon `subject` (any simple polygon) inside the convex polygon
    `window` (counter-clockwise), by Sutherland & Hodgman (Commun ACM 17(1), 1974).
    With a concave subject the result may hold zero-width bridges along the window's
    edges; they add no area."""
    output = [(float(x), float(y)) for x, y in subject]
    edges = [(float(x), float(y)) for x, y in window]
    n = len(edges)
    for k in range(n):
        a, b = edges[k], edges[(k + 1) % n]
        inputs, output = output, []
        if not inputs:
            break
        previous = inputs[-1]
        side_before = _cross(a, b, previous)
        for current in inputs:
            side_now = _cross(a, b, current)
            if side_now >= 0.0:
                if side_before < 0.0:
                    output.append(_meet(previous, current, side_before, side_now))
                output.append(current)
            elif side_before >= 0.0:
                output.append(_meet(previous, current, side_before, side_now))
            previous, side_before = current, side_now
    return np.array(output, dtype=float).reshape(-1, 2)


def _meet(p, q, d1: float, d2: float) -> tuple[float, float]:
    """Where segment p-q crosses the window's edge line, p and q at signed distances
    (times the edge's length) d1 and d2 from it."""
    share = d1 / (d1 - d2)
    return (p[0] + (q[0] - p[0]) * share, p[1] + (q[1] - p[1]) * share)


def chord_and_width(pts: np.ndarray) -> tuple[float, float]:
    """The longest distance between two of the points (the major axis) and the
    points' extent perpendicular to that chord (the minor axis), m.

    The chord joins two antipodal vertices of the convex hull (Shamos 1978, rotating
    calipers): for each hull edge, the vertex farthest across from it is where the
    edges' direction has turned by half a turn (a search in the edges' cumulative
    angles); the longest of the distances from the edge's two ends to that vertex and
    its two neighbours (parallel edges have two farthest vertices) is the chord."""
    ring = convex_hull(pts)
    if len(ring) < 2:
        return 0.0, 0.0
    if len(ring) == 2:
        pairs_a, pairs_b = np.array([0]), np.array([1])
    else:
        h = len(ring)
        edges = np.roll(ring, -1, axis=0) - ring
        # cumulative direction of the edges: increasing, by 2π over the hull; kept
        # monotonic against rounding at nearly straight vertices
        turned = np.maximum.accumulate(np.unwrap(np.arctan2(edges[:, 1], edges[:, 0])))
        across = np.searchsorted(np.concatenate([turned, turned + 2 * math.pi]),
                                 turned + math.pi)
        ends = np.arange(h)
        pairs_a = np.concatenate([np.tile(ends, 3), np.tile((ends + 1) % h, 3)])
        pairs_b = np.tile(np.concatenate([(across - 1) % h, across % h, (across + 1) % h]), 2)
    lengths = np.hypot(*(ring[pairs_b] - ring[pairs_a]).T)
    k = int(np.argmax(lengths))
    best = float(lengths[k])
    if best < _EPS_M:
        return 0.0, 0.0
    axis = (ring[pairs_b[k]] - ring[pairs_a[k]]) / best
    spread = ring @ np.array([-axis[1], axis[0]])
    return best, float(spread.max() - spread.min())
