"""The three models in JAX, for training: the same formulas as the numpy inference
(core.learning.networks) with jax.numpy, and the DeLaN's Euler–Lagrange terms by automatic
differentiation (Ḣ q̇ through `jax.jvp`, ∂(q̇ᵀ H q̇)/∂q and ∂V/∂q through `jax.grad`).

Imported only by the training (core.learning.training), never at the console's start.
"""

from __future__ import annotations

import jax

jax.config.update("jax_enable_x64", True)  # float64 as the data and the numpy inference

import jax.numpy as jnp  # noqa: E402  (after x64 is on)

from core.learning import networks as nw  # noqa: E402


def delan_sample_terms(spec: dict, params: dict, q, qd, qdd) -> dict:
    """One sample's torque components, each (n,), H (n, n), by the Euler–Lagrange equation."""
    def H_of(position):
        return nw.mass_matrix(jnp, spec, params, position)

    H, H_dot = jax.jvp(H_of, (q,), (qd,))
    kinetic_gradient = jax.grad(lambda position: qd @ H_of(position) @ qd)(q)
    return {"H": H, "inertial": H @ qdd,
            "coriolis": H_dot @ qd - 0.5 * kinetic_gradient,
            "gravity": jax.grad(lambda p: nw.potential(jnp, spec, params, p))(q),
            "dissipative": nw.dissipative_forces(jnp, spec, params, q, qd)}


def delan_components(spec: dict, params: dict, q, qd, qdd) -> dict:
    """The DeLaN's torque components for samples (N, n)."""
    return jax.vmap(lambda a, b, c: delan_sample_terms(spec, params, a, b, c))(q, qd, qdd)


def delan_forces(spec: dict, params: dict, q, qd, qdd):
    """The DeLaN's generalised forces for samples (N, n): the sum of its components."""
    terms = delan_components(spec, params, q, qd, qdd)
    return terms["inertial"] + terms["coriolis"] + terms["gravity"] + terms["dissipative"]


def fnn_forces(spec: dict, params: dict, q, qd, qdd):
    return nw.fnn_forces(jnp, spec, params, q, qd, qdd)


def rnn_forces(spec: dict, params: dict, x):
    """A GRU through windows of normalised inputs (B, T, 3n) from a zero state: (B, T, n)."""
    def step(h, x_t):
        h = nw.gru_step(jnp, params, h, x_t)
        return h, nw.rnn_output(jnp, spec, params, h)

    h0 = jnp.zeros((x.shape[0], spec["hidden"][0]))
    _, out = jax.lax.scan(step, h0, jnp.swapaxes(x, 0, 1))
    return jnp.swapaxes(out, 0, 1)
