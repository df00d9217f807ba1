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
import subprocess
import sys
import time
from pathlib import Path

from device.compiled.cachedir import CACHE_DIR, is_warm

GROUPS = ("physics", "control", "headless", "loop")
"""The simulator's physics; the pipeline's control and the supervisor; the headless run
(run_ticks); the live loop's tick engine (the simulator's tick in one call, and the
tick around another backend's read and write). The last two call the first two, which
share only the robot's terms: a cold cache compiles those two at once in two processes
(`compile_in_parallel`)."""
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
    from device.backend import SensorReading
    from device.compiled.jit import compiled
    from device.loop.engine import ROW_SIZE, TickEngine, run_ticks, supervised_command
    from device.loop.pipeline import TickPipeline, TrialPlan
    from device.safety.checks import supervise
    from device.safety.supervisor import SafetySupervisor
    from device.sim.faultinjection import FaultInjectingBackend
    from device.sim.simulator import SimulatorBackend

    params = THESIS_SUBJECT.replace(repetitions=1)
    plan = TrialPlan.build(params)
    pipeline = TickPipeline(plan, compiled=True)
    supervisor = SafetySupervisor(plan.robot)
    robot = np.asarray(plan.robot.constants)
    q1, q2 = plan.robot.ik_terms(*plan.start_point_m)
    reading = SensorReading(0.0, q1, q2, 0.0, 0.0, 0.0)
    simulator = None
    if todo != ["control"]:
        simulator = SimulatorBackend.from_trial(params, robot=plan.robot, compiled=True)
        simulator.open()  # the physics: reset …
        reading = simulator.read(0.0)  # … read
        simulator.write(0.0, 0.0)  # … and write
    pipeline.begin(reading.q1_rad, reading.q2_rad)
    v, g, w = pipeline.vectors, supervisor.constants, supervisor.state
    if "control" in todo:
        pipeline.control(0, reading)
        compiled(supervise)(robot, g, w, 0.0, *reading, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, False,
                            False, 0.0, False)
        compiled(supervised_command)(
            pipeline.kind, v.robot, v.model, v.tracker, v.gains, v.assist, v.guide, v.rates,
            v.integral, v.guided, 1, v.rows, pipeline.rows_from, pipeline.n_rows,
            pipeline.approach_ticks, pipeline.period_s, pipeline.sensor_offset_rad, v.last, g,
            w, 0.0, *reading, 0.0, 0.0, False, False)
    if "headless" in todo:
        (r, a, c, p, table, episodes), flavour, scratch = simulator.physics
        flavour(run_ticks)(
            0, 1, plan.period_s, r, a, c, p, table, episodes, simulator.state, simulator.noise,
            scratch, pipeline.kind, v.robot, v.arm, v.model, v.tracker, v.gains, v.assist,
            v.guide, v.rates, v.integral, v.guided, v.rows, pipeline.rows_from,
            pipeline.n_rows, pipeline.approach_ticks, pipeline.sensor_offset_rad, v.last, g, w,
            np.zeros((1, ROW_SIZE)), 0, False, False)
    if "loop" in todo:
        # the simulator's tick in one call, and the tick around any other backend's read
        # and write (here the simulator's, through the fault-injecting wrapper)
        engine = TickEngine(simulator, pipeline, supervisor)
        engine.rehearse(None, 0.002)
        engine.step(None, 0.002, 0.0, 0.0, False, False)
        engine.step(0, 0.004, 0.0, 0.0, False, False)
        wrapped = TickEngine(FaultInjectingBackend(simulator, "nan", at_s=1e9), pipeline,
                             supervisor)
        wrapped.step(None, 0.006, 0.0, 0.0, False, False)
        wrapped.step(1, 0.008, 0.0, 0.0, False, False)
    if simulator is not None:
        simulator.close()
    _loaded.update(todo)
    return time.perf_counter() - started


def compile_in_parallel() -> float:
    """Fill a cold cache: the physics and the control kernels compiled at once in two
    processes (numba compiles in one thread; a cache entry is written whole or not at
    all, so two processes compiling a shared term write the same entry), then everything
    here, mostly from the cache. Returns the seconds it took."""
    started = time.perf_counter()
    workers = [subprocess.Popen([sys.executable, "-m", "device.compiled.warmup", "--group",
                                 group]) for group in ("physics", "control")]
    for worker in workers:
        worker.wait()
    load_kernels()
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
    if "--group" in sys.argv:
        load_kernels((sys.argv[sys.argv.index("--group") + 1],))
        sys.exit(0)
    if is_warm() and "--force" not in sys.argv:
        sys.exit(0)
    print("Compiling the tick's kernels (once, under a minute)…", file=sys.stderr)
    prune_stale_caches()
    seconds = compile_in_parallel()
    print(f"compiled kernels ready in {seconds:.1f} s (cache: {CACHE_DIR or 'none'})",
          file=sys.stderr)
