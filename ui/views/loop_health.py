"""The control loop's timing as the status bar shows it to the therapist: "Timing OK", or
a warning with what to do; the figures (how late the ticks woke, the share of late ticks)
are for the researcher, in its tooltip.

A tick is late when it wakes more than one period (2 ms) after its deadline; the
lateness of every tick arrives with the records (`lateness`, in s). The line warns when
the last batches had more than 1 % of their ticks late or one tick later than half the
real robot's watchdog (device.safety.limits: 10 ms), and keeps the warning for ten
seconds after the last such batch, so that it does not flicker. On the simulator, which
is stepped tick by tick, lateness stops nothing; on the real robot its watchdog would
stop the trial, so the words say so (README, "For the therapist", 5).
"""

from __future__ import annotations

import numpy as np

from device.loop.pipeline import PERIOD_S
from device.safety.limits import SafetyLimits

LATE_SHARE_WARN = 0.01
"""Late ticks in the last batches above which the line warns."""
LATEST_WARN_S = SafetyLimits().late_tick_s / 2
"""One tick later than this (half the real robot's watchdog) warns."""
HOLD_UPDATES = 20
"""Updates (0.5 s each) a warning stays after the last late batch: ten seconds."""

OK = "Timing OK"
WARN_SIMULATOR = "⚠ Timing late: close other programs before using the robot"
WARN_ROBOT = "⚠ Timing late, the robot may stop: close other programs, plug the laptop in"


class LoopHealth:
    """Ticks' lateness gathered between two status updates, the running late share, and
    how long a warning still holds."""

    def __init__(self) -> None:
        self._waiting: list[np.ndarray] = []
        self.late_total = 0
        self.ticks_total = 0
        self.p99_ms = float("nan")
        self._warn_for = 0

    def add(self, lateness_s: np.ndarray) -> None:
        """The lateness of a batch of ticks (s), kept until the next `text`."""
        self._waiting.append(lateness_s)

    def text(self, robot: bool = False) -> str | None:
        """The status line for the ticks added since the last call, or None if none were
        (the line then stays as it is); `robot`: the real robot is connected."""
        if not self._waiting:
            return None
        lateness = np.concatenate(self._waiting).astype(float)
        self._waiting = []
        late = int(np.count_nonzero(lateness > PERIOD_S))
        self.late_total += late
        self.ticks_total += lateness.size
        self.p99_ms = 1e3 * float(np.percentile(lateness, 99))
        if late > LATE_SHARE_WARN * lateness.size or float(np.max(lateness)) > LATEST_WARN_S:
            self._warn_for = HOLD_UPDATES
        elif self._warn_for:
            self._warn_for -= 1
        if not self._warn_for:
            return OK
        return WARN_ROBOT if robot else WARN_SIMULATOR

    def figures(self) -> str:
        """What the line means and the figures behind it (its tooltip)."""
        share = 100.0 * self.late_total / max(1, self.ticks_total)
        return ("This computer runs the robot's 2 ms loop. When it runs it late, the "
                "simulator runs on, but the real robot's watchdog stops a trial: close other "
                "programs (video calls, updates, a second console), plug a laptop in and set "
                "its power mode to performance. "
                f"Lateness, 99th percentile of the last half second: {self.p99_ms:.2f} ms; "
                f"ticks more than {1e3 * PERIOD_S:g} ms late since the start: {share:.2f} %.")
