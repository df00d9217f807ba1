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

GROUPS = ("simulator", "headless", "loop")
"""The Python simulator's (its dynamics and the patients' torques), the headless
trial's and the live loop's."""
_loaded: set[str] = set()
STALE_AFTER_S = 7 * 24 * 3600.0


def load_kernels(groups: tuple[str, ...] = GROUPS) -> float:
    """Call the kernels of `groups` once on placeholder arrays of the real types (their
    results are thrown away); returns the seconds it took, 0 when already done here."""
    todo = [group for group in groups if group not in _loaded]
    if not todo:
        return 0.0
    started = time.perf_counter()
    import numpy as np

    from device.compiled import control as ctl
    from device.compiled import dynamics as dyn
    from device.compiled import guard
    from device.compiled.looptick import _SHADOW, loop_tick, warm_tick
    from device.compiled.trial import run_ticks
    from device.recording.record import RECORD_DTYPE

    sc, p, kc, gc = (np.zeros(n) for n in (dyn.S_SIZE, dyn.P_SIZE, ctl.K_SIZE, guard.G_SIZE))
    table, rows, noise = np.zeros((1, 18)), np.zeros((1, 12)), np.zeros((1, 3))
    episodes = np.zeros(1)
    x, z, w, c = (np.zeros(n) for n in (dyn.X_SIZE, ctl.Z_SIZE, guard.W_SIZE, ctl.C_SIZE))
    scratch = np.zeros(15)
    if "simulator" in todo:
        dyn.evaluate(sc, p, table, episodes, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, scratch)
        dyn.patient_torque(p, table, episodes, 0.0, 0.0, 0.0, 0.0, 0.0)
    if "headless" in todo:
        dyn.reset(sc, p, table, episodes, 0.0, 0.0, noise, x)
        run_ticks(0, 0, 0.002, rows, 0, sc, p, table, episodes, x, noise, kc, z, gc, w, c,
                  scratch, np.zeros(1, dtype=RECORD_DTYPE))
    if "loop" in todo:
        loop_tick(0, 0.0, 0.0, 0.0, False, False, rows, 0, sc, p, table, episodes, x, noise,
                  kc, z, gc, w, c, scratch, np.zeros(dyn.X_SIZE + ctl.Z_SIZE + guard.W_SIZE))
        warm_tick(0, 0.0, rows, 0, sc, p, table, episodes, x, noise, kc, z, gc, w,
                  np.zeros(_SHADOW))
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
