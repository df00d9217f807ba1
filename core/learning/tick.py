"""A trained model evaluated one sample at a time, as the 2 ms loop calls it: the same
formulas as core.learning.inference, with the weights laid out once and no batch axes, so
a tick costs tens of microseconds in plain numpy (docs/performance.md, "Learned dynamics").
The tests hold it equal to the batch inference."""

from __future__ import annotations

import numpy as np

from core.learning import networks as nw
from core.learning.kernel import pack


def _softplus(x):
    return np.logaddexp(0.0, x)


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
