"""The window's job thread: disk work (finishing a trial, writing its report, finishing
the trials a crash left recording) one job after another off the GUI thread, each
result handed to its callback in the GUI thread.

Unlike `ui.plots.Background`, which keeps only the newest waiting request, every job
given here runs: none may be dropped (a trial must be finished, a report saved).
"""

from __future__ import annotations

import concurrent.futures
import logging
from collections.abc import Callable

from PySide6.QtCore import QObject, Signal

log = logging.getLogger(__name__)


class Jobs(QObject):
    """Signals: failed(error) when a job raised; its callback is then not called."""

    failed = Signal(object)
    # Emitted in the worker; queued to the GUI thread, where this object lives.
    _finished = Signal(object, object, object, object)  # callback, result, error, settled

    def __init__(self, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._closed = False
        self._executor = concurrent.futures.ThreadPoolExecutor(
            max_workers=1, thread_name_prefix="console-job")
        self._finished.connect(self._deliver)

    def run(self, work: Callable[[], object], callback: Callable[[object], None], *,
            settled: Callable[[], None] | None = None) -> None:
        """Run `work` on the job thread; `callback(result)` runs in the GUI thread, and
        `settled()`, when given, before it or before the failure is said: whatever waits
        for the job (the next Start for a trial's finish) waits for both outcomes. After
        `shutdown` (the window closed) nothing more runs: a trial finished as the window
        closed hands its result over after the thread stopped, and its callback's next
        job (reading the file for the live tabs) raised "cannot schedule new futures
        after shutdown" on the console."""
        if self._closed:
            log.warning("not run, the console is closing: %s", getattr(work, "__qualname__", work))
            return
        future = self._executor.submit(work)

        def done(f: concurrent.futures.Future) -> None:
            error = f.exception()
            self._finished.emit(callback, None if error else f.result(), error, settled)

        future.add_done_callback(done)

    @property
    def closed(self) -> bool:
        """`shutdown` was called (the window closed): an answer that comes now is stale."""
        return self._closed

    def shutdown(self, *, wait: bool = True) -> None:
        """No job is taken from now on; the jobs given so far still run, one after
        another. `wait`: return once they have (False: return at once, the thread ending
        after its last job; Python waits for it before the process ends). Called again
        with `wait`, it waits for them."""
        self._closed = True
        self._executor.shutdown(wait=wait)

    def _deliver(self, callback, result, error, settled) -> None:
        if settled is not None:
            settled()
        if error is not None:
            self.failed.emit(error)
            return
        callback(result)
