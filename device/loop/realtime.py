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

Whatever the loop does, it cannot wake up earlier than the OS wakes it. `measure_wakeups`
measures that floor (the loop's sleep, nothing else), and `timing_warning` says in plain
words when it would trip the hardware's late-tick watchdog: the loop runs it before it
connects a real robot, and bench/wakeup.py prints it for a longer stretch.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import logging
import os
import time
from collections.abc import Callable, Sequence

from device.background import loop_cpu

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


class WallClock:
    """The loop's clock: perf_counter, with `wait_until`'s sleep-then-spin."""

    name = "wall"

    def now(self) -> float:
        return time.perf_counter()

    def wait_until(self, deadline_s: float) -> float:
        return wait_until(deadline_s)

    def sleep(self, seconds: float) -> None:
        time.sleep(seconds)


class OwnClock:
    """A clock of the loop's own, for proving the late-tick watchdog by injection on a
    machine whose host stalls its processes now and then (a shared VM).

    It advances by the loop's own waits, always to the deadline exactly, and by the
    delays it is told of with `sleep` (a fault-injected slow read sleeps on it); never
    by the time the host took from the process. So a tick is late on this clock only
    where a test made it late, and the watchdog's verdict does not depend on the machine.
    The loop still paces itself on the wall clock (it really sleeps), so the console's
    heartbeat and the recorder see a loop that runs in real time.
    """

    name = "own"

    def __init__(self) -> None:
        self._now = time.perf_counter()

    def now(self) -> float:
        return self._now

    def wait_until(self, deadline_s: float) -> float:
        remaining = deadline_s - self._now
        if remaining > 0.0:
            time.sleep(remaining)
            self._now = deadline_s
        return self._now

    def sleep(self, seconds: float) -> None:
        time.sleep(seconds)
        self._now += seconds


CLOCKS = {"wall": WallClock, "own": OwnClock}


LAST_CPU = -1
"""`cpu` value for the highest-numbered CPU the process may use (the one the OS gives
least to interrupt handling on most machines), which background work keeps off
(device.background)."""


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
                cpu = loop_cpu(available)
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


WAKEUP_SLEEP_S = 0.0015
"""The sleep `measure_wakeups` times: the loop's own sleep before its spin."""


def measure_wakeups(seconds: float, sleep_s: float = WAKEUP_SLEEP_S,
                    clock: Callable[[], float] = time.perf_counter,
                    sleep: Callable[[float], None] = time.sleep) -> list[float]:
    """Sleep `sleep_s` again and again for about `seconds`; return how late (s) each
    wake-up came. Call it from a process prepared as the loop is (`prepare_process`)."""
    late: list[float] = []
    end = clock() + seconds
    start = clock()
    while start < end:
        sleep(sleep_s)
        woke = clock()
        late.append(max(0.0, woke - start - sleep_s))
        start = woke
    return late


def timing_warning(late_s: Sequence[float], late_tick_s: float, late_run_ticks: int,
                   period_s: float) -> str:
    """'' when wake-ups this late would not trip the late-tick watchdog (one tick more
    than `late_tick_s` late, or `late_run_ticks` in a row each over a period late);
    otherwise what the therapist should know and do, in one paragraph."""
    if not late_s:
        return ""
    worst = max(late_s)
    run = longest = 0
    for value in late_s:
        run = run + 1 if value > period_s else 0
        longest = max(longest, run)
    if worst <= late_tick_s and longest < late_run_ticks:
        return ""
    if worst > late_tick_s:
        what = (f"the control loop woke up as much as {worst * 1e3:.1f} ms late (the robot "
                f"stops itself at {late_tick_s * 1e3:.0f} ms)")
    else:
        what = (f"the control loop woke up more than one period late {longest} times in a "
                f"row (the robot stops itself at {late_run_ticks})")
    return ("This computer is not keeping the robot's timing: in a timing check just now "
            f"{what}. A trial on the robot would probably stop with \"the control loop ran "
            "late\". Close other programs and try again; a clinic PC needs a real-time "
            "kernel or a CPU kept for the loop (docs/hardware.md, Timing).")
