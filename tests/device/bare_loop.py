"""A DeviceLoop in the test's own process, without the loop process around it: its console
pipe, its ring and its shared flags made and torn down in one place, for tests that drive
its ticks and commands by hand (the loop's ordering, timing, area and rebuild checks)."""

from __future__ import annotations

import contextlib
import multiprocessing as mp
from types import SimpleNamespace

from device.loop.process import DeviceLoop, LoopConfig
from device.recording.ring import RecordRing


@contextlib.contextmanager
def bare_loop(ring_records: int, config: LoopConfig | None = None, *, recording_failed=None):
    """(loop, the console's end of its pipe); the backend disconnected and the pipe and
    ring closed after. `recording_failed`: the shared value the test sets (`.value`), zero
    when not given."""
    console, loop_end = mp.Pipe()
    ring = RecordRing.create(ring_records)
    loop = DeviceLoop(loop_end, None, ring, SimpleNamespace(value=0),
                      SimpleNamespace(value=0), recording_failed or SimpleNamespace(value=0),
                      config or LoopConfig(compiled=False, realtime=False))
    try:
        yield loop, console
    finally:
        loop._disconnect_backend()
        ring.close()
        ring.unlink()
        console.close()
        loop_end.close()
