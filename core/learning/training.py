"""The one training loop for the three models (thesis section 2.5: Adam, k-fold
cross-validation): mean squared error on the generalised forces scaled by their spread,
Adam (optax) with a cosine decay of its rate, early stopping on each fold's validation
cycles, seeds fixed so a run repeats itself. From the schedule's middle on, what is
validated and kept is the weights' moving average over about the last epoch's steps
(`average_weights`, Polyak's tail averaging); before it, the steps' own weights.
Folds are made of whole cycles, so a recurrent model sees whole sequences and no cycle is
both trained and validated on.

The model kept is the fold whose validation error was lowest; the metrics carry every
fold's. Imports JAX (core.learning.jaxmodels); the console imports this module only when
a training runs.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np
import optax

from core.learning import jaxmodels as jm, networks as nw

DEFAULT_HIDDEN = {"fnn": [24, 24], "rnn": [12], "delan": [16, 16]}
DEFAULT_LEARNING_RATE = {"fnn": 3e-3, "rnn": 3e-3, "delan": 1e-2}
# samples; the GRU's: sequences. The DeLaN's 128 takes four times the steps of 512 in the
# same epochs: at 512 its training on the pendulum had not converged in 100 epochs (its best
# epoch the last, τ's error at unseen speeds 0.21 N·m; 0.03 at 128, docs/performance.md)
DEFAULT_BATCH = {"fnn": 512, "rnn": 16, "delan": 128}


@dataclass(frozen=True)
class TrainingOptions:
    """Hyper-parameters of one training run (all saved in the model file)."""

    kind: str
    hidden: tuple[int, ...] = ()
    dissipation_hidden: tuple[int, ...] = (8,)
    epochs: int = 100
    batch_size: int | None = None      # default: DEFAULT_BATCH
    learning_rate: float | None = None  # Adam's first step (default: DEFAULT_LEARNING_RATE)
    final_learning_rate: float = 1e-4  # cosine decay over the epochs
    patience: int = 20                 # epochs without a better validation error, counted
                                       # from the schedule's middle (`train`)
    folds: int = 5
    validation_fraction: float = 0.2   # with folds = 1: the share of cycles kept aside
    window: int = 101                  # a recurrent model's training sequences, samples
    seed: int = 0
    coulomb_speed_fraction: float = 0.01
    cyclic: tuple[int, ...] = ()       # coordinates the dynamics does not depend on
    activation: str = "tanh"           # the DeLaN's hidden layers (tanh or softplus)
    # the DeLaN's Cholesky factor's unit, of the order of √ of the mass matrix's entries:
    # 3 for the pendulum (11 kg, 3.3 kg·m²), 0.5 for the robot (0.1–0.2 kg·m²)
    mass_scale: float = 3.0
    # validate and keep the weights averaged over about the last epoch's steps (an
    # exponential moving average, Polyak averaging): Adam's steps at the schedule's first,
    # high rates jitter the weights, and a jittered validation error stops a run early on
    # a lucky epoch; the average's error falls smoothly
    average_weights: bool = True

    def __post_init__(self) -> None:
        if self.kind not in nw.KINDS:
            raise ValueError(f"unknown model {self.kind!r}; one of {', '.join(nw.KINDS)}")

    def hyper_parameters(self) -> dict:
        out = {k: getattr(self, k) for k in self.__dataclass_fields__}
        out["hidden"] = list(self.layers())
        out["dissipation_hidden"] = list(self.dissipation_hidden)
        out["cyclic"] = list(self.cyclic)
        out["learning_rate"] = self.first_learning_rate()
        out["batch_size"] = self.batch_size or DEFAULT_BATCH[self.kind]
        return out

    def first_learning_rate(self) -> float:
        return self.learning_rate or DEFAULT_LEARNING_RATE[self.kind]

    def layers(self) -> tuple[int, ...]:
        return tuple(self.hidden) or tuple(DEFAULT_HIDDEN[self.kind])


@dataclass
class TrainingResult:
    spec: dict
    params: dict[str, np.ndarray]
    metrics: dict = field(default_factory=dict)


def make_spec(options: TrainingOptions, q, qd, qdd, tau) -> dict:
    """The model's fixed numbers from its training data: input normalisation, output
    scales, and the DeLaN's mass and energy scales."""
    n = q.shape[1]
    x = np.concatenate([q, qd, qdd], axis=1)
    input_std = x.std(axis=0)
    input_std = np.where(input_std > 1e-12, input_std, 1.0)  # a constant input stays put
    output_std = tau.std(axis=0)
    output_std = np.where(output_std > 1e-12, output_std, 1.0)
    if any(not 0 <= i < n for i in options.cyclic) or len(set(options.cyclic)) == n:
        raise ValueError(f"cyclic coordinates {list(options.cyclic)} do not fit {n} "
                         "coordinates (at least one must remain)")
    spec = {"kind": options.kind, "dof": n, "hidden": list(options.layers()),
            "position_inputs": [i for i in range(n) if i not in options.cyclic],
            "input_mean": x.mean(axis=0).tolist(), "input_std": input_std.tolist(),
            "output_mean": tau.mean(axis=0).tolist(), "output_std": output_std.tolist()}
    if options.kind == "delan":
        spec.update(dissipation_hidden=list(options.dissipation_hidden),
                    activation=options.activation,
                    mass_scale=options.mass_scale,
                    # energy of the order of a force times its coordinate's spread
                    potential_scale=float(np.mean((output_std * input_std[:n])[
                        spec["position_inputs"]])),
                    coulomb_speed_fraction=options.coulomb_speed_fraction)
    return spec


def _windows(x, y, cycle, window):
    """Each cycle cut into sequences of `window` samples, the last one padded and masked."""
    xs, ys, masks = [], [], []
    starts = np.flatnonzero(np.r_[True, cycle[1:] != cycle[:-1]])
    ends = np.r_[starts[1:], len(cycle)]
    for start, end in zip(starts, ends, strict=True):
        for a in range(start, end, window):
            b = min(a + window, end)
            pad = window - (b - a)
            xs.append(np.pad(x[a:b], ((0, pad), (0, 0))))
            ys.append(np.pad(y[a:b], ((0, pad), (0, 0))))
            masks.append(np.r_[np.ones(b - a), np.zeros(pad)])
    return np.stack(xs), np.stack(ys), np.stack(masks)


def _model_function(spec):
    kind = spec["kind"]
    if kind == "fnn":
        return lambda p, b: jm.fnn_forces(spec, p, b["q"], b["qd"], b["qdd"])
    if kind == "delan":
        return lambda p, b: jm.delan_forces(spec, p, b["q"], b["qd"], b["qdd"])
    return lambda p, b: jm.rnn_forces(spec, p, b["x"])


def _batches(spec, q, qd, qdd, tau, cycle, window):
    """The training examples as a dict of arrays with a leading example axis."""
    if spec["kind"] == "rnn":
        x = nw.normalised_inputs(np, spec, q, qd, qdd)
        xw, yw, mw = _windows(x, tau, cycle, window)
        return {"x": xw, "y": yw, "mask": mw}
    return {"q": q, "qd": qd, "qdd": qdd, "y": tau, "mask": np.ones(len(q))}


def train(q, qd, qdd, tau, cycle, options: TrainingOptions,
          progress: Callable[[float], None] | None = None) -> TrainingResult:
    """Train one model with k-fold cross-validation over the cycles; return the best fold's
    model and every fold's figures."""
    q, qd, qdd, tau = (np.asarray(a, dtype=np.float64) for a in (q, qd, qdd, tau))
    cycle = np.asarray(cycle)
    spec = make_spec(options, q, qd, qdd, tau)
    cycles = np.unique(cycle)
    rng = np.random.default_rng(options.seed)
    shuffled = rng.permutation(cycles)
    if options.folds > 1:
        if cycles.size < options.folds:
            raise ValueError(f"{options.folds}-fold cross-validation needs at least "
                             f"{options.folds} cycles; the data has {cycles.size}")
        groups = np.array_split(shuffled, options.folds)
    else:
        if cycles.size < 2:
            raise ValueError("a validation needs at least 2 cycles; the data has 1")
        keep = max(1, round(options.validation_fraction * cycles.size))
        groups = [shuffled[:keep]]
    model = _model_function(spec)
    scale = jnp.asarray(spec["output_std"])

    def loss_fn(p, batch):
        error = ((model(p, batch) - batch["y"]) / scale) ** 2
        mask = batch["mask"][..., None] * jnp.ones_like(error)
        return jnp.sum(error * mask) / jnp.sum(mask)

    def squared_error(p, batch):  # per force, in SI units, and the sample count
        error = (model(p, batch) - batch["y"]) ** 2
        mask = batch["mask"][..., None]
        return jnp.sum(error * mask, axis=tuple(range(error.ndim - 1))), jnp.sum(mask)

    sets = []
    for validation_cycles in groups:
        is_validation = np.isin(cycle, validation_cycles)
        sets.append((_batches(spec, *(a[~is_validation] for a in (q, qd, qdd, tau, cycle)),
                              options.window),
                     _batches(spec, *(a[is_validation] for a in (q, qd, qdd, tau, cycle)),
                              options.window)))
    # one batch shape, one step count and one optimiser for every fold: compiled once
    smallest = min(len(train_set["y"]) for train_set, _ in sets)
    batch_size = min(options.batch_size or DEFAULT_BATCH[options.kind], smallest)
    steps = smallest // batch_size
    rate = options.first_learning_rate()
    schedule = optax.cosine_decay_schedule(
        rate, options.epochs * steps, alpha=min(1.0, options.final_learning_rate / rate))
    optimiser = optax.adam(schedule)

    # the average's weight on its past: 1 − 1/steps, a memory of about one epoch; it starts
    # at the schedule's middle from the weights there (below)
    past = 1.0 - 1.0 / steps if options.average_weights else 0.0

    @jax.jit
    def step(params, state, average, batch):
        loss, grads = jax.value_and_grad(loss_fn)(params, batch)
        updates, state = optimiser.update(grads, state, params)
        params = optax.apply_updates(params, updates)
        average = jax.tree.map(lambda a, p: past * a + (1.0 - past) * p, average, params)
        return params, state, average, loss

    squared_error = jax.jit(squared_error)

    def validation_error(params, val_set):
        """Squared error per force over the validation set, in batches of the training's
        shape (the last one padded and masked), and the sample count."""
        total, samples = 0.0, 0.0
        for a in range(0, len(val_set["y"]), batch_size):
            chunk = {k: v[a:a + batch_size] for k, v in val_set.items()}
            pad = batch_size - len(chunk["y"])
            if pad:
                chunk = {k: np.concatenate([v, np.zeros((pad, *v.shape[1:]))])
                         for k, v in chunk.items()}
            sse, count = squared_error(params, chunk)
            total, samples = total + np.asarray(sse), samples + float(count)
        return total, samples

    # early stopping watches from the schedule's middle, where the rate has come down to
    # half its first value: before it, Adam's jitter can make one epoch's validation error
    # a lucky low that twenty noisy ones do not beat (a pendulum DeLaN stopped at epoch 50,
    # its best at 30: τ's error at unseen speeds 0.080 N·m; run on, 0.024)
    watch_from = options.epochs // 2
    folds, start_time = [], time.perf_counter()
    total_epochs = options.epochs * len(groups)
    output_var = np.asarray(spec["output_std"]) ** 2
    for index, (validation_cycles, (train_set, val_set)) in enumerate(
            zip(groups, sets, strict=True)):
        params = {k: jnp.asarray(v) for k, v in
                  nw.init_params(spec, options.seed * 1000 + index).items()}
        state = optimiser.init(params)
        order_rng = np.random.default_rng(options.seed * 1000 + index)
        count = len(train_set["y"])
        best, best_params, best_epoch, epochs_run = np.inf, params, 0, 0
        average = params
        for e in range(options.epochs):
            if e == watch_from:
                # the average starts where the rate has come down (Polyak's tail average):
                # before, the weights kept are the steps' own, so a model whose best epoch
                # is an early one (the robot's data: the 1st to the 11th of 60) is not
                # pulled toward its initial weights (37 % of an average a epoch old)
                average = params
            order = order_rng.permutation(count)[: steps * batch_size].reshape(steps, -1)
            for rows in order:
                params, state, average, _ = step(params, state, average,
                                                 {k: v[rows] for k, v in train_set.items()})
            kept = average if e >= watch_from else params
            sse, samples = validation_error(kept, val_set)
            val = float(np.sum(sse / output_var) / samples / spec["dof"])
            epochs_run = e + 1
            if val < best:
                best, best_params, best_epoch = val, kept, e + 1
            if progress is not None:
                progress((index * options.epochs + e + 1) / total_epochs)
            if e + 1 - max(best_epoch, watch_from) >= options.patience:
                break
        sse, samples = validation_error(best_params, val_set)
        rmse = np.sqrt(sse / samples)
        folds.append({"fold": index, "validation_cycles": len(validation_cycles),
                      "best_epoch": best_epoch, "epochs_run": epochs_run,
                      "validation_loss": best, "validation_rmse": rmse.tolist(),
                      "params": best_params})
    if progress is not None:
        progress(1.0)
    chosen = min(folds, key=lambda f: f["validation_loss"])
    params = {k: np.asarray(v, dtype=np.float64) for k, v in chosen["params"].items()}
    metrics = {
        "training_seconds": time.perf_counter() - start_time,
        "chosen_fold": chosen["fold"],
        "folds": [{k: v for k, v in f.items() if k != "params"} for f in folds],
        "cross_validation_rmse": np.mean([f["validation_rmse"] for f in folds],
                                         axis=0).tolist(),
        "parameters": nw.count_parameters(spec),
    }
    return TrainingResult(spec=spec, params=params, metrics=metrics)
