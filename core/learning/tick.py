"""A trained model evaluated one sample at a time, as the 2 ms loop calls it: the same
formulas as core.learning.inference, with the weights laid out once and no batch axes, so
a tick costs tens of microseconds in plain numpy (docs/performance.md, "Learned dynamics").
The tests hold it equal to the batch inference."""

from __future__ import annotations

import math

import numpy as np

from core.learning import networks as nw
from core.learning.kernel import pack


def _softplus(x):
    return np.logaddexp(0.0, x)


def _softplus_float(x: float) -> float:
    return max(x, 0.0) + math.log1p(math.exp(-abs(x)))


def _joined_LV(layers: dict) -> list | None:
    """The DeLaN's L and V perceptrons as one: their first layers side by side (they read
    the same positions), the later ones block-diagonal, so each layer is one product; None
    when their depths differ. The outputs are L's, then V's."""
    L, V = layers["L"], layers["V"]
    if len(L) != len(V):
        return None
    joined = [(np.concatenate([L[0][0], V[0][0]], axis=1), np.concatenate([L[0][1], V[0][1]]))]
    for (WL, bL), (WV, bV) in zip(L[1:], V[1:], strict=True):
        W = np.zeros((WL.shape[0] + WV.shape[0], WL.shape[1] + WV.shape[1]))
        W[:WL.shape[0], :WL.shape[1]] = WL
        W[WL.shape[0]:, WL.shape[1]:] = WV
        joined.append((W, np.concatenate([bL, bV])))
    return joined


class TickModel:
    """`forces(q, qd, qdd)` → the generalised forces, (n,); a GRU carries its state from
    one call to the next until `reset()`."""

    def __init__(self, spec: dict, params: dict) -> None:
        self.spec = spec
        self.kind = spec["kind"]
        n = self.n = spec["dof"]
        self.used = np.asarray(spec["position_inputs"])
        mean, std = np.asarray(spec["input_mean"]), np.asarray(spec["input_std"])
        columns = np.r_[self.used, np.arange(n, 3 * n)]
        self.x_mean, self.x_std = mean[columns], std[columns]
        self.q_mean, self.q_std = mean[:n][self.used], std[:n][self.used]
        self.out_mean = np.asarray(spec["output_mean"])
        self.out_std = np.asarray(spec["output_std"])
        self.params = {k: np.ascontiguousarray(v) for k, v in params.items()}
        layers = {p: nw._layers(self.params, p) for p in ("net", "out", "L", "V", "s")}
        self.layers = {p: v for p, v in layers.items() if v}
        if self.kind == "rnn":
            h = spec["hidden"][0]
            self.Wx = np.concatenate([params[f"gru.{g}.Wx"] for g in "rzn"], axis=1)
            self.bx = np.concatenate([params[f"gru.{g}.bx"] for g in "rzn"])
            self.Wh = np.concatenate([params[f"gru.{g}.Wh"] for g in "rzn"], axis=1)
            self.bh = np.concatenate([params[f"gru.{g}.bh"] for g in "rzn"])
            self.h = np.zeros(h)
            self.size = h
        if self.kind == "delan":
            self.tangent = nw.position_tangents(spec)  # (used, n)
            self.scale = spec["mass_scale"]
            self.rows, self.cols = np.tril_indices(n, -1)
            self.diag = np.arange(n)
            self.viscous = (_softplus(params["viscous"]) * self.out_std
                            / std[n:2 * n])
            self.coulomb = _softplus(params["coulomb"]) * self.out_std
            self.coulomb_speed = spec["coulomb_speed_fraction"] * std[n:2 * n]
            self.tanh = spec["activation"] == "tanh"
            self.joined = _joined_LV(self.layers) if n == 2 else None
            self._stacked = np.vstack((np.zeros(len(self.used)), self.tangent.T))
            self.dissipation = (self.viscous.tolist(), self.coulomb.tolist(),
                                np.asarray(self.coulomb_speed, dtype=float).tolist())

    def reset(self) -> None:
        if self.kind == "rnn":
            self.h[:] = 0.0

    def forces(self, q, qd, qdd) -> np.ndarray:
        if self.kind == "fnn":
            x = (np.concatenate((q, qd, qdd))[self._columns()] - self.x_mean) / self.x_std
            return self._mlp("net", x) * self.out_std + self.out_mean
        if self.kind == "rnn":
            x = (np.concatenate((q, qd, qdd))[self._columns()] - self.x_mean) / self.x_std
            gx, gh = x @ self.Wx + self.bx, self.h @ self.Wh + self.bh
            s = self.size
            r = 1.0 / (1.0 + np.exp(-(gx[:s] + gh[:s])))
            z = 1.0 / (1.0 + np.exp(-(gx[s:2 * s] + gh[s:2 * s])))
            cand = np.tanh(gx[2 * s:] + r * gh[2 * s:])
            self.h = (1.0 - z) * cand + z * self.h
            return self._mlp("out", self.h) * self.out_std + self.out_mean
        return self.delan_forces(q, qd, qdd)

    def _columns(self):
        n = self.n
        return np.r_[self.used, np.arange(n, 3 * n)]

    def _mlp(self, prefix, x):
        layers = self.layers[prefix]
        for W, b in layers[:-1]:
            x = np.tanh(x @ W + b)
        W, b = layers[-1]
        return x @ W + b

    def _mlp_tangent(self, prefix, x):
        """Output and its Jacobian with respect to q, (m,), (m, n)."""
        J = self.tangent.T  # (n, used): the derivatives along each q_k, row by row
        layers = self.layers[prefix]
        for W, b in layers[:-1]:
            z = x @ W + b
            J = J @ W
            if self.tanh:
                x = np.tanh(z)
                J = J * (1.0 - x * x)
            else:
                J = J * (1.0 / (1.0 + np.exp(-z)))
                x = _softplus(z)
        W, b = layers[-1]
        return x @ W + b, (J @ W).T

    def delan_forces(self, q, qd, qdd) -> np.ndarray:
        """H q̈ + Ḣ q̇ − ½ ∂(q̇ᵀ H q̇)/∂q + ∂V/∂q + d(q, q̇) for one sample."""
        if self.joined is not None:
            return self._delan_two(q, qd, qdd)
        n = self.n
        qn = (q[self.used] - self.q_mean) / self.q_std
        out, d_out = self._mlp_tangent("L", qn)
        L = np.zeros((n, n))
        dL = np.zeros((n, n, n))
        L[self.diag, self.diag] = self.scale * _softplus(out[:n]) + nw.DIAGONAL_EPS
        L[self.rows, self.cols] = self.scale * out[n:]
        dL[self.diag, self.diag] = (self.scale / (1.0 + np.exp(-out[:n])))[:, None] * d_out[:n]
        dL[self.rows, self.cols] = self.scale * d_out[n:]
        H = L @ L.T
        force = H @ qdd
        kinetic = np.empty(n)
        for k in range(n):  # ∂H/∂q_k = ∂L_k Lᵀ + L ∂L_kᵀ
            A = dL[:, :, k] @ L.T
            dH = A + A.T
            force += (dH @ qd) * qd[k]
            kinetic[k] = qd @ dH @ qd
        force -= 0.5 * kinetic
        _, dV = self._mlp_tangent("V", qn)
        force += self.spec["potential_scale"] * dV[0]
        s = self._mlp_s(qn)
        return (force + s * self.out_std + self.viscous * qd
                + self.coulomb * np.tanh(qd / self.coulomb_speed))

    def _delan_two(self, q, qd, qdd) -> np.ndarray:
        """`delan_forces` for two coordinates (the robot, the pendulum), the same formulas
        with the few numpy calls a tick can afford: the L and V networks run as one
        (`_joined_LV`), and the 2×2 algebra of H, ∂H/∂q_k and the Coriolis terms in
        plain floats (numpy's per-call cost, not arithmetic, set the general path's 95 µs)."""
        qn = (q[self.used] - self.q_mean) / self.q_std
        # row 0 the layer's values, rows 1.. their derivatives along each q_k: one product
        # a layer carries both
        X = self._stacked
        X[0] = qn
        layers = self.joined
        for W, b in layers[:-1]:
            Y = X @ W
            z = Y[0] + b
            if self.tanh:
                y = np.tanh(z)
                Y[1:] *= 1.0 - y * y
            else:
                Y[1:] *= 1.0 / (1.0 + np.exp(-z))
                y = _softplus(z)
            Y[0] = y
            X = Y
        W, b = layers[-1]
        Y = X @ W
        Y[0] += b
        rows = Y.tolist()
        out, d = rows[0], rows[1:]  # L's three outputs, then V; d[k][m] = ∂out_m/∂q_k
        c = self.scale
        o0, o1, o2 = out[0], out[1], out[2]
        l00 = c * _softplus_float(o0) + nw.DIAGONAL_EPS
        l11 = c * _softplus_float(o1) + nw.DIAGONAL_EPS
        l10 = c * o2
        s0, s1 = c / (1.0 + math.exp(-o0)), c / (1.0 + math.exp(-o1))
        v1, v2 = float(qd[0]), float(qd[1])
        a1, a2 = float(qdd[0]), float(qdd[1])
        h00, h01, h11 = l00 * l00, l00 * l10, l10 * l10 + l11 * l11
        f1 = h00 * a1 + h01 * a2
        f2 = h01 * a1 + h11 * a2
        kinetic = [0.0, 0.0]
        for k, vk in ((0, v1), (1, v2)):  # ∂H/∂q_k = ∂L_k Lᵀ + L ∂L_kᵀ
            dl00, dl11, dl10 = s0 * d[k][0], s1 * d[k][1], c * d[k][2]
            g00 = 2.0 * l00 * dl00
            g01 = dl00 * l10 + l00 * dl10
            g11 = 2.0 * (l10 * dl10 + l11 * dl11)
            w1, w2 = g00 * v1 + g01 * v2, g01 * v1 + g11 * v2
            f1 += w1 * vk
            f2 += w2 * vk
            kinetic[k] = v1 * w1 + v2 * w2
        p = self.spec["potential_scale"]
        s = (self._mlp_s(qn) * self.out_std).tolist()
        vis, cou, speed = self.dissipation
        return np.array([
            f1 - 0.5 * kinetic[0] + p * d[0][3] + s[0] + vis[0] * v1
            + cou[0] * math.tanh(v1 / speed[0]),
            f2 - 0.5 * kinetic[1] + p * d[1][3] + s[1] + vis[1] * v2
            + cou[1] * math.tanh(v2 / speed[1])])

    def _mlp_s(self, x):
        layers = self.layers["s"]
        for W, b in layers[:-1]:
            z = x @ W + b
            x = np.tanh(z) if self.tanh else _softplus(z)
        W, b = layers[-1]
        return x @ W + b


class LearnedInverseDynamics:
    """A trained model of a 2-joint robot in place of M, C and f in the computed-torque PID
    (eq. 4.8, core.control.ctpid): `inverse_dynamics_terms(θ1, θ2, θ̇1, θ̇2, a1, a2)` is the
    model's torque for the commanded acceleration a. A recurrent model is stepped once a
    call, so one controller owns it. `name` is what the console shows: "learned: <name>".
    It pickles (plain dicts and arrays): the console sends it to the loop process."""

    def __init__(self, spec: dict, params: dict, name: str = "model",
                 content_sha256: str = "") -> None:
        if spec["dof"] != 2:
            raise ValueError(f"a model of {spec['dof']} coordinates cannot drive the 2-joint "
                             "robot")
        self.tick = TickModel(spec, params)
        self.name = name
        self.content_sha256 = content_sha256
        try:
            weights = pack(spec, params)
        except ValueError:  # a GRU, or a model that leaves out a joint angle
            weights = None
        self.kernel_weights = weights
        """The model as the compiled loop's kernel takes it (core.learning.kernel), None
        when it has no compiled form; then its controller runs interpreted."""
        """The model file's SHA-256 (app.learning.modelfile), what the trial file records."""

    def reset(self) -> None:
        """A recurrent model's state back to zero (the controller's reset, each trial)."""
        self.tick.reset()

    def inverse_dynamics_terms(self, q1, q2, qd1, qd2, qdd1, qdd2):
        tau = self.tick.forces(np.array([q1, q2]), np.array([qd1, qd2]),
                               np.array([qdd1, qdd2]))
        return float(tau[0]), float(tau[1])
