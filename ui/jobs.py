"""The window's job thread: disk work (finishing a trial, writing its report, finishing
the trials a crash left recording) one job after another off the GUI thread, each
result handed to its callback in the GUI thread.

Unlike `ui.plots.Background`, which keeps only the newest waiting request, every job
given here runs: none may be dropped (a trial must be finished, a report saved).
"""

from __future__ import annotations

import concurrent.futures
from collections.abc import Callable

from PySide6.QtCore import QObject, Signal


class Jobs(QObject):
    """Signals: failed(error) when a job raised; its callback is then not called."""

    failed = Signal(object)
    # Emitted in the worker; queued to the GUI thread, where this object lives.
    _finished = Signal(object, object, object)  # callback, result, error

    def __init__(self, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._executor = concurrent.futures.ThreadPoolExecutor(
            max_workers=1, thread_name_prefix="console-job")
        self._finished.connect(self._deliver)

    def run(self, work: Callable[[], object], callback: Callable[[object], None]) -> None:
        """Run `work` on the job thread; `callback(result)` runs in the GUI thread."""
        future = self._executor.submit(work)

        def done(f: concurrent.futures.Future) -> None:
            error = f.exception()
            self._finished.emit(callback, None if error else f.result(), error)

        future.add_done_callback(done)

    def shutdown(self) -> None:
        """Wait for the jobs given so far, then stop the thread."""
        self._executor.shutdown(wait=True)

    def _deliver(self, callback, result, error) -> None:
        if error is not None:
            self.failed.emit(error)
            return
        callback(result)
