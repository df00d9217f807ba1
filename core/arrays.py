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
    """Stack row-major 2×2 entries (a, b, c, d) into an array of shape (..., 2, 2) (put in
    place: three nested stacks took six times as long for a trial's reference)."""
    a, b, c, d = np.broadcast_arrays(*(np.asarray(t, dtype=float) for t in terms))
    out = np.empty((*a.shape, 2, 2))
    out[..., 0, 0] = a
    out[..., 0, 1] = b
    out[..., 1, 0] = c
    out[..., 1, 1] = d
    return out


def solve2(matrices, vectors) -> np.ndarray:
    """x with A x = b for each 2×2 A (..., 2, 2) and b (..., 2), by Cramer's rule. Written
    out rather than numpy.linalg.solve: LAPACK's result depends in its last bits on the
    CPU's kernels (a trial recorded on one machine would not repeat bit for bit on
    another), and these are plain IEEE products and sums everywhere."""
    a = np.asarray(matrices, dtype=float)
    b = np.asarray(vectors, dtype=float)
    a11, a12, a21, a22 = a[..., 0, 0], a[..., 0, 1], a[..., 1, 0], a[..., 1, 1]
    det = a11 * a22 - a12 * a21
    return np.stack(((a22 * b[..., 0] - a12 * b[..., 1]) / det,
                     (a11 * b[..., 1] - a21 * b[..., 0]) / det), axis=-1)


def joint_motion(model, position_m, velocity_m_s, acceleration_m_s2):
    """The joint angles, rates and accelerations (N, 2 each) of a two-joint model, the
    robot (eq. 3.1, 3.4, 3.5) or the arm (eq. 3.16, 3.18, 3.19), whose end follows the
    given Cartesian motion: θ = IK(P), θ̇ = J⁻¹ Ṗ, θ̈ = J⁻¹ (P̈ − J̇ θ̇)."""
    q = model.ik(position_m)
    sines = model.sines(q)  # J's and J̇'s, taken once
    jac = model.jacobian(q, sines)
    qd = solve2(jac, velocity_m_s)
    rhs = np.asarray(acceleration_m_s2, dtype=float) - np.einsum(
        "nij,nj->ni", model.jacobian_dot(q, qd, sines), qd)
    return q, qd, solve2(jac, rhs)


def groups(labels: np.ndarray, count: int) -> list[np.ndarray]:
    """For each label 0…count−1, the indices where `labels` (ints) holds it, ascending; any
    other label is in none. One stable sort for all of them: a mask per label went
    through the whole array once per label (a task's timetable has dozens of stretches
    and its patient's plan a sample a millisecond)."""
    labels = np.asarray(labels)
    order = np.argsort(labels, kind="stable")
    bounds = np.searchsorted(labels[order], np.arange(count + 1))
    return [order[bounds[k]:bounds[k + 1]] for k in range(count)]
