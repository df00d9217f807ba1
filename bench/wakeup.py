"""The machine's own floor for the loop's lateness: how late a process that does nothing
but sleep wakes up.

    .venv/bin/python bench/wakeup.py [--seconds 90]

Prepares the process exactly as the loop does: SCHED_FIFO where allowed, pinned to
the last CPU, 1 ns timer slack, gc off. It then sleeps 1.5 ms at a time, the loop's
sleep before its spin, and prints how far past each 1.5 ms it woke up. Whatever this
shows, bench/loop_jitter.py cannot beat. On the 2-core development VM (a Firecracker
guest) it shows rare wake-ups 2–10 ms late: the host preempting the virtual CPU, not
anything the loop does. The last line says whether the hardware's late-tick watchdog
(10 ms, or 10 ticks in a row a period late) would have tripped, in the words the
console uses before it connects a robot. Figures only, no assertion.
"""

from __future__ import annotations

import argparse

import numpy as np

from device.loop.realtime import (
    LAST_CPU,
    WAKEUP_SLEEP_S,
    measure_wakeups,
    prepare_process,
    timing_warning,
)
from device.safety.limits import SafetyLimits


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=90.0)
    args = parser.parse_args()
    problems = prepare_process(LAST_CPU)
    late = np.array(measure_wakeups(args.seconds))
    ms = late * 1e3
    print(f"{late.size} sleeps of {WAKEUP_SLEEP_S * 1e3:g} ms"
          + (f" ({'; '.join(problems)})" if problems else ""))
    print(f"woke late by p50 {np.percentile(ms, 50):.3f}  p99 {np.percentile(ms, 99):.3f}  "
          f"p99.99 {np.percentile(ms, 99.99):.3f}  max {ms.max():.3f} ms; "
          f"{(ms > 1).sum()} over 1 ms, {(ms > 2).sum()} over 2 ms, "
          f"{(ms > 10).sum()} over 10 ms")
    limits = SafetyLimits()
    warning = timing_warning(late.tolist(), limits.late_tick_s, limits.late_run_ticks,
                             limits.period_s)
    print(warning or "this machine would not have tripped the hardware's late-tick watchdog")


if __name__ == "__main__":
    main()
