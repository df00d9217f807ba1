"""Which clock each live record is on, so the robot's LSL stream never goes back in time.

The loop's records carry `wall_time`, seconds from the moment it began ticking; that moment
is new at every Connect. The loop says so with a ClockStarted (its monotonic origin and
the ring sequence number of the first record on it) before it pushes that record. A
reader that reads a batch of records and *then* the loop's messages therefore holds the
origin of every record it read: `RingClocks` keeps the origins by first sequence number
and stamps each record `origin + wall_time`, the monotonic time of its sensor read, which
is LSL's `local_clock()` on Linux (device.lsl.library).

Before this, the outlet took its origin from the trial's start event, which the reader
could meet after the trial's first records (they were dropped), and kept it across a
Disconnect and Connect (the next connection's samples were stamped as much earlier as it
had been connected: the stream went backwards).

`RingClocks` also keeps the stamps of the last few seconds of records by sequence number,
so a marker for an event at a given record (device.loop.messages.TrialMarker) is stamped
exactly at that record's sensor read, whichever of the two the reader meets first.
"""

from __future__ import annotations

import bisect
from collections import deque

import numpy as np

HISTORY = 8192
"""Records whose stamps are kept for the markers (16 s at 500 Hz)."""


class RingClocks:
    """Ring sequence numbers → monotonic stamps (module docstring)."""

    def __init__(self, history: int = HISTORY) -> None:
        self._firsts: list[int] = []
        self._origins: list[float] = []
        self._stamps = np.full(history, np.nan)
        self._newest = -1  # the newest sequence number stamped
        self.unstamped = 0
        """Records met before any clock was known (none once ClockStarted precedes them)."""

    def started(self, first_seq: int, origin_monotonic_s: float) -> None:
        """A ClockStarted: records from `first_seq` on count from `origin_monotonic_s`."""
        at = bisect.bisect_left(self._firsts, first_seq)
        if at < len(self._firsts) and self._firsts[at] == first_seq:
            self._origins[at] = origin_monotonic_s
            return
        self._firsts.insert(at, first_seq)
        self._origins.insert(at, origin_monotonic_s)
        del self._firsts[:-64], self._origins[:-64]  # a session's connections, and more

    def stamps(self, wall_time: np.ndarray, first_seq: int) -> np.ndarray:
        """The monotonic stamps of consecutive records from `first_seq` (NaN where no clock
        is known yet); remembered for `stamp_of`."""
        n = len(wall_time)
        seqs = first_seq + np.arange(n)
        which = np.searchsorted(np.asarray(self._firsts, dtype=np.int64), seqs,
                                side="right") - 1
        origins = np.asarray([*self._origins, np.nan])[np.where(which >= 0, which, -1)]
        out = origins + np.asarray(wall_time, dtype=float)
        self.unstamped += int(np.count_nonzero(which < 0))
        size = len(self._stamps)
        keep = slice(max(0, n - size), n)
        self._stamps[seqs[keep] % size] = out[keep]
        if n:
            self._newest = max(self._newest, int(seqs[-1]))
        return out

    def stamp_of(self, seq: int) -> float | None:
        """The stamp of record `seq` if it was stamped and is still remembered, else None
        (not reached yet, or too old)."""
        size = len(self._stamps)
        if seq > self._newest or seq <= self._newest - size:
            return None
        value = float(self._stamps[seq % size])
        return None if np.isnan(value) else value

    def reached(self, seq: int) -> bool:
        return seq <= self._newest


class MarkerQueue:
    """Markers waiting for the record they belong to (a trial's start is announced before
    its first record is pushed; a fault after its record)."""

    def __init__(self) -> None:
        self._waiting: deque = deque()

    def add(self, marker) -> None:
        self._waiting.append(marker)

    def ready(self, clocks: RingClocks, *, flush: bool = False) -> list[tuple[object, float]]:
        """(marker, stamp) for every marker whose record has been stamped, in order: at
        that record's stamp, or at the marker's own send time when the record is gone or,
        with `flush`, will never come (a Disconnect, the outlet closing)."""
        out = []
        while self._waiting:
            marker = self._waiting[0]
            if not (flush or clocks.reached(marker.seq)):
                break
            self._waiting.popleft()
            stamp = clocks.stamp_of(marker.seq)
            out.append((marker, marker.monotonic_s if stamp is None else stamp))
        return out
