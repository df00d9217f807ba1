"""Load (or, with an empty cache, compile) every compiled kernel ahead of use.

The first call of a compiled function costs a few hundred milliseconds from the cache
and tens of seconds without it; neither may happen inside a 2 ms tick or at the start
of a timed run. The loop calls `load_kernels` when it connects to the simulator, and
the install script runs this module so a fresh install starts with a full cache
(it returns at once, without importing numba, when the cache is already warm):

    .venv/bin/python -m device.compiled.warmup
"""

from __future__ import annotations

import shutil
import sys
import time
from pathlib import Path

from device.compiled.cachedir import CACHE_DIR, is_warm

GROUPS = ("headless", "loop")
"""The headless run's kernels (run_ticks and the simulator's physics) and the live loop's
(the tick engine's, the supervisor's and the simulator's)."""
_loaded: set[str] = set()
STALE_AFTER_S = 7 * 24 * 3600.0


def load_kernels(groups: tuple[str, ...] = GROUPS) -> float:
    """Run the kernels of `groups` once, compiled, on a real simulated trial's objects
    (the results are thrown away), so that their first call, which compiles or loads them,
    happens here and not in a tick; returns the seconds it took, 0 when already done."""
    todo = [group for group in groups if group not in _loaded]
    if not todo:
        return 0.0
    started = time.perf_counter()
    import numpy as np

    from core.trial import THESIS_SUBJECT
    from device.loop.engine import ROW_SIZE, TickEngine, run_ticks
    from device.loop.pipeline import TickPipeline, TrialPlan
    from device.safety.supervisor import SafetySupervisor
    from device.sim.faultinjection import FaultInjectingBackend
    from device.sim.simulator import SimulatorBackend

    for controller in ("smc", "ctpid"):
        params = THESIS_SUBJECT.replace(repetitions=1, controller=controller)
        plan = TrialPlan.build(params)
        simulator = SimulatorBackend.from_trial(params, robot=plan.robot, compiled=True)
        pipeline = TickPipeline(plan, compiled=True)
        supervisor = SafetySupervisor(plan.robot)
        simulator.open()
        reading = simulator.read(0.0)
        pipeline.begin(reading.q1_rad, reading.q2_rad)
        if "loop" in todo:
            # the simulator's tick in one call, and the tick around any other backend's
            # read and write (here the simulator's, through the fault-injecting wrapper)
            engine = TickEngine(simulator, pipeline, supervisor)
            engine.rehearse(None, 0.002)
            engine.step(None, 0.002, 0.0, 0.0, False, False)
            engine.step(0, 0.004, 0.0, 0.0, False, False)
            wrapped = TickEngine(FaultInjectingBackend(simulator, "nan", at_s=1e9), pipeline,
                                 supervisor)
            wrapped.step(None, 0.006, 0.0, 0.0, False, False)
            wrapped.step(1, 0.008, 0.0, 0.0, False, False)
            pipeline.control(2, simulator.read(0.010))
        if "headless" in todo:
            (r, a, c, p, table, episodes), flavour, scratch = simulator.physics
            v = pipeline.vectors
            flavour(run_ticks)(
                0, 1, plan.period_s, r, a, c, p, table, episodes, simulator.state,
                simulator.noise, scratch, pipeline.kind, v.robot, v.model, v.tracker, v.gains,
                v.assist, v.rates, v.integral, v.rows, pipeline.approach_ticks,
                pipeline.sensor_offset_rad, v.last, supervisor.constants, supervisor.state,
                np.zeros((ROW_SIZE, 1)))
        simulator.close()
    _loaded.update(todo)
    return time.perf_counter() - started


def prune_stale_caches(older_than_s: float = STALE_AFTER_S) -> list[Path]:
    """Remove the caches of earlier versions of the kernels beside this one (each source
    edit keys a new directory) once untouched for `older_than_s`, so that another
    checkout in use keeps its own; returns what was removed."""
    if CACHE_DIR is None:
        return []
    removed = []
    cutoff = time.time() - older_than_s
    for sibling in CACHE_DIR.parent.iterdir():
        if (sibling != CACHE_DIR and sibling.is_dir() and len(sibling.name) == 16
                and all(ch in "0123456789abcdef" for ch in sibling.name)
                and sibling.stat().st_mtime < cutoff):
            shutil.rmtree(sibling, ignore_errors=True)
            removed.append(sibling)
    return removed


if __name__ == "__main__":
    if is_warm() and "--force" not in sys.argv:
        sys.exit(0)
    print("Compiling the simulator's kernels (once, about a minute at most)…", file=sys.stderr)
    prune_stale_caches()
    seconds = load_kernels()
    print(f"compiled kernels ready in {seconds:.1f} s (cache: {CACHE_DIR or 'none'})",
          file=sys.stderr)
