"""Per-tick cost of the controllers and the performance-based assistance.

    .venv/bin/python bench/controllers.py [--ticks N]

Walks the thesis D (constant speed, 4 s per traversal, 2 ms ticks) over and
over for N ticks (default 120 000, 60 traversals), feeding each controller the
reference plus a small deterministic measurement error, and a hand force of
about 1.5 N that swings ±40° around the path's direction (so the assistance is
inside its 20° cone on part of the ticks and does its full work there).
`time.perf_counter_ns` brackets each call: the controller's `step`, or `step`
followed by `PerformanceAssistance.apply`. Prints p50 / p99 / max in µs and the
share of ticks over the 50 µs budget. No assertion: figures only.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from core.control import PerformanceAssistance, make_controller
from core.robot import RobotModel
from core.trial import THESIS_SUBJECT

BUDGET_US = 50.0
DT_S = 0.002


def inputs(robot: RobotModel, seed: int = 1):
    """One traversal of ticks: (q, qd, r, rd, rdd, force, direction) as lists of floats."""
    traj = THESIS_SUBJECT.replace(repetitions=1).trajectory()
    t = np.arange(round(traj.duration_s / DT_S)) * DT_S
    r, rd, rdd = traj.joint_reference(robot, t)
    rng = np.random.default_rng(seed)
    q = r + rng.normal(0.0, 1e-3, r.shape)
    qd = rd + rng.normal(0.0, 0.03, rd.shape)
    direction = traj.sample(t).direction
    swing = np.radians(40.0) * np.sin(2.0 * np.pi * t / 0.7)
    c, s = np.cos(swing), np.sin(swing)
    magnitude = 1.5 + 0.3 * rng.normal(size=t.size)
    force = magnitude[:, None] * np.column_stack(
        (c * direction[:, 0] - s * direction[:, 1], s * direction[:, 0] + c * direction[:, 1])
    )
    return [
        tuple(float(v) for v in row)
        for row in np.column_stack((q, qd, r, rd, rdd, force, direction))
    ]


def run(controller, assistance, ticks: int, rows) -> tuple[np.ndarray, float]:
    """Time `ticks` ticks; returns the cost per tick (ns) and the share assisted."""
    timer = time.perf_counter_ns
    costs = [0] * ticks
    step = controller.step
    apply = assistance.apply if assistance is not None else None
    n_rows = len(rows)
    assisted = 0
    for k in range(ticks):
        q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2, fx, fy, dx, dy = rows[k % n_rows]
        if apply is None:
            start = timer()
            step(DT_S, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2)
            costs[k] = timer() - start
        else:
            start = timer()
            tau1, tau2 = step(DT_S, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2)
            out = apply(q1, q2, tau1, tau2, fx, fy, dx, dy)
            costs[k] = timer() - start
            assisted += out[2]
    return np.asarray(costs, dtype=float), assisted / ticks


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=120_000, help="ticks per case (≥ 100 000)")
    args = parser.parse_args()
    robot = RobotModel()
    rows = inputs(robot)
    print(f"{args.ticks} ticks per case along the thesis D; budget {BUDGET_US:.0f} µs p99")
    print(f"{'case':<22}{'p50 µs':>9}{'p99 µs':>9}{'max µs':>10}{'>50 µs':>9}{'assisted':>10}")
    worst_p99 = 0.0
    for name in ("smc", "ctpid"):
        for with_assistance in (False, True):
            controller = make_controller(name, robot)
            assistance = PerformanceAssistance(robot) if with_assistance else None
            run(controller, assistance, 5_000, rows)  # warm caches and the allocator
            controller.reset()
            costs_ns, share = run(controller, assistance, args.ticks, rows)
            us = costs_ns / 1e3
            p50, p99 = np.percentile(us, [50, 99])
            over = np.mean(us > BUDGET_US)
            label = name + (" + assistance" if with_assistance else "")
            assisted = f"{100 * share:.0f} %" if with_assistance else "-"
            print(f"{label:<22}{p50:9.1f}{p99:9.1f}{us.max():10.1f}"
                  f"{100 * over:8.3f}%{assisted:>10}")
            if with_assistance:
                worst_p99 = max(worst_p99, p99)
    print(f"worst p99 with assistance: {worst_p99:.1f} µs = {worst_p99 / BUDGET_US:.2f} of the "
          f"{BUDGET_US:.0f} µs budget ({math.ceil(args.ticks * DT_S)} s of loop time per case)")


if __name__ == "__main__":
    main()
