"""A trained model's generalised forces from its plain weights, with numpy only: what the
2 ms loop and `rehab learn evaluate` run (no JAX). The DeLaN's Euler–Lagrange terms come
from forward-mode derivatives of its networks (core.learning.networks.mlp_with_jacobian),
which the tests hold equal to JAX's automatic differentiation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.learning import networks as nw


@dataclass(frozen=True)
class DelanTerms:
    """The DeLaN's torque components at each sample, each (..., n) but H (..., n, n)."""

    H: np.ndarray
    inertial: np.ndarray     # H q̈
    coriolis: np.ndarray     # Ḣ q̇ − ½ ∂(q̇ᵀ H q̇)/∂q
    gravity: np.ndarray      # ∂V/∂q
    dissipative: np.ndarray  # d(q, q̇)

    @property
    def total(self) -> np.ndarray:
        return self.inertial + self.coriolis + self.gravity + self.dissipative


def delan_terms(spec: dict, params: dict, q, qd, qdd) -> DelanTerms:
    """Every term of the DeLaN's inverse dynamics, numpy, for (..., n) inputs."""
    q, qd, qdd = (np.asarray(a, dtype=float) for a in (q, qd, qdd))
    n = spec["dof"]
    qn = nw.normalised_positions(np, spec, q)
    tangent = np.broadcast_to(nw.position_tangents(spec),
                              (*q.shape[:-1], len(spec["position_inputs"]), n))
    activation = spec["activation"]
    # the outputs (..., m) and their derivatives (..., m, n)
    out, d_out = nw.mlp_with_jacobian(np, params, "L", qn, tangent, activation)
    L = nw.cholesky_factor(np, spec, out)
    scale = spec["mass_scale"]
    dL = np.zeros((*q.shape[:-1], n, n, n))  # ∂L_ab/∂q_k at [..., a, b, k]
    diag = np.arange(n)
    dL[..., diag, diag, :] = scale * nw.sigmoid(np, out[..., :n])[..., None] * d_out[..., :n, :]
    rows, cols = np.tril_indices(n, -1)
    dL[..., rows, cols, :] = scale * d_out[..., n:, :]
    H = L @ np.swapaxes(L, -1, -2)
    # ∂H/∂q_k = ∂L_k Lᵀ + L ∂L_kᵀ
    dH = np.einsum("...ack,...bc->...abk", dL, L)
    dH = dH + np.swapaxes(dH, -2, -3)
    coriolis = (np.einsum("...ijk,...j,...k->...i", dH, qd, qd)
                - 0.5 * np.einsum("...jki,...j,...k->...i", dH, qd, qd))
    _, dV = nw.mlp_with_jacobian(np, params, "V", qn, tangent, activation)
    gravity = spec["potential_scale"] * dV[..., 0, :]
    inertial = np.einsum("...ij,...j->...i", H, qdd)
    dissipative = nw.dissipative_forces(np, spec, params, q, qd)
    return DelanTerms(H, inertial, coriolis, gravity, dissipative)


def predict(spec: dict, params: dict, q, qd, qdd, cycle=None) -> np.ndarray:
    """The model's generalised forces for samples (N, n). A recurrent model runs through
    each cycle in order from a zero state (`cycle` numbers them; one cycle if None)."""
    q, qd, qdd = (np.asarray(a, dtype=float) for a in (q, qd, qdd))
    kind = spec["kind"]
    if kind == "fnn":
        return nw.fnn_forces(np, spec, params, q, qd, qdd)
    if kind == "delan":
        return delan_terms(spec, params, q, qd, qdd).total
    if kind == "rnn":
        cycle = np.zeros(len(q), dtype=int) if cycle is None else np.asarray(cycle)
        x = nw.normalised_inputs(np, spec, q, qd, qdd)
        out = np.empty_like(q)
        starts = np.flatnonzero(np.r_[True, cycle[1:] != cycle[:-1]])
        ends = np.r_[starts[1:], len(q)]
        # all cycles advance together, one sample at a time, padded to the longest
        length = int(np.max(ends - starts))
        h = np.zeros((len(starts), spec["hidden"][0]))
        for t in range(length):
            live = starts + t < ends
            index = starts[live] + t
            h[live] = nw.gru_step(np, params, h[live], x[index])
            out[index] = nw.rnn_output(np, spec, params, h[live])
        return out
    raise ValueError(f"unknown model kind {kind!r}")


class RecurrentState:
    """A GRU model evaluated one tick at a time, carrying its state (the loop's use)."""

    def __init__(self, spec: dict, params: dict) -> None:
        self.spec, self.params = spec, params
        self.h = np.zeros(spec["hidden"][0])

    def reset(self) -> None:
        self.h[:] = 0.0

    def step(self, q, qd, qdd) -> np.ndarray:
        x = nw.normalised_inputs(np, self.spec, np.asarray(q, float), np.asarray(qd, float),
                                 np.asarray(qdd, float))
        self.h = nw.gru_step(np, self.params, self.h, x)
        return nw.rnn_output(np, self.spec, self.params, self.h)
