"""Keeping a 2 ms period in CPython: absolute deadlines, a hybrid wait, and what the OS allows.

* Absolute deadlines (`next += period`): a late tick does not shift every later one.
* Hybrid wait: `time.sleep` until shortly before the deadline (the kernel wakes us
  up to ~50 µs late with the default timer slack, more under load), then spin on
  `perf_counter` for the last stretch. The spin costs CPU only for that margin.
* Timer slack 1 ns (prctl PR_SET_TIMERSLACK) so the sleep itself wakes on time.
* Real-time scheduling (SCHED_FIFO) and a CPU of its own when the OS allows; when
  it does not (no privilege, a container), a warning is logged and the loop runs
  at normal priority — the lateness it measures every tick says how well.
* Garbage collection frozen and disabled in the loop process: a collection of the
  young generation can take milliseconds, and the loop allocates only small tuples
  that reference counting frees at once.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import logging
import os
import time

log = logging.getLogger(__name__)

SPIN_MARGIN_S = 0.0003
"""Sleep until this long before the deadline, then spin. 0.3 ms covers the kernel's
wake-up latency on an idle machine with timer slack at 1 ns."""

_PR_SET_TIMERSLACK = 29


def wait_until(deadline_s: float, clock=time.perf_counter, sleep=time.sleep) -> float:
    """Return at or just after `deadline_s` (perf_counter time); returns the time reached."""
    remaining = deadline_s - clock()
    if remaining > SPIN_MARGIN_S:
        sleep(remaining - SPIN_MARGIN_S)
    now = clock()
    while now < deadline_s:
        now = clock()
    return now


LAST_CPU = -1
"""`cpu` value for the highest-numbered CPU the process may use (the one the OS gives
least to interrupt handling on most machines)."""


def prepare_process(cpu: int | None = None, priority: int = 50) -> list[str]:
    """Make this process as real-time as the OS allows. Returns what could not be done,
    one line each (also logged as warnings), so the caller can show it."""
    problems: list[str] = []
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        if libc.prctl(_PR_SET_TIMERSLACK, 1, 0, 0, 0) != 0:
            problems.append("timer slack could not be set to 1 ns; sleeps may wake ~50 µs late")
    except (OSError, AttributeError):
        problems.append("prctl is not available; sleeps may wake ~50 µs late")
    if hasattr(os, "sched_setscheduler"):
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        except (PermissionError, OSError) as exc:
            problems.append(
                f"real-time priority (SCHED_FIFO {priority}) refused ({exc.strerror or exc}); "
                "the loop runs at normal priority"
            )
    else:
        problems.append("real-time scheduling is not available on this OS")
    if cpu is not None and hasattr(os, "sched_setaffinity"):
        try:
            available = os.sched_getaffinity(0)
            if cpu == LAST_CPU:
                cpu = max(available)
            if cpu in available and len(available) > 1:
                os.sched_setaffinity(0, {cpu})
            else:
                problems.append(f"CPU {cpu} is not available for the loop alone")
        except OSError as exc:
            problems.append(f"CPU affinity refused ({exc.strerror or exc})")
    gc.collect()
    gc.freeze()
    gc.disable()
    for problem in problems:
        log.warning("real-time setup: %s", problem)
    return problems
