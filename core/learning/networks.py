"""The three models' formulas, written once for any array module `xp` (numpy in the loop
and for evaluation, jax.numpy in training): a multi-layer perceptron, a GRU step, and the
parts of a Deep Lagrangian Network (Lutter et al. 2019; thesis section 2.5.3).

A model is a *spec* (plain numbers: its kind, sizes, input normalisation, output scales)
and *params* (a dict of named float64 arrays). Weights multiply on the right: z = a W + b.

DeLaN: the mass matrix H(q) = L(q) L(q)ᵀ with L lower-triangular, its diagonal positive
(softplus + ε), so H is symmetric positive definite for every q; V(q) the potential energy;
the Euler–Lagrange equation gives τ = H q̈ + Ḣ q̇ − ½ ∂(q̇ᵀ H q̇)/∂q + ∂V/∂q + d(q, q̇), with
d the learned dissipative and non-conservative term: a position network s(q) (friction that
depends on the load, stiffness), viscous friction diag(ν) q̇ and Coulomb friction
diag(φ) tanh(q̇ / v) with ν, φ ≥ 0 (softplus), which take energy out of the system.
"""

from __future__ import annotations

import itertools

import numpy as np

KINDS = ("fnn", "rnn", "delan")
DIAGONAL_EPS = 1e-4  # keeps H's eigenvalues away from zero (kg, kg·m²)


def mlp_shapes(prefix: str, sizes: list[int]) -> dict[str, tuple[int, ...]]:
    """The weight shapes of a perceptron with layer sizes `sizes` (inputs first)."""
    shapes = {}
    for i, (a, b) in enumerate(itertools.pairwise(sizes)):
        shapes[f"{prefix}.{i}.W"] = (a, b)
        shapes[f"{prefix}.{i}.b"] = (b,)
    return shapes


def param_shapes(spec: dict) -> dict[str, tuple[int, ...]]:
    """Every parameter's shape for a model spec."""
    n, hidden = spec["dof"], list(spec["hidden"])
    kind = spec["kind"]
    used = len(spec["position_inputs"])  # the coordinates the dynamics depends on
    if kind == "fnn":
        return mlp_shapes("net", [2 * n + used, *hidden, n])
    if kind == "rnn":
        h = hidden[0]
        shapes = {}
        for gate in ("r", "z", "n"):
            shapes[f"gru.{gate}.Wx"] = (2 * n + used, h)
            shapes[f"gru.{gate}.Wh"] = (h, h)
            shapes[f"gru.{gate}.bx"] = (h,)
            shapes[f"gru.{gate}.bh"] = (h,)
        shapes.update(mlp_shapes("out", [h, n]))
        return shapes
    if kind == "delan":
        shapes = mlp_shapes("L", [used, *hidden, n * (n + 1) // 2])
        shapes.update(mlp_shapes("V", [used, *hidden, 1]))
        shapes.update(mlp_shapes("s", [used, *list(spec["dissipation_hidden"]), n]))
        shapes["viscous"] = (n,)
        shapes["coulomb"] = (n,)
        return shapes
    raise ValueError(f"unknown model kind {kind!r}; one of {', '.join(KINDS)}")


def count_parameters(spec: dict) -> int:
    return int(sum(np.prod(s) for s in param_shapes(spec).values()))


def init_params(spec: dict, seed: int) -> dict[str, np.ndarray]:
    """Glorot-uniform weights, zero biases, from a fixed seed."""
    rng = np.random.default_rng(seed)
    params = {}
    for name, shape in param_shapes(spec).items():
        if len(shape) == 2:
            limit = np.sqrt(6.0 / (shape[0] + shape[1]))
            params[name] = rng.uniform(-limit, limit, shape)
        else:
            params[name] = np.zeros(shape)
    for name in ("viscous", "coulomb"):
        if name in params:  # start with little friction: softplus(−3) ≈ 0.05 of the scale
            params[name] = np.full(params[name].shape, -3.0)
    return params


ACTIVATIONS = ("tanh", "softplus")


def mlp(xp, params: dict, prefix: str, x, activation: str = "tanh"):
    """Hidden layers with `activation`, a linear output."""
    layers = _layers(params, prefix)
    for i, (W, b) in enumerate(layers):
        x = x @ W + b
        if i < len(layers) - 1:
            x = xp.tanh(x) if activation == "tanh" else softplus(xp, x)
    return x


def mlp_with_jacobian(xp, params: dict, prefix: str, x, dx, activation: str = "tanh"):
    """The perceptron's output and its derivative along the tangents `dx` (..., in, k):
    forward-mode differentiation, for inference without automatic differentiation."""
    layers = _layers(params, prefix)
    for i, (W, b) in enumerate(layers):
        x = x @ W + b
        dx = xp.einsum("...ik,io->...ok", dx, W)
        if i < len(layers) - 1:
            if activation == "tanh":
                x = xp.tanh(x)
                dx = (1.0 - x**2)[..., :, None] * dx
            else:
                dx = sigmoid(xp, x)[..., :, None] * dx
                x = softplus(xp, x)
    return x, dx


def _layers(params: dict, prefix: str) -> list:
    layers, i = [], 0
    while f"{prefix}.{i}.W" in params:
        layers.append((params[f"{prefix}.{i}.W"], params[f"{prefix}.{i}.b"]))
        i += 1
    return layers


def softplus(xp, x):
    return xp.logaddexp(0.0, x)


def sigmoid(xp, x):
    return 1.0 / (1.0 + xp.exp(-x))


def normalised_inputs(xp, spec: dict, q, qd, qdd):
    """(q, q̇, q̈) standardised by the training data's mean and spread, (..., 2n + used):
    the positions of cyclic coordinates (those the dynamics does not depend on, such as
    the pendulum's base position x1) left out."""
    n = spec["dof"]
    x = xp.concatenate([q, qd, qdd], axis=-1)
    x = (x - xp.asarray(spec["input_mean"])) / xp.asarray(spec["input_std"])
    return x[..., [*spec["position_inputs"], *range(n, 3 * n)]]


def fnn_forces(xp, spec: dict, params: dict, q, qd, qdd):
    """The feed-forward network's generalised forces, (..., n)."""
    out = mlp(xp, params, "net", normalised_inputs(xp, spec, q, qd, qdd))
    return out * xp.asarray(spec["output_std"]) + xp.asarray(spec["output_mean"])


def gru_step(xp, params: dict, h, x):
    """One GRU step (Cho et al. 2014): the new hidden state from the state h and input x."""
    def gate(name, hidden):
        return (x @ params[f"gru.{name}.Wx"] + params[f"gru.{name}.bx"],
                hidden @ params[f"gru.{name}.Wh"] + params[f"gru.{name}.bh"])

    rx, rh = gate("r", h)
    zx, zh = gate("z", h)
    nx, nh = gate("n", h)
    r = sigmoid(xp, rx + rh)
    z = sigmoid(xp, zx + zh)
    n = xp.tanh(nx + r * nh)
    return (1.0 - z) * n + z * h


def rnn_output(xp, spec: dict, params: dict, h):
    """The generalised forces read from the GRU's state, (..., n)."""
    out = mlp(xp, params, "out", h)
    return out * xp.asarray(spec["output_std"]) + xp.asarray(spec["output_mean"])


def cholesky_factor(xp, spec: dict, out):
    """L from the network's n (n+1)/2 outputs: a positive diagonal (softplus + ε) and the
    strictly lower part, (..., n, n)."""
    n = spec["dof"]
    scale = spec["mass_scale"]
    diagonal = scale * softplus(xp, out[..., :n]) + DIAGONAL_EPS
    rows, cols = np.tril_indices(n, -1)
    L = xp.zeros((*out.shape[:-1], n, n))
    if hasattr(L, "at"):  # jax arrays are immutable
        L = L.at[..., np.arange(n), np.arange(n)].set(diagonal)
        return L.at[..., rows, cols].set(scale * out[..., n:])
    L[..., np.arange(n), np.arange(n)] = diagonal
    L[..., rows, cols] = scale * out[..., n:]
    return L


def normalised_positions(xp, spec: dict, q):
    """The positions the DeLaN's networks take: standardised, cyclic coordinates left out."""
    n = spec["dof"]
    qn = (q - xp.asarray(spec["input_mean"][:n])) / xp.asarray(spec["input_std"][:n])
    return qn[..., spec["position_inputs"]]


def position_tangents(spec: dict) -> np.ndarray:
    """∂(normalised positions)/∂q, (used, n): the seed of forward-mode derivatives."""
    n = spec["dof"]
    return np.diag(1.0 / np.asarray(spec["input_std"][:n]))[spec["position_inputs"]]


def mass_matrix(xp, spec: dict, params: dict, q):
    """H(q) = L Lᵀ, symmetric positive definite by construction, (..., n, n)."""
    L = cholesky_factor(xp, spec, mlp(xp, params, "L", normalised_positions(xp, spec, q),
                                      spec["activation"]))
    return L @ xp.swapaxes(L, -1, -2)


def potential(xp, spec: dict, params: dict, q):
    """V(q), J, (...,)."""
    qn = normalised_positions(xp, spec, q)
    return spec["potential_scale"] * mlp(xp, params, "V", qn, spec["activation"])[..., 0]


def dissipative_forces(xp, spec: dict, params: dict, q, qd):
    """d(q, q̇): the position network s(q) plus viscous and Coulomb friction, (..., n)."""
    force_scale = xp.asarray(spec["output_std"])
    s = mlp(xp, params, "s", normalised_positions(xp, spec, q), spec["activation"]) * force_scale
    rate_scale = xp.asarray(spec["input_std"][spec["dof"]:2 * spec["dof"]])
    viscous = softplus(xp, params["viscous"]) * force_scale / rate_scale * qd
    coulomb = (softplus(xp, params["coulomb"]) * force_scale
               * xp.tanh(qd / (spec["coulomb_speed_fraction"] * rate_scale)))
    return s + viscous + coulomb
