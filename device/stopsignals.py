"""The signals that ask a console's process to stop (SIGINT: Ctrl+C; SIGTERM: the system
or a service manager; SIGHUP: its terminal or session closed), caught instead of ending
the process where it stands (issue 28, item 5).

A terminal's Ctrl+C or a `kill` of the process group reaches the console, the loop and
the recorder at once. Killed where they stood, the loop left the robot without a last
zero torque or a fault event, the recorder left the trial file `recording`, both with
tracebacks. Caught, each finishes its part: the loop stops the trial as at a fault that
names the signal (zero torque in that tick), the recorder writes the trial's last
samples and closes the file, the console records the trial with its cause.
"""

from __future__ import annotations

import signal

STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP")
                     if hasattr(signal, name))
SIGNAL_WORDS = {
    "SIGINT": "Ctrl+C",
    "SIGTERM": "the system or a service manager asked it to end",
    "SIGHUP": "its terminal or session closed",
}


class StopSignal:
    """Remembers the first stop signal this process was given (`name`, '' until then)."""

    def __init__(self) -> None:
        self.name = ""

    def install(self) -> StopSignal:
        """Catch the stop signals from now on (main thread only)."""
        for number in STOP_SIGNALS:
            signal.signal(number, self._caught)
        return self

    def _caught(self, number: int, _frame) -> None:
        if not self.name:
            self.name = signal.Signals(number).name

    def set(self, name: str) -> None:
        """As if `name` had been caught (the console passes on the one it was given)."""
        if not self.name:
            self.name = name

    @property
    def words(self) -> str:
        """'SIGTERM: the system or a service manager asked it to end'."""
        return f"{self.name}: {SIGNAL_WORDS.get(self.name, 'a stop signal')}"


def signal_name(number: int) -> str:
    """'SIGTERM' for 15; the number itself when it is not a signal here."""
    try:
        return signal.Signals(number).name
    except ValueError:
        return str(number)
