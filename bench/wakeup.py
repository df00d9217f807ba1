"""The machine's own floor for the loop's lateness: how late a process that does nothing
but sleep wakes up.

    .venv/bin/python bench/wakeup.py [--seconds 90]

Prepares the process exactly as the loop does: SCHED_FIFO where allowed, pinned to
the last CPU, 1 ns timer slack, gc off. It then sleeps 1.5 ms at a time, the loop's
sleep before its spin, and prints how far past each 1.5 ms it woke up. Whatever this
shows, bench/loop_jitter.py cannot beat. On the 2-core development VM (a Firecracker
guest) it shows rare wake-ups 2–10 ms late: the host preempting the virtual CPU, not
anything the loop does. Figures only, no assertion.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from device.realtime import LAST_CPU, prepare_process

SLEEP_S = 0.0015


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=90.0)
    args = parser.parse_args()
    problems = prepare_process(LAST_CPU)
    n = int(args.seconds / (SLEEP_S + 0.00005))
    late = np.empty(n)
    clock = time.perf_counter
    for i in range(n):
        start = clock()
        time.sleep(SLEEP_S)
        late[i] = clock() - start - SLEEP_S
    ms = late * 1e3
    print(f"{n} sleeps of {SLEEP_S * 1e3:g} ms" + (f" ({'; '.join(problems)})" if problems else ""))
    print(f"woke late by p50 {np.percentile(ms, 50):.3f}  p99 {np.percentile(ms, 99):.3f}  "
          f"p99.99 {np.percentile(ms, 99.99):.3f}  max {ms.max():.3f} ms; "
          f"{(ms > 1).sum()} over 1 ms, {(ms > 2).sum()} over 2 ms")


if __name__ == "__main__":
    main()
