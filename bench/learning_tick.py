"""Per-tick cost of a learned model in the loop: the numpy TickModel (core.learning.tick),
one sample a call, for each model at its default size (Table 2.1's ~800 parameters).

Run: .venv/bin/python bench/learning_tick.py [--calls N]
Prints p50 / p99 in µs per call (goal: ≤ 50 µs in numpy), and the compiled form's
(core.learning.kernel compiled by numba, what the loop runs for an FNN or a DeLaN; goal
≤ 20 µs) called from Python one sample a call (the loop calls it inside its compiled tick,
without that call's overhead). The cost does not depend on the weights' values, so random
weights of the trained shapes are used.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from core.learning import inference, networks as nw
from core.learning.kernel import learned_torques, pack
from core.learning.tick import TickModel
from core.learning.training import TrainingOptions, make_spec


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=20_000)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.normal(size=(50, 2)) for _ in range(3))
    from device.compiled.jit import compiled

    fast = compiled(learned_torques)
    print(f"{'model':<6} {'params':>6} {'tick p50 µs':>12} {'tick p99 µs':>12} "
          f"{'batch µs/sample':>16} {'compiled p50 µs':>16} {'compiled p99 µs':>16}")
    for kind in nw.KINDS:
        spec = make_spec(TrainingOptions(kind=kind, cyclic=(0,)), q, qd, qdd, q + qd)
        params = {k: rng.normal(scale=0.3, size=s) for k, s in nw.param_shapes(spec).items()}
        tick = TickModel(spec, params)
        times = []
        for i in range(args.calls):
            j = i % 50
            t0 = time.perf_counter_ns()
            tick.forces(q[j], qd[j], qdd[j])
            times.append(time.perf_counter_ns() - t0)
        t = np.asarray(times) / 1000.0
        big = [np.tile(a, (200, 1)) for a in (q, qd, qdd)]
        t0 = time.perf_counter()
        inference.predict(spec, params, *big) if kind != "rnn" else None
        batch = (time.perf_counter() - t0) / 10_000 * 1e6 if kind != "rnn" else float("nan")
        cp50 = cp99 = float("nan")
        if kind != "rnn":
            # the robot's shapes: both joint angles in (a compiled model needs them)
            robot_spec = make_spec(TrainingOptions(kind=kind), q, qd, qdd, q + qd)
            weights = pack(robot_spec, {k: rng.normal(scale=0.3, size=s) for k, s in
                                        nw.param_shapes(robot_spec).items()})
            rows = [tuple(map(float, np.r_[q[j], qd[j], qdd[j]])) for j in range(50)]
            fast(weights, *rows[0])  # compile or load it before timing
            times = []
            for i in range(args.calls):
                row = rows[i % 50]
                t0 = time.perf_counter_ns()
                fast(weights, *row)
                times.append(time.perf_counter_ns() - t0)
            cp50, cp99 = np.percentile(np.asarray(times) / 1000.0, [50, 99])
        print(f"{kind:<6} {nw.count_parameters(spec):>6} {np.percentile(t, 50):>12.1f} "
              f"{np.percentile(t, 99):>12.1f} {batch:>16.2f} {cp50:>16.2f} {cp99:>16.2f}")


if __name__ == "__main__":
    main()
