"""Python's cyclic garbage collector, run on the window's thread only, between events.

CPython runs a cyclic collection in whichever thread crosses the allocation threshold, at
whatever point that thread has reached. The console's other threads allocate a lot (the
job thread reads and analyses trial files, the live batches arrive on theirs), and the
widgets the window drops (a closed dialog, a replaced report page, a test's window) are
often kept in reference cycles by the slots that capture them. Collected from a job
thread, a QObject is destroyed off the thread it lives in; collected inside Qt's event
dispatch (a paint, a slot of the widget itself), it is freed while Qt still uses it. Both
crash the process (seen once: a worker segfaulting in `processEvents` after a tab's
test). Automatic collection is therefore switched off and the same generational schedule
is run from a timer on the window's thread, where no widget is in the middle of an event
(the pattern of pyqtgraph's `GarbageCollector` and calibre's).
"""

from __future__ import annotations

import gc

from PySide6.QtCore import QObject, QTimer

INTERVAL_MS = 1000
"""How often the counts are looked at: a second's cyclic garbage is small beside what the
console holds, and a pass every second keeps each one short."""


class WindowThreadCollector(QObject):
    """While it runs, no thread collects by itself: the window's thread does, on a timer,
    each generation when its count passed the threshold automatic collection would use."""

    def __init__(self, parent: QObject | None = None, interval_ms: int = INTERVAL_MS) -> None:
        super().__init__(parent)
        self.thresholds = gc.get_threshold()
        self.timer = QTimer(self)
        self.timer.setInterval(interval_ms)
        self.timer.timeout.connect(self.collect)

    def start(self) -> None:
        gc.disable()
        self.timer.start()

    def stop(self) -> None:
        """Automatic collection again (the window closed, or a test ended)."""
        self.timer.stop()
        gc.enable()

    def collect(self) -> int:
        """The generations due, youngest first, as the interpreter would: an older
        generation only when the younger one's pass pushed its count over its
        threshold (the interpreter's schedule, less its heuristic of putting off a
        full pass while few objects have survived: the start-up objects are frozen out
        of its reach, ui.gui). Returns the objects found unreachable."""
        found = 0
        for generation, threshold in enumerate(self.thresholds):
            if threshold <= 0 or gc.get_count()[generation] <= threshold:
                break
            found += gc.collect(generation)
        return found
