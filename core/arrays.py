"""Small helpers shared by the models: one formula for floats and arrays, 2×2 algebra."""

from __future__ import annotations

import math

import numpy as np

from core.errors import ParameterError


def xp_of(value):
    """The math namespace for `value`: numpy for arrays, `math` for plain numbers.

    Model formulas are written once with `xp.cos`, `xp.atan2`, … so the 2 ms tick
    runs them on plain floats (a few µs) and analyses run them on whole arrays.
    """
    return np if isinstance(value, np.ndarray) else math


def as_pairs(name: str, value) -> np.ndarray:
    """`value` as a float array of shape (..., 2), or a ParameterError naming it."""
    array = np.asarray(value, dtype=float)
    if array.ndim == 0 or array.shape[-1] != 2:
        raise ParameterError(name, f"an array of shape {array.shape}", "shape (..., 2)")
    return array


def matrix2(terms) -> np.ndarray:
    """Stack row-major 2×2 entries (a, b, c, d) into an array of shape (..., 2, 2)."""
    a, b, c, d = np.broadcast_arrays(*(np.asarray(t, dtype=float) for t in terms))
    return np.stack((np.stack((a, b), axis=-1), np.stack((c, d), axis=-1)), axis=-2)


def smallest_singular_value(a, b, c, d):
    """σ_min of [[a, b], [c, d]] in closed form (floats or arrays)."""
    xp = xp_of(a)
    total = a * a + b * b + c * c + d * d
    det = a * d - b * c
    disc = total * total - 4.0 * det * det
    if xp is math:
        disc = max(disc, 0.0)
        return math.sqrt(max(0.5 * (total - math.sqrt(disc)), 0.0))
    disc = np.maximum(disc, 0.0)
    return np.sqrt(np.maximum(0.5 * (total - np.sqrt(disc)), 0.0))


def solve2_damped(a, b, c, d, r1, r2, threshold):
    """Solve [[a, b], [c, d]] x = r, damped near a singularity.

    Where σ_min ≥ threshold this is the exact inverse. Below it, the damped
    least-squares solution x = (AᵀA + λ²I)⁻¹ Aᵀ r with λ² = threshold² − σ_min²,
    which grows smoothly from zero, so the result has no jump where damping
    starts. Returns (x1, x2, damped) with `damped` a bool or a bool array.
    """
    sigma = smallest_singular_value(a, b, c, d)
    lam2 = threshold * threshold - sigma * sigma
    xp = xp_of(a)
    if xp is math:
        if lam2 <= 0.0:
            det = a * d - b * c
            return ((d * r1 - b * r2) / det, (a * r2 - c * r1) / det, False)
        return (*_damped(a, b, c, d, r1, r2, lam2), True)
    damped = lam2 > 0.0
    x1, x2 = _damped(a, b, c, d, r1, r2, np.maximum(lam2, 0.0))
    return (x1, x2, damped)


def _damped(a, b, c, d, r1, r2, lam2):
    # (AᵀA + λ²I) x = Aᵀ r; with λ² = 0 this is the exact solution.
    p11 = a * a + c * c + lam2
    p12 = a * b + c * d
    p22 = b * b + d * d + lam2
    s1 = a * r1 + c * r2
    s2 = b * r1 + d * r2
    det = p11 * p22 - p12 * p12
    return ((p22 * s1 - p12 * s2) / det, (p11 * s2 - p12 * s1) / det)
