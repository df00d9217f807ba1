"""Small array helpers shared by the models: checked (..., 2) inputs and 2×2 stacking."""

from __future__ import annotations

import numpy as np

from core.errors import ParameterError


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
