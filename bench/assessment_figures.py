"""What the assessment figures (core.assessment) cost on recordings of a task's size.

    .venv/bin/python bench/assessment_figures.py [--repeats N]

Constructed recordings at 500 Hz, the protocols' sizes (core.assessment.protocol):
visually guided reaching, 16 minimum-jerk reaches of 10 cm in a 96 s trial (speed
derived from the positions, as for a trial file); circle drawing, 5 laps of a 14 cm
circle each way (20 s a trial); active range, 60 s of outward reaches against a
reachable polygon of 200 vertices; isometric strength, 8 pushes of 3 s; position
sense, 12 reproductions. Prints the median and the worst of N runs per task, in ms.

Figures only; no assertion.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from core.assessment.active_range import range_figures
from core.assessment.circle import circle_figures, circle_task_figures
from core.assessment.position_sense import position_figures
from core.assessment.reaching import vgr_figures, vgr_reaches
from core.assessment.strength import PushWindow, strength_figures
from core.reaches import Reach

DT = 0.002


def _minimum_jerk(t, t0, duration, start, end):
    tau = np.clip((t - t0) / duration, 0.0, 1.0)
    share = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    return share[:, None] * (np.asarray(end) - np.asarray(start))


def reaching_case():
    t = np.arange(round(96.0 / DT)) * DT
    position = np.zeros((t.size, 2))
    reaches, ends = [], []
    for k in range(16):
        angle = 2 * math.pi * (k % 8) / 8
        target = (0.1 * math.cos(angle), 0.1 * math.sin(angle))
        on = 6.0 * k
        position += _minimum_jerk(t, on + 0.3, 0.8, (0, 0), target)
        position += _minimum_jerk(t, on + 3.3, 0.8, target, (0, 0))
        reaches.append(Reach(on, (0.0, 0.0), target))
        ends.append(on + 3.0)
    return lambda: vgr_figures(vgr_reaches(t, position, reaches, ends_s=ends))


def circle_case():
    t = np.arange(round(20.0 / DT)) * DT
    phase = 2 * math.pi * t / 4.0
    position = np.column_stack([0.07 * np.cos(phase), 0.4 + 0.07 * np.sin(phase)])
    angles = np.column_stack([0.6 + 0.2 * np.sin(phase), 1.4 + 0.3 * np.sin(phase - 1.0)])
    mirrored = position * [1.0, 1.0]
    mirrored[:, 1] = 0.8 - position[:, 1]
    return lambda: circle_task_figures(circle_figures(t, position, angles),
                                       circle_figures(t, mirrored, angles))


def range_case():
    t = np.arange(round(60.0 / DT)) * DT
    angle = 2 * math.pi * t / 7.5
    reach = 0.15 * np.abs(np.sin(2 * math.pi * t / 1.5))
    position = np.column_stack([reach * np.cos(angle), 0.4 + reach * np.sin(angle)])
    ring = np.linspace(0, 2 * math.pi, 200, endpoint=False)
    region = np.column_stack([0.2 * np.cos(ring), 0.4 + 0.12 * np.sin(ring)])
    return lambda: range_figures(position, region)


def strength_case():
    t = np.arange(round(24.0 / DT)) * DT
    force = np.column_stack([5 * np.sin(t), 5 * np.cos(t)])
    windows = [PushWindow(math.radians(45 * k), 3.0 * k + 0.5, 3.0 * k + 2.5) for k in range(8)]
    return lambda: strength_figures(t, force, windows)


def position_case():
    rng = np.random.default_rng(0)
    targets = np.array([[0.1, 0.4], [-0.1, 0.4], [0.0, 0.5], [0.0, 0.3]] * 3)
    reproduced = targets + rng.normal(0.0, 0.01, targets.shape)
    return lambda: position_figures(targets, reproduced)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    cases = {"reaching": reaching_case(), "circle": circle_case(), "range": range_case(),
             "strength": strength_case(), "position": position_case()}
    print(f"{'task':10s} {'median ms':>10s} {'worst ms':>10s}")
    for name, run in cases.items():
        run()  # the first call imports and warms the filters
        times = []
        for _ in range(args.repeats):
            started = time.perf_counter()
            run()
            times.append(1e3 * (time.perf_counter() - started))
        print(f"{name:10s} {np.median(times):10.1f} {max(times):10.1f}")


if __name__ == "__main__":
    main()
