"""Capturing a live EMG source on its own thread while a trial runs.

A source is anything with `read(timeout_s) -> (monotonic stamps (k,), samples (k, C))`,
`rate_hz` and `close()`: the Trigno client (device.emg.trigno) or an LSL inlet
(device.lsl). The capture runs in the console process, never in the loop process:
the loop neither waits for it nor shares a lock with it, so EMG cannot hold the trial
up (bench/emg.py measures the loop beside it). A source that fails ends the capture
and keeps what it had; `error` says why, and the trial goes on.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from device.errors import DeviceError

STALL_S = 1.0
"""No sample for this long, or a jump of this much in the stamps, is a source that stopped
(module docstring). EMG software sends every 10-50 ms; liblsl took 1.7 s or more to
recover a restarted stream on this machine, so a restart is always caught."""

class EmgSource(Protocol):
    rate_hz: float

    def read(self, timeout_s: float = 0.1) -> tuple[np.ndarray, np.ndarray]: ...

    def close(self) -> None: ...


@dataclass(frozen=True, slots=True, eq=False)
class Captured:
    """What a capture recorded: monotonic stamps (M,), samples (M, C), the source's rate,
    the samples the stamps say are missing, and the error that ended it (or "")."""

    stamps_s: np.ndarray
    samples: np.ndarray
    rate_hz: float
    missing: int
    error: str
    labels: tuple[str, ...] = ()
    """The channels' names as the source declares them (an LSL stream's labels), one per
    column, or () when it names none."""
    notes: tuple[str, ...] = ()
    """What the source said of itself when it opened (an LSL stream's trigger channel left
    out: device.lsl.inlet), kept with the EMG it gave (app.emg.importing)."""
    clock_offsets: tuple[tuple[float, float], ...] = ()
    """The clock offsets the source added to put its stamps on this machine's clock (an
    LSL inlet's: device.lsl.inlet), each with the first stamp it was added to; () for a
    source stamped on this machine's clock (a Trigno)."""


class EmgCapture:
    """Reads a source on a daemon thread from `start()` until `stop()`."""

    def __init__(self, source: EmgSource, *, channels=None, latest_s: float = 5.0,
                 stall_s: float | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.source = source
        self.channels = None if channels is None else list(channels)
        self._chunks: list[tuple[np.ndarray, np.ndarray]] = []
        self._lock = threading.Lock()  # the capture's own lock: the loop never takes it
        self._running = threading.Event()
        self._ended = threading.Event()  # set when the reading thread returns, for any reason
        self._thread: threading.Thread | None = None
        self.error = ""
        self.latest_s = latest_s
        self._forgotten = 0  # samples dropped by forget_before, for the even restamp
        # read at each capture, not at import: a test's fake source may be given longer
        self.stall_s = STALL_S if stall_s is None else stall_s
        self.clock = clock

    def start(self) -> EmgCapture:
        self._running.set()
        self._thread = threading.Thread(target=self._run, name="emg-capture", daemon=True)
        self._thread.start()
        return self

    def _run(self) -> None:
        try:
            self._read_until_stopped()
        finally:
            self._ended.set()

    def wait_ended(self, timeout_s: float) -> bool:
        """Wait up to `timeout_s` s for the capture to end by itself (its source failed or
        stopped streaming: `error` says why); True as soon as it has. A recording of a
        fixed length (`rehab emg record`) waits on this rather than sleeping, so a patient
        is not kept contracting for a source that is gone."""
        return self._ended.wait(timeout_s)

    def _read_until_stopped(self) -> None:
        heard, last_stamp = self.clock(), None
        while self._running.is_set():
            try:
                stamps, samples = self.source.read(0.05)
            except DeviceError as exc:
                self._end(str(exc))
                return
            now = self.clock()
            if not stamps.size and now - heard > self.stall_s:
                self._end(f"no EMG came for {now - heard:.1f} s: the source stopped streaming")
                return
            if stamps.size and last_stamp is not None and stamps[0] - last_stamp > self.stall_s:
                self._end(f"the source's samples jumped {stamps[0] - last_stamp:.1f} s ahead: "
                          "it stopped and started again")
                return
            if stamps.size:
                heard, last_stamp = now, float(stamps[-1])
                if self.channels is not None:
                    samples = samples[:, self.channels]
                with self._lock:
                    self._chunks.append((stamps, np.asarray(samples, dtype=float)))

    def _end(self, error: str) -> None:
        self.error = error
        self._running.clear()

    @property
    def running(self) -> bool:
        return self._running.is_set()

    def latest(self) -> tuple[np.ndarray, np.ndarray]:
        """The last `latest_s` seconds captured (for a live view), copied: the reads from
        the newest back to the first that reaches `latest_s` before the newest stamp,
        however many a second the source gives (the 250 newest were taken, as if no source
        gave more than 50 a second: a Trigno base station's came about 130 a second, and
        the live plot showed 1.3-2 s of its 5)."""
        chunks = []
        with self._lock:
            if self._chunks:
                oldest = float(self._chunks[-1][0][-1]) - self.latest_s
                for chunk in reversed(self._chunks):
                    chunks.append(chunk)
                    if chunk[0][0] <= oldest:
                        break
        if not chunks:
            return np.empty(0), np.empty((0, 0))
        chunks.reverse()
        t = np.concatenate([c[0] for c in chunks])
        x = np.concatenate([c[1] for c in chunks])
        keep = t >= t[-1] - self.latest_s
        return t[keep], x[keep]

    @property
    def last_stamp_s(self) -> float | None:
        """Monotonic stamp of the newest sample read, or None before the first."""
        with self._lock:
            return float(self._chunks[-1][0][-1]) if self._chunks else None

    def between(self, start_s: float, end_s: float) -> tuple[np.ndarray, np.ndarray]:
        """The samples stamped from `start_s` to `end_s` (monotonic), copied: one
        contraction of a guided MVC. Only the chunks that reach the span are joined, so
        the cost is that of the span, not of everything captured since `start()`."""
        with self._lock:
            chunks = []
            for stamps, samples in reversed(self._chunks):
                if stamps[-1] < start_s:
                    break
                chunks.append((stamps, samples))
        if not chunks:
            return np.empty(0), np.empty((0, 0))
        t = np.concatenate([c[0] for c in reversed(chunks)])
        x = np.concatenate([c[1] for c in reversed(chunks)])
        keep = (t >= start_s) & (t <= end_s)
        return t[keep], x[keep]

    def forget_before(self, t_s: float) -> int:
        """Drop the chunks wholly before monotonic time `t_s`: a source that streams across
        a whole clinic session (16 channels at 2 kHz: about 0.9 GB an hour) keeps only
        what the next trial may still need. Returns the samples dropped."""
        with self._lock:
            keep = 0
            while keep < len(self._chunks) and self._chunks[keep][0][-1] < t_s:
                keep += 1
            dropped = sum(c[0].size for c in self._chunks[:keep])
            del self._chunks[:keep]
            self._forgotten += dropped
        return dropped

    def stop(self, timeout_s: float = 2.0) -> Captured:
        """Stop reading, close the source, and return the whole recording. A source with a
        better origin at the end (the Trigno client's `origin_s`) restamps it evenly."""
        self._running.clear()
        if self._thread is not None:
            self._thread.join(timeout_s)
        try:
            self.source.close()
        except DeviceError as exc:
            self.error = self.error or str(exc)
        return self.snapshot()

    def snapshot(self) -> Captured:
        """Everything captured so far, without stopping (a trial that ends while the source
        goes on streaming for the next one)."""
        with self._lock:
            chunks, forgotten = list(self._chunks), self._forgotten
        rate = float(self.source.rate_hz)
        labels = tuple(getattr(self.source, "labels", ()) or ())
        if labels and self.channels is not None:
            labels = tuple(labels[k] for k in self.channels) if max(
                self.channels, default=-1) < len(labels) else ()
        notes = tuple(getattr(self.source, "notes", ()) or ())
        offsets = tuple(getattr(self.source, "clock_offsets", ()) or ())
        if not chunks:
            width = 0 if self.channels is None else len(self.channels)
            return Captured(np.empty(0), np.empty((0, width)), rate, 0, self.error, labels,
                            notes, offsets)
        t = np.concatenate([c[0] for c in chunks])
        x = np.concatenate([c[1] for c in chunks])
        origin = getattr(self.source, "origin_s", None)
        if origin is not None:
            t = origin + (forgotten + np.arange(t.size)) / rate
        else:
            t, moved = increasing(t, rate)
            if moved:
                notes = (*notes, moved)
        span = (t[-1] - t[0]) * rate + 1 if t.size > 1 else t.size
        missing = max(0, round(span) - t.size)
        return Captured(t, x, rate, missing, self.error,
                        labels if len(labels) == x.shape[1] else (), notes, offsets)


STAMP_STEP_SHARE = 0.01
"""The least step between two stamps made to follow each other, a share of the sample
period: far below the jitter it repairs, so the samples keep the times they were given."""


def increasing(stamps_s: np.ndarray, rate_hz: float) -> tuple[np.ndarray, str]:
    """The stamps made strictly increasing, and what was done in words ('' when nothing
    was). An LSL sender that stamps each chunk as it pushes it gives the chunk's first
    sample a stamp back-dated by the rate, which a late push puts before the last chunk's
    last (seen under load: 2 ms back); the trial file's EMG times only ever increase,
    and its reader refused the whole EMG as damaged. A stamp not after the one before
    is moved to just after it, the samples kept in the order they came. Done here, not by
    liblsl's proc_monotonize, which leaves the stamp equal and tells nobody
    (device.lsl.inlet)."""
    floor = STAMP_STEP_SHARE / rate_hz
    step = floor * np.arange(stamps_s.size)
    fixed = np.maximum.accumulate(stamps_s - step) + step  # max(t_k, fixed_{k-1} + floor)
    moved = fixed != stamps_s
    if not moved.any():
        return stamps_s, ""
    back = float(np.max(fixed - stamps_s))
    return fixed, (f"{int(moved.sum())} samples' stamps were not after the sample before "
                   f"(by up to {1e3 * back:.1f} ms, the sender's jitter) and were moved to "
                   "just after it, in the order they came")
