"""Table 2.1 reproduced and beaten: FNN, GRU and DeLaN on the thesis's pendulum data
(eq. 2.36–2.39), and Fig. 2.15 (error against the number of training cycles).

Run: .venv/bin/python bench/learning.py [--epochs 100] [--folds 5] [--models delan fnn rnn]
     [--batch-size N] [--no-average-weights] [--sizes 5 10 25 …]
     [--figure docs/figures/learning-fig-2-15.png] [--no-figure-2-15]
(--batch-size and --no-average-weights: the training as it was before 2026-12-02, for the
DeLaN --batch-size 512 --no-average-weights.)
Prints, for each model: parameters, training time on this CPU, RMSE of f and τ on the
held-out 5 rad/s cycle (Table 2.1's test), on cycles at speeds between the training speeds
(never trained on) and beyond them (extrapolation, 0.5 and 11–12 rad/s); then the RMSE of τ
on the held-out cycle against the number of training cycles, and per-sample inference cost
of the numpy models (what the 2 ms loop would run).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from core.learning import inference, networks as nw, pendulum as pd
from core.learning.training import TrainingOptions, train

THESIS = {"delan": (2.097, 801), "fnn": (2.257, 793), "rnn": (2.221, 820)}
BETWEEN = [1.0045, 2.5045, 4.2, 5.55, 7.7777, 9.9955]   # none on the 1 + k/111 grid
BEYOND = [0.5, 11.0, 12.0]


def rmse(model, data) -> np.ndarray:
    pred = inference.predict(model.spec, model.params, data.q, data.qd, data.qdd, data.cycle)
    return np.sqrt(np.mean((pred - data.tau) ** 2, axis=0))


def fit(kind, data, epochs, folds, seed=0, **options):
    options = TrainingOptions(kind=kind, epochs=epochs, folds=folds, cyclic=(0,), seed=seed,
                              **options)
    return train(data.q, data.qd, data.qdd, data.tau, data.cycle, options)


def subset(data, keep):
    return pd.PendulumData(data.q[keep], data.qd[keep], data.qdd[keep], data.tau[keep],
                           data.cycle[keep], data.speeds_rad_s)


def cost_us(model, calls=2000) -> float:
    """Per-sample numpy cost, one sample a call as the loop calls it, median µs."""
    q, qd, qdd = np.array([0.1, 0.2]), np.array([0.3, 5.0]), np.array([1.0, 0.0])
    if model.spec["kind"] == "rnn":
        state = inference.RecurrentState(model.spec, model.params)
        call = lambda: state.step(q, qd, qdd)  # noqa: E731
    else:
        call = lambda: inference.predict(model.spec, model.params, q[None], qd[None],  # noqa: E731
                                         qdd[None])
    times = []
    for _ in range(calls):
        t0 = time.perf_counter_ns()
        call()
        times.append(time.perf_counter_ns() - t0)
    return float(np.median(times)) / 1000.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--epochs", type=int, default=100)
    parser.add_argument("--folds", type=int, default=5)
    parser.add_argument("--models", nargs="+", default=["delan", "fnn", "rnn"])
    parser.add_argument("--batch-size", type=int, help="every model's (default: its own)")
    parser.add_argument("--no-average-weights", action="store_true",
                        help="validate and keep the last step's weights, not their average")
    parser.add_argument("--sizes", type=int, nargs="+", default=[5, 10, 25, 50, 100, 250])
    parser.add_argument("--figure", default="docs/figures/learning-fig-2-15.png")
    parser.add_argument("--no-figure-2-15", action="store_true")
    args = parser.parse_args()
    options = {"average_weights": not args.no_average_weights}
    if args.batch_size:
        options["batch_size"] = args.batch_size

    data = pd.generate()
    test = pd.held_out_mask(data)
    train_data, held = subset(data, ~test), subset(data, test)
    between = pd.generate(BETWEEN)
    beyond = pd.generate(BEYOND)
    print(f"pendulum: {len(train_data.q):,} training samples, {len(held.q)} held out "
          f"(5 rad/s); {args.folds}-fold cross-validation, at most {args.epochs} epochs")
    print(f"{'model':<6} {'params':>6} {'train s':>8} {'τ 5 rad/s':>10} {'f 5 rad/s':>10} "
          f"{'τ between':>10} {'τ beyond':>10} {'thesis τ':>9} {'µs/sample':>10}")
    full = {}
    for kind in args.models:
        t0 = time.perf_counter()
        model = fit(kind, train_data, args.epochs, args.folds, **options)
        seconds = time.perf_counter() - t0
        full[kind] = model
        r_held, r_between, r_beyond = rmse(model, held), rmse(model, between), rmse(model, beyond)
        print(f"{kind:<6} {nw.count_parameters(model.spec):>6} {seconds:>8.0f} "
              f"{r_held[1]:>10.4f} {r_held[0]:>10.4f} {r_between[1]:>10.4f} "
              f"{r_beyond[1]:>10.3f} {THESIS[kind][0]:>9.3f} {cost_us(model):>10.1f}",
              flush=True)
    if args.no_figure_2_15:
        return
    # Fig. 2.15: τ's RMSE on the held-out cycle against the number of training cycles
    train_cycles = np.unique(train_data.cycle)
    rng = np.random.default_rng(0)
    curves = {kind: [] for kind in args.models}
    sizes = [s for s in args.sizes if s < train_cycles.size]
    print("\nFig. 2.15: RMSE of τ (N·m) on the 5 rad/s cycle against training cycles")
    print(f"{'cycles':>7} " + " ".join(f"{k:>9}" for k in args.models))
    for size in sizes:
        chosen = rng.choice(train_cycles, size, replace=False)
        part = subset(train_data, np.isin(train_data.cycle, chosen))
        row = []
        for kind in args.models:
            model = fit(kind, part, args.epochs, min(args.folds, size), **options)
            row.append(rmse(model, held)[1])
            curves[kind].append(row[-1])
        print(f"{size:>7} " + " ".join(f"{v:>9.4f}" for v in row), flush=True)
    sizes.append(int(train_cycles.size))
    for kind in args.models:
        curves[kind].append(rmse(full[kind], held)[1])
    print(f"{sizes[-1]:>7} " + " ".join(f"{curves[k][-1]:>9.4f}" for k in args.models))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for kind, marker in zip(args.models, "osD", strict=False):
        ax.loglog(sizes, curves[kind], marker=marker, label=kind.upper())
    ax.axhline(0.2, color="grey", linestyle=":", label="goal 0.2 N·m")
    ax.set_xlabel("training cycles (101 samples each)")
    ax.set_ylabel("RMSE of τ on the 5 rad/s cycle (N·m)")
    ax.set_title("Error against training-set size (thesis Fig. 2.15)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.figure, dpi=120)
    print(f"\nfigure: {args.figure}")


if __name__ == "__main__":
    main()
