"""Per-call cost of the core models on plain floats, as the 2 ms tick calls them.

Run: .venv/bin/python bench/core_models.py [--calls N]
Prints p50 / p99 / max in µs for FK, Jacobian, M_R, C_R, inverse dynamics and for one
whole control tick's model work (goal: ≤ 20 µs p99 for the tick).
"""

from __future__ import annotations

import argparse
import gc
import time

import numpy as np

from core.interaction import subject_state
from core.robot import RobotModel
from core.trial import THESIS_SUBJECT


def percentiles(samples_ns: list[int]) -> tuple[float, float, float]:
    a = np.asarray(samples_ns, dtype=float) / 1000.0
    return float(np.percentile(a, 50)), float(np.percentile(a, 99)), float(a.max())


def measure(fn, states, calls: int) -> tuple[float, float, float]:
    clock = time.perf_counter_ns
    out = []
    n = len(states)
    for i in range(calls):
        s = states[i % n]
        t0 = clock()
        fn(*s)
        out.append(clock() - t0)
    return percentiles(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=100_000)
    args = parser.parse_args()

    robot = RobotModel()
    arm = THESIS_SUBJECT.arm()
    trajectory = THESIS_SUBJECT.trajectory()
    t = np.arange(0.0, trajectory.duration_s, 0.002)
    q, qd, qdd = trajectory.joint_reference(robot, t)
    rng = np.random.default_rng(0)
    force = rng.normal(0.0, 2.0, (t.size, 2))
    states = [
        (float(q[i, 0]), float(q[i, 1]), float(qd[i, 0]), float(qd[i, 1]),
         float(qdd[i, 0]), float(qdd[i, 1]), float(force[i, 0]), float(force[i, 1]))
        for i in range(t.size)
    ]

    def tick(q1, q2, qd1, qd2, qdd1, qdd2, fx, fy):
        # What the loop's model work is per tick: the end-effector position, the
        # controller's model terms, the inverse dynamics, the subject's contribution
        # J_Rᵀ F, and the whole interaction model for the record.
        robot.position(q1, q2)
        robot.mass_terms(q1, q2)
        robot.bias_terms(q1, q2, qd1, qd2)
        robot.inverse_dynamics_terms(q1, q2, qd1, qd2, qdd1, qdd2)
        robot.joint_torque_terms(q1, q2, fx, fy)
        subject_state(robot, arm, q1, q2, qd1, qd2, qdd1, qdd2, fx, fy)

    cases = [
        ("FK (eq. 3.2)", lambda q1, q2, *_: robot.position(q1, q2)),
        ("Jacobian (eq. 3.3)", lambda q1, q2, *_: robot.jacobian_terms(q1, q2)),
        ("M_R (eq. 3.7)", lambda q1, q2, *_: robot.mass_terms(q1, q2)),
        ("C_R (eq. 3.8)", lambda q1, q2, qd1, qd2, *_: robot.coriolis_terms(q1, q2, qd1, qd2)),
        ("inverse dynamics (eq. 3.6)",
         lambda q1, q2, qd1, qd2, qdd1, qdd2, *_:
         robot.inverse_dynamics_terms(q1, q2, qd1, qd2, qdd1, qdd2)),
        ("subject state (eq. 3.27–3.38)",
         lambda q1, q2, qd1, qd2, qdd1, qdd2, fx, fy:
         subject_state(robot, arm, q1, q2, qd1, qd2, qdd1, qdd2, fx, fy)),
        ("whole tick's model work", tick),
    ]
    gc.disable()
    try:
        print(f"{'call':<32}{'p50 µs':>9}{'p99 µs':>9}{'max µs':>9}   ({args.calls} calls each)")
        for name, fn in cases:
            measure(fn, states, 2000)  # warm up
            p50, p99, worst = measure(fn, states, args.calls)
            print(f"{name:<32}{p50:9.2f}{p99:9.2f}{worst:9.1f}")
    finally:
        gc.enable()
    print(f"goal: whole tick ≤ 20 µs p99; numpy on 2×2 arrays would cost ~30 µs "
          f"(for reference, one np.linalg.solve of 2×2: {numpy_reference():.1f} µs)")


def numpy_reference() -> float:
    a = np.array([[1.0, 0.2], [0.2, 1.0]])
    b = np.array([1.0, 2.0])
    t0 = time.perf_counter_ns()
    for _ in range(10_000):
        np.linalg.solve(a, b)
    return (time.perf_counter_ns() - t0) / 10_000 / 1000.0


if __name__ == "__main__":
    main()
