"""Work that runs beside the 2 ms loop on the same machine gives way to it.

The loop is its own process, on the highest-numbered CPU when it may have one alone
(`loop_cpu`; device.loop.realtime.prepare_process), at real-time priority when the OS
allows it and at normal priority when it does not (a console run by an ordinary user).
Heavy work started from the window, such as MediaPipe on the live camera
(device.camera.live), then competes with the loop for the CPU on equal terms: on the
2-core development VM the live pose at normal priority took one core whole and raised
the loop's late share by 0.05–0.12 percentage points (docs/performance.md).

`give_way_to_the_loop` lowers the calling thread's priority (a higher nice value: the
scheduler gives a nice-10 thread about a tenth of a nice-0 one's share when both want
the CPU) and keeps it off the loop's CPU. On Linux both are attributes of the thread
and are copied to the threads it starts, so a worker that calls it before it makes its
model takes the model's own thread pool along. Raising one's nice value needs no
privilege; lowering it again would, so only a worker thread of its own should call it.
"""

from __future__ import annotations

import os
import threading

BACKGROUND_NICE = 10
"""How much lower than the window's the background work's priority is (nice steps)."""

NICE_MAX = 19


def loop_cpu(available: set[int]) -> int:
    """The CPU the loop takes when it runs on one of its own: the highest-numbered, which
    the OS gives least interrupt handling on most machines."""
    return max(available)


def give_way_to_the_loop(nice: int = BACKGROUND_NICE) -> list[str]:
    """Lower the calling thread's priority by `nice` and keep it off the loop's CPU (when
    there are others). Returns what could not be done, one line each."""
    problems: list[str] = []
    thread = threading.get_native_id()
    try:
        current = os.getpriority(os.PRIO_PROCESS, thread)
        os.setpriority(os.PRIO_PROCESS, thread, min(NICE_MAX, current + nice))
    except (AttributeError, OSError) as exc:
        problems.append(f"could not lower the background work's priority ({exc}); "
                        "it competes with the loop on equal terms")
    try:
        available = os.sched_getaffinity(0)  # 0: the calling thread on Linux
        if len(available) > 1:
            os.sched_setaffinity(0, available - {loop_cpu(available)})
    except (AttributeError, OSError) as exc:
        problems.append(f"could not keep the background work off the loop's CPU ({exc})")
    return problems
