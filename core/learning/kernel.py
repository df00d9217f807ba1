"""A trained FNN or DeLaN of the 2-joint robot as a per-tick kernel (core.kernels): the
formulas of core.learning.tick.TickModel written in the part of Python numba compiles, on
one flat vector of the model's weights, so that a "CT-PID (learned: …)" trial's tick runs
compiled in the loop like the analytic one (device.compiled; docs/performance.md,
"Learned dynamics"). The tests hold it equal to TickModel to 1e-6.

`pack(spec, params)` lays the vector out: a header (H_*), the normalisation (N_*), each
perceptron as [layers, then per layer n_in, n_out, W row-major (z = a W + b), b], the
DeLaN's dissipation already in SI units, and a scratch region at the end that the kernel
writes into (two ping-pong buffers of a value and its derivatives along θ1 and θ2 per
unit), so the kernel allocates nothing. Interpreted, the kernel is a few hundred times
slower than TickModel: it is meant to run compiled.
"""

from __future__ import annotations

import numpy as np

from core.kernels import kernel, xp
from core.learning import networks as nw

KIND_FNN, KIND_DELAN = 1.0, 2.0
TANH, SOFTPLUS = 1.0, 0.0
(H_KIND, H_NET, H_V, H_S, H_WIDTH, H_SCRATCH, H_MASS_SCALE, H_POTENTIAL_SCALE,
 H_ACTIVATION, H_SIZE) = range(10)
# the normalisation, after the header: the inputs' (θ1, θ2, θ̇1, θ̇2, θ̈1, θ̈2) mean and
# spread, the torques' mean and spread, the DeLaN's viscous, Coulomb and Coulomb-speed pairs
N_IN_MEAN = H_SIZE
N_IN_STD = N_IN_MEAN + 6
N_OUT_MEAN = N_IN_STD + 6
N_OUT_STD = N_OUT_MEAN + 2
N_VISCOUS = N_OUT_STD + 2
N_COULOMB = N_VISCOUS + 2
N_COULOMB_SPEED = N_COULOMB + 2
N_END = N_COULOMB_SPEED + 2
_EPS = nw.DIAGONAL_EPS  # the floor of H's Cholesky diagonal, as the networks have it


def pack(spec: dict, params: dict) -> np.ndarray:
    """The model as the kernel's vector (float64). Refuses what the kernel does not
    compute: another number of joints, a model that leaves out a joint angle, a GRU."""
    kind = spec.get("kind")
    if spec.get("dof") != 2 or list(spec.get("position_inputs", [])) != [0, 1]:
        raise ValueError("a compiled model takes both joint angles of the 2-joint robot")
    if kind not in ("fnn", "delan"):
        raise ValueError(f"a {kind} model has no compiled form (FNN and DeLaN have)")
    std = np.asarray(spec["input_std"], float)
    out_std = np.asarray(spec["output_std"], float)
    body: list[float] = []
    offsets = {}
    prefixes = ("net",) if kind == "fnn" else ("L", "V", "s")
    width = 6
    for prefix in prefixes:
        layers = nw._layers(params, prefix)
        offsets[prefix] = N_END + len(body)
        body.append(float(len(layers)))
        for W, b in layers:
            W, b = np.asarray(W, float), np.asarray(b, float)
            body += [float(W.shape[0]), float(W.shape[1]), *W.reshape(-1), *b]
            width = max(width, *W.shape)
    header = [0.0] * H_SIZE
    header[H_KIND] = KIND_FNN if kind == "fnn" else KIND_DELAN
    header[H_NET] = float(offsets.get("net", offsets.get("L")))
    header[H_V] = float(offsets.get("V", 0))
    header[H_S] = float(offsets.get("s", 0))
    header[H_WIDTH] = float(width)
    header[H_SCRATCH] = float(N_END + len(body))
    norm = [*spec["input_mean"], *std, *spec["output_mean"], *out_std]
    dissipation = [0.0] * 6
    if kind == "delan":
        header[H_MASS_SCALE] = float(spec["mass_scale"])
        header[H_POTENTIAL_SCALE] = float(spec["potential_scale"])
        header[H_ACTIVATION] = TANH if spec["activation"] == "tanh" else SOFTPLUS
        softplus = np.logaddexp(0.0, np.asarray(params["viscous"], float))
        dissipation = [*(softplus * out_std / std[2:4]),
                       *(np.logaddexp(0.0, np.asarray(params["coulomb"], float)) * out_std),
                       *(spec["coulomb_speed_fraction"] * std[2:4])]
    return np.asarray([*header, *norm, *dissipation, *body, *([0.0] * 6 * width)], float)


@kernel
def softplus_of(x):
    """log(1 + eˣ) without overflow."""
    return (x if x > 0.0 else 0.0) + xp.log1p(xp.exp(-abs(x)))


@kernel
def mlp_forward(w, offset, scratch, width, activation, tangent):
    """The perceptron at w[offset] on the input in the scratch's first buffer (values,
    then the derivatives along θ1 and θ2 when `tangent`), hidden layers tanh or softplus,
    the last linear; returns where in w its output's buffer starts."""
    layers = int(w[offset])
    p = offset + 1
    src = scratch
    dst = scratch + 3 * width
    for layer in range(layers):
        n_in = int(w[p])
        n_out = int(w[p + 1])
        weights = p + 2
        bias = weights + n_in * n_out
        hidden = layer < layers - 1
        for j in range(n_out):
            z = w[bias + j]
            d1 = 0.0
            d2 = 0.0
            for i in range(n_in):
                wij = w[weights + i * n_out + j]
                z += w[src + i] * wij
                if tangent:
                    d1 += w[src + width + i] * wij
                    d2 += w[src + 2 * width + i] * wij
            if hidden:
                if activation == TANH:
                    z = xp.tanh(z)
                    slope = 1.0 - z * z
                else:
                    slope = 1.0 / (1.0 + xp.exp(-z))
                    z = softplus_of(z)
                d1 *= slope
                d2 *= slope
            w[dst + j] = z
            w[dst + width + j] = d1
            w[dst + 2 * width + j] = d2
        p = bias + n_out
        swap = src
        src = dst
        dst = swap
    return src


@kernel
def seed_positions(w, scratch, width, q1, q2):
    """The normalised joint angles and their derivatives along θ1, θ2 into the scratch."""
    w[scratch] = (q1 - w[N_IN_MEAN]) / w[N_IN_STD]
    w[scratch + 1] = (q2 - w[N_IN_MEAN + 1]) / w[N_IN_STD + 1]
    w[scratch + width] = 1.0 / w[N_IN_STD]
    w[scratch + width + 1] = 0.0
    w[scratch + 2 * width] = 0.0
    w[scratch + 2 * width + 1] = 1.0 / w[N_IN_STD + 1]


@kernel
def learned_torques(w, q1, q2, qd1, qd2, qdd1, qdd2):
    """The model's joint torques (N·m) for (θ, θ̇, θ̈), one sample: the FNN's output, or
    the DeLaN's H q̈ + Ḣ q̇ − ½ ∂(q̇ᵀ H q̇)/∂q + ∂V/∂q + d(q, q̇) (core.learning.tick)."""
    width = int(w[H_WIDTH])
    scratch = int(w[H_SCRATCH])
    if w[H_KIND] == KIND_FNN:
        values = (q1, q2, qd1, qd2, qdd1, qdd2)
        for i in range(6):
            w[scratch + i] = (values[i] - w[N_IN_MEAN + i]) / w[N_IN_STD + i]
        out = mlp_forward(w, int(w[H_NET]), scratch, width, TANH, False)
        return (w[out] * w[N_OUT_STD] + w[N_OUT_MEAN],
                w[out + 1] * w[N_OUT_STD + 1] + w[N_OUT_MEAN + 1])
    activation = w[H_ACTIVATION]
    scale = w[H_MASS_SCALE]
    # the Cholesky factor L = [[l00, 0], [l10, l11]] and its derivatives along θ1, θ2
    seed_positions(w, scratch, width, q1, q2)
    out = mlp_forward(w, int(w[H_NET]), scratch, width, activation, True)
    o0 = w[out]
    o1 = w[out + 1]
    l00 = scale * softplus_of(o0) + _EPS
    l11 = scale * softplus_of(o1) + _EPS
    l10 = scale * w[out + 2]
    s0 = scale / (1.0 + xp.exp(-o0))
    s1 = scale / (1.0 + xp.exp(-o1))
    a00 = s0 * w[out + width]          # ∂l00/∂θ1
    b00 = s0 * w[out + 2 * width]      # ∂l00/∂θ2
    a11 = s1 * w[out + width + 1]
    b11 = s1 * w[out + 2 * width + 1]
    a10 = scale * w[out + width + 2]
    b10 = scale * w[out + 2 * width + 2]
    h00 = l00 * l00
    h01 = l00 * l10
    h11 = l10 * l10 + l11 * l11
    # ∂H/∂θ_k = ∂L_k Lᵀ + L ∂L_kᵀ, entries (00, 01, 11) along θ1 (a) and θ2 (b)
    a_h00 = 2.0 * l00 * a00
    a_h01 = a00 * l10 + l00 * a10
    a_h11 = 2.0 * (l10 * a10 + l11 * a11)
    b_h00 = 2.0 * l00 * b00
    b_h01 = b00 * l10 + l00 * b10
    b_h11 = 2.0 * (l10 * b10 + l11 * b11)
    # Ḣ q̇ = Σ_k ∂H/∂θ_k θ̇_k q̇, and ½ ∂(q̇ᵀ H q̇)/∂θ_k
    hd00 = a_h00 * qd1 + b_h00 * qd2
    hd01 = a_h01 * qd1 + b_h01 * qd2
    hd11 = a_h11 * qd1 + b_h11 * qd2
    k1 = a_h00 * qd1 * qd1 + 2.0 * a_h01 * qd1 * qd2 + a_h11 * qd2 * qd2
    k2 = b_h00 * qd1 * qd1 + 2.0 * b_h01 * qd1 * qd2 + b_h11 * qd2 * qd2
    tau1 = h00 * qdd1 + h01 * qdd2 + hd00 * qd1 + hd01 * qd2 - 0.5 * k1
    tau2 = h01 * qdd1 + h11 * qdd2 + hd01 * qd1 + hd11 * qd2 - 0.5 * k2
    # the potential's gradient
    seed_positions(w, scratch, width, q1, q2)
    out = mlp_forward(w, int(w[H_V]), scratch, width, activation, True)
    tau1 += w[H_POTENTIAL_SCALE] * w[out + width]
    tau2 += w[H_POTENTIAL_SCALE] * w[out + 2 * width]
    # the dissipative term: its network on the positions, viscous and Coulomb friction
    seed_positions(w, scratch, width, q1, q2)
    out = mlp_forward(w, int(w[H_S]), scratch, width, activation, False)
    tau1 += (w[out] * w[N_OUT_STD] + w[N_VISCOUS] * qd1
             + w[N_COULOMB] * xp.tanh(qd1 / w[N_COULOMB_SPEED]))
    tau2 += (w[out + 1] * w[N_OUT_STD + 1] + w[N_VISCOUS + 1] * qd2
             + w[N_COULOMB + 1] * xp.tanh(qd2 / w[N_COULOMB_SPEED + 1]))
    return (tau1, tau2)
