"""The control loop's health as the status bar shows it: how late its ticks wake (the 99th
percentile of the last half second) and the share of late ticks since the console started.

A tick is late when it wakes more than one period (2 ms) after its deadline; the
lateness of every tick arrives with the records (`lateness`, in s).
"""

from __future__ import annotations

import numpy as np

from device.loop.pipeline import PERIOD_S
from device.safety.faults import Fault


class LoopHealth:
    """Ticks' lateness gathered between two status updates, and the running late share."""

    def __init__(self) -> None:
        self._waiting: list[np.ndarray] = []
        self.late_total = 0
        self.ticks_total = 0

    def add(self, lateness_s: np.ndarray) -> None:
        """The lateness of a batch of ticks (s), kept until the next `text`."""
        self._waiting.append(lateness_s)

    def text(self, fault_code: int = 0) -> str | None:
        """The status line for the ticks added since the last call, or None if none were
        (the line then stays as it is)."""
        if not self._waiting:
            return None
        lateness = np.concatenate(self._waiting).astype(float)
        self._waiting = []
        late = int(np.count_nonzero(lateness > PERIOD_S))
        self.late_total += late
        self.ticks_total += lateness.size
        p99 = 1e3 * float(np.percentile(lateness, 99))
        share = 100.0 * self.late_total / max(1, self.ticks_total)
        return (f"loop: lateness p99 {p99:.2f} ms · late {share:.2f} %"
                + (f" · fault {Fault(fault_code).label}" if fault_code else ""))
