"""EMG-to-joint-torque models and their honest validation (thesis section 5.2.2, eq. 5.1).

Inputs: MVC-normalised envelopes (fractions of MVC) of the muscles, on the trial's ticks.
Outputs: the subject's anatomical (shoulder, elbow) torques, N·m. Three models:

* `LinearModel`: least squares, τ = W·[u, 1]. The baseline every other model must beat.
* `FeedForwardNetwork`: the thesis's network, u → one hidden tanh layer → τ, trained on
  the mean squared error with L-BFGS (scipy) and a small weight decay; inputs and outputs
  standardised on the training set. Deterministic for a seed.
* `MuscleModel`: physiologically informed. Each envelope passes first-order activation
  dynamics (time constants for rise and fall) and an electromechanical delay; each
  muscle's activation then pulls with a non-negative strength along the sign its moment
  arm has at each joint (biceps flexes the elbow and the shoulder, triceps extends both,
  the anterior deltoid flexes the shoulder, the posterior deltoid extends it), fitted by
  non-negative least squares with a free offset per joint; the delay and the time
  constants are chosen on the training data from a small grid.

`validate` scores a model on a split: RMSE (N·m) and R² = 1 − SSE/SST per joint on the
test trials, with the linear baseline's beside it. A model may feed the assistance as an
estimate of the patient's torque only if, held out, its R² reaches `USABLE_R2` at both
joints, it beats the baseline, and the force its torques imply judges the patient's push
as the force sensor does on `USABLE_CONE_AGREEMENT` of the samples (core.emg.force: the
assistance's cone test is what the estimate is for); `usable` says so and why not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from core.emg.force import (
    USABLE_CONE_AGREEMENT,
    ForceContext,
    ForceScore,
    force_score,
    joined,
)
from core.errors import ParameterError

USABLE_R2 = 0.6
JOINTS = ("shoulder", "elbow")
# moment-arm signs (shoulder, elbow) by muscle: flexion positive (core.emg.synthetic)
SIGNS = {"biceps": (1, 1), "triceps": (-1, -1), "anterior_deltoid": (1, 0),
         "posterior_deltoid": (-1, 0)}


@dataclass(frozen=True, slots=True, eq=False)
class TrialSet:
    """One trial's aligned data: envelopes u (N, M), torques (N, 2), its subject, its name."""

    u: np.ndarray
    torques: np.ndarray
    subject: int
    name: str
    dt_s: float
    context: ForceContext | None = None
    """The samples' arm states, sensor force and cone, to score the force the torques
    imply (core.emg.force); None where the trial has none."""

    def __post_init__(self) -> None:
        if self.u.ndim != 2 or self.torques.shape != (self.u.shape[0], 2):
            raise ParameterError("u, torques", (self.u.shape, self.torques.shape),
                                 "(N, muscles) and (N, 2)")
        if self.context is not None and len(self.context) != self.u.shape[0]:
            raise ParameterError("context", f"{len(self.context)} samples",
                                 f"one per envelope sample ({self.u.shape[0]})")


def _stack(trials, what):
    return np.concatenate([getattr(t, what) for t in trials])


class LinearModel:
    name = "linear"

    def fit(self, trials) -> LinearModel:
        u, y = _stack(trials, "u"), _stack(trials, "torques")
        X = np.column_stack((u, np.ones(len(u))))
        self.W, *_ = np.linalg.lstsq(X, y, rcond=None)
        return self

    def predict(self, trial: TrialSet) -> np.ndarray:
        return np.column_stack((trial.u, np.ones(len(trial.u)))) @ self.W

    def to_dict(self) -> dict:
        return {"model": self.name, "W": _listed(self.W)}

    @classmethod
    def from_dict(cls, d: dict) -> LinearModel:
        model = cls()
        model.W = _array(d, "W", 2)
        return model


class FeedForwardNetwork:
    """The thesis's FNN: inputs → `hidden` tanh units → 2 outputs."""

    name = "network"

    def __init__(self, hidden: int = 10, weight_decay: float = 1e-3, seed: int = 0,
                 max_iterations: int = 500) -> None:
        self.hidden, self.decay, self.seed, self.max_iterations = hidden, weight_decay, seed, \
            max_iterations

    def _unpack(self, w, m):
        h = self.hidden
        a = m * h
        W1, b1 = w[:a].reshape(m, h), w[a:a + h]
        W2, b2 = w[a + h:a + h + 2 * h].reshape(h, 2), w[a + 3 * h:]
        return W1, b1, W2, b2

    def fit(self, trials) -> FeedForwardNetwork:
        from scipy.optimize import minimize

        u, y = _stack(trials, "u"), _stack(trials, "torques")
        self.u_mean, self.u_std = u.mean(0), u.std(0) + 1e-9
        self.y_mean, self.y_std = y.mean(0), y.std(0) + 1e-9
        X, Y = (u - self.u_mean) / self.u_std, (y - self.y_mean) / self.y_std
        m, h, n = X.shape[1], self.hidden, len(X)
        rng = np.random.default_rng(self.seed)
        w0 = np.concatenate((rng.normal(0, 1 / np.sqrt(m), m * h), np.zeros(h),
                             rng.normal(0, 1 / np.sqrt(h), 2 * h), np.zeros(2)))

        def loss(w):
            W1, b1, W2, b2 = self._unpack(w, m)
            z = np.tanh(X @ W1 + b1)
            e = z @ W2 + b2 - Y
            value = 0.5 * np.sum(e * e) / n + 0.5 * self.decay * (np.sum(W1 ** 2)
                                                                + np.sum(W2 ** 2))
            g_out = e / n
            gW2 = z.T @ g_out + self.decay * W2
            gb2 = g_out.sum(0)
            g_hidden = (g_out @ W2.T) * (1 - z * z)
            gW1 = X.T @ g_hidden + self.decay * W1
            gb1 = g_hidden.sum(0)
            return value, np.concatenate((gW1.ravel(), gb1, gW2.ravel(), gb2))

        result = minimize(loss, w0, jac=True, method="L-BFGS-B",
                          options={"maxiter": self.max_iterations})
        self.w, self.m = result.x, m
        return self

    def predict(self, trial: TrialSet) -> np.ndarray:
        W1, b1, W2, b2 = self._unpack(self.w, self.m)
        X = (trial.u - self.u_mean) / self.u_std
        return (np.tanh(X @ W1 + b1) @ W2 + b2) * self.y_std + self.y_mean

    def to_dict(self) -> dict:
        return {"model": self.name, "hidden": self.hidden, "weight_decay": self.decay,
                "seed": self.seed, "max_iterations": self.max_iterations, "inputs": self.m,
                "w": _listed(self.w), **{k: _listed(getattr(self, k)) for k in _SCALING}}

    @classmethod
    def from_dict(cls, d: dict) -> FeedForwardNetwork:
        model = cls(int(d["hidden"]), float(d["weight_decay"]), int(d["seed"]),
                    int(d["max_iterations"]))
        model.m = int(d["inputs"])
        model.w = _array(d, "w", 1)
        if model.w.size != model.m * model.hidden + 3 * model.hidden + 2:
            raise ParameterError("w", f"{model.w.size} weights",
                                 f"{model.m * model.hidden + 3 * model.hidden + 2} for "
                                 f"{model.m} inputs and {model.hidden} hidden units")
        for k in _SCALING:
            setattr(model, k, _array(d, k, 1))
        return model


def activation(u: np.ndarray, dt_s: float, rise_s: float, fall_s: float,
               delay_s: float) -> np.ndarray:
    """First-order activation dynamics of excitations u (N, M), then delayed by delay_s."""
    from core.emg.synthetic import MuscleModel as Synthetic, activation_dynamics

    a = activation_dynamics(u, dt_s, Synthetic(activation_tau_s=rise_s,
                                               deactivation_tau_s=fall_s, delay_s=0.0))
    shift = round(delay_s / dt_s)
    if shift:
        a = np.concatenate((np.repeat(a[:1], shift, axis=0), a[:-shift]))
    return a


class MuscleModel:
    """Activation dynamics + delay + signed non-negative strengths (module docstring)."""

    name = "muscle model"

    def __init__(self, muscles, *, delays_s=(0.0, 0.04, 0.08),
                 time_constants_s=((0.015, 0.05), (0.04, 0.12))) -> None:
        unknown = [m for m in muscles if m not in SIGNS]
        if unknown:
            raise ParameterError("muscles", unknown, ", ".join(SIGNS))
        self.muscles = tuple(muscles)
        self.delays_s, self.time_constants_s = delays_s, time_constants_s

    def _columns(self, a: np.ndarray, joint: int) -> np.ndarray:
        cols = [SIGNS[m][joint] * a[:, i] for i, m in enumerate(self.muscles)
                if SIGNS[m][joint] != 0]
        n = len(a)
        return np.column_stack([*cols, np.ones(n), -np.ones(n)])

    def _fit_with(self, trials, rise, fall, delay):
        from scipy.optimize import nnls

        a = np.concatenate([activation(t.u, t.dt_s, rise, fall, delay) for t in trials])
        y = _stack(trials, "torques")
        weights, sse = [], 0.0
        for j in range(2):
            X = self._columns(a, j)
            w, residual = nnls(X, y[:, j])
            weights.append(w)
            sse += residual ** 2
        return weights, sse

    def fit(self, trials) -> MuscleModel:
        best = None
        for rise, fall in self.time_constants_s:
            for delay in self.delays_s:
                weights, sse = self._fit_with(trials, rise, fall, delay)
                if best is None or sse < best[0]:
                    best = (sse, weights, (rise, fall, delay))
        _, self.weights, self.dynamics = best
        return self

    def predict(self, trial: TrialSet) -> np.ndarray:
        a = activation(trial.u, trial.dt_s, *self.dynamics)
        return np.column_stack([self._columns(a, j) @ self.weights[j] for j in range(2)])

    def to_dict(self) -> dict:
        return {"model": self.name, "muscles": list(self.muscles),
                "delays_s": list(self.delays_s),
                "time_constants_s": [list(t) for t in self.time_constants_s],
                "dynamics": list(self.dynamics), "weights": [_listed(w) for w in self.weights]}

    @classmethod
    def from_dict(cls, d: dict) -> MuscleModel:
        model = cls(tuple(d["muscles"]), delays_s=tuple(d["delays_s"]),
                    time_constants_s=tuple(tuple(t) for t in d["time_constants_s"]))
        model.dynamics = tuple(float(v) for v in d["dynamics"])
        model.weights = [np.asarray(w, dtype=float) for w in d["weights"]]
        for j, w in enumerate(model.weights):
            width = model._columns(np.zeros((1, len(model.muscles))), j).shape[1]
            if w.shape != (width,):
                raise ParameterError("weights", f"{w.shape} at the {JOINTS[j]}",
                                     f"({width},) for the muscles {', '.join(model.muscles)}")
        return model


_SCALING = ("u_mean", "u_std", "y_mean", "y_std")


def _listed(values) -> list:
    return np.asarray(values, dtype=float).tolist()


def _array(d: dict, key: str, ndim: int) -> np.ndarray:
    a = np.asarray(d[key], dtype=float)
    if a.ndim != ndim or not np.isfinite(a).all():
        raise ParameterError(key, f"an array of shape {a.shape}", f"{ndim}-D, finite")
    return a


def model_from_dict(d: dict):
    """A fitted model from its `to_dict` (the EMG model file's "model")."""
    kinds = {c.name: c for c in (LinearModel, FeedForwardNetwork, MuscleModel)}
    kind = d.get("model") if isinstance(d, dict) else None
    if kind not in kinds:
        raise ParameterError("model", kind, "one of " + ", ".join(kinds))
    return kinds[kind].from_dict(d)


def inputs_of(model) -> int:
    """How many muscles' envelopes the fitted model takes."""
    if isinstance(model, LinearModel):
        return model.W.shape[0] - 1
    if isinstance(model, FeedForwardNetwork):
        return model.m
    return len(model.muscles)


@dataclass(frozen=True, slots=True)
class Score:
    rmse_Nm: tuple[float, float]
    r2: tuple[float, float]


def score(predicted: np.ndarray, actual: np.ndarray) -> Score:
    e = predicted - actual
    rmse = np.sqrt(np.mean(e * e, axis=0))
    sst = np.sum((actual - actual.mean(0)) ** 2, axis=0)
    r2 = 1 - np.sum(e * e, axis=0) / np.where(sst > 0, sst, np.nan)
    return Score(tuple(float(v) for v in rmse), tuple(float(v) for v in r2))


@dataclass(frozen=True, slots=True)
class Validation:
    """A model's held-out score on one split, with the linear baseline's."""

    model: str
    split: str
    test: tuple[str, ...]
    score: Score
    baseline: Score
    threshold_r2: float = USABLE_R2
    notes: tuple[str, ...] = field(default=())
    force: ForceScore | None = None
    """The force the held-out torques imply against the sensor's (core.emg.force); None
    when the test trials carry no force to score it on."""
    threshold_agreement: float = USABLE_CONE_AGREEMENT

    @property
    def usable(self) -> bool:
        return not self.why_not

    def to_dict(self) -> dict:
        return {"model": self.model, "split": self.split, "test": list(self.test),
                "rmse_Nm": list(self.score.rmse_Nm), "r2": list(self.score.r2),
                "baseline_rmse_Nm": list(self.baseline.rmse_Nm),
                "baseline_r2": list(self.baseline.r2), "threshold_r2": self.threshold_r2,
                "force": None if self.force is None else self.force.to_dict(),
                "threshold_agreement": self.threshold_agreement}

    @classmethod
    def from_dict(cls, d: dict) -> Validation:
        def pair(key):
            values = tuple(float(v) for v in d[key])
            if len(values) != 2:
                raise ParameterError(key, list(values), "two values (shoulder, elbow)")
            return values

        return cls(str(d["model"]), str(d["split"]), tuple(map(str, d["test"])),
                   Score(pair("rmse_Nm"), pair("r2")),
                   Score(pair("baseline_rmse_Nm"), pair("baseline_r2")),
                   float(d["threshold_r2"]),
                   force=None if d.get("force") is None else ForceScore.from_dict(d["force"]),
                   threshold_agreement=float(d.get("threshold_agreement",
                                                   USABLE_CONE_AGREEMENT)))

    @property
    def why_not(self) -> str:
        low = [f"{j} R² {r:.2f}" for j, r in zip(JOINTS, self.score.r2, strict=True)
               if not r >= self.threshold_r2]
        if low:
            return (f"{self.model}, held out ({self.split}): {', '.join(low)} below "
                    f"{self.threshold_r2:.2f}; it does not generalise to a new trial, so it "
                    "cannot stand in for the force sensor")
        worse = [j for j, r, b in zip(JOINTS, self.score.r2, self.baseline.r2, strict=True)
                 if r < b]
        if worse and self.model != LinearModel.name:
            return (f"{self.model}, held out ({self.split}): no better than the linear "
                    f"baseline at the {', '.join(worse)}")
        if self.force is None:
            return (f"{self.model}, held out ({self.split}): its test trials have no force "
                    "sensor recording to check the force it implies against")
        if not self.force.cone_agreement >= self.threshold_agreement:
            return (f"{self.model}, held out ({self.split}): the force it implies agrees "
                    f"with the sensor's on {self.force.cone_agreement:.0%} of the samples "
                    f"about the {math.degrees(self.force.tolerance_rad):.0f}° tolerance "
                    f"cone, below {self.threshold_agreement:.0%}; it would judge the "
                    "patient's push wrongly too often")
        return ""


def validate(make_model, trials, test_names, split: str, judge=None) -> Validation:
    """Fit `make_model()` and the baseline on every trial not in `test_names`, score both on
    the test trials together. The force the model implies is scored by `judge(model,
    test trials)` → ForceScore, or, without one, sample by sample on the test trials'
    contexts (core.emg.force.force_score) when they all have one."""
    train = [t for t in trials if t.name not in test_names]
    test = [t for t in trials if t.name in test_names]
    if not train or not test:
        raise ParameterError("test_names", list(test_names), "some trials, not all")
    model = make_model().fit(train)
    baseline = LinearModel().fit(train)
    actual = _stack(test, "torques")
    predicted = np.concatenate([model.predict(t) for t in test])
    base = np.concatenate([baseline.predict(t) for t in test])
    force = None
    if judge is not None:
        force = judge(model, test)
    elif all(t.context is not None for t in test):
        force = force_score(predicted, joined(t.context for t in test))
    return Validation(model.name, split, tuple(t.name for t in test), score(predicted, actual),
                      score(base, actual), force=force)


def in_sample(make_model, trial: TrialSet) -> Score:
    """Fit and score on one trial itself: how well the model can describe what it saw."""
    model = make_model().fit([trial])
    return score(model.predict(trial), trial.torques)


def leave_one_subject_out(make_model, trials, judge=None) -> list[Validation]:
    subjects = sorted({t.subject for t in trials})
    return [validate(make_model, trials, {t.name for t in trials if t.subject == s},
                     f"leave subject {s} out", judge) for s in subjects]


class ModelRefused(ParameterError):
    """A model that did not pass its held-out validation was asked to estimate the
    patient's torque."""

    def __init__(self, validation: Validation) -> None:
        super().__init__("model", validation.model, "a model whose held-out validation passes",
                         validation.why_not)


def torque_estimator(model, validation: Validation):
    """The model, to stand in for the force sensor's estimate of the patient's torque (the
    thesis's cHRI aim), only if its held-out validation passed; otherwise ModelRefused,
    whose message says why (Validation.why_not)."""
    if validation.model != model.name:
        raise ParameterError("validation", validation.model, f"a validation of {model.name}")
    if not validation.usable:
        raise ModelRefused(validation)
    return model
