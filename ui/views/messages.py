"""What the window tells the therapist, as one model: the robot's current state, the last
event, and a history they can open.

Before it, each part of the window wrote its own line and nothing took a line back: "Trial
built. Connect…" stayed up after Connect, "Fault cleared." sat under a new emergency stop.
Here every event names the states it belongs to, and stops being the last event the moment
the robot leaves them (it stays in the history, with its time). A fault is not an event
line: it is the banner's, and a new fault replaces any event line under it.
"""

from __future__ import annotations

import datetime
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from device.loop.states import State

HISTORY_LENGTH = 500
"""Events the history keeps (a long clinic day's worth); the log file keeps them all."""


@dataclass(frozen=True, slots=True)
class Event:
    """One thing that happened, worded for the therapist."""

    text: str
    problem: bool
    at: datetime.datetime
    states: frozenset[State] | None
    """The robot states the line is current in; None: until the next event."""

    def line(self) -> str:
        return f"{self.at:%H:%M:%S}  {'⚠ ' if self.problem else ''}{self.text}"


class Messages:
    """The current state line, the last event still current, and the history."""

    def __init__(self, clock: Callable[[], datetime.datetime] | None = None) -> None:
        self._clock = clock or datetime.datetime.now
        self._history: deque[Event] = deque(maxlen=HISTORY_LENGTH)
        self._last: Event | None = None
        self.state = State.IDLE
        self.fault = ""

    # -- what happened -----------------------------------------------------------
    def say(self, text: str, *, problem: bool = False,
            states: Iterable[State] | None = None) -> Event:
        """A new event; `states` are those it stays current in (None: until replaced)."""
        event = Event(text, problem, self._clock(), None if states is None else frozenset(states))
        self._history.append(event)
        # current even if the robot is not yet in one of its states: a reply often comes
        # just before the state change it announces ("Trial built" before BUILT)
        self._last = event
        return event

    def withdraw(self, event: Event | None) -> bool:
        """`event` is no longer true (what it said was done or changed): it leaves the line,
        not the history, if it is still the line's; True when it was."""
        if event is None or self._last is not event:
            return False
        self._last = None
        return True

    def set_state(self, state: State) -> None:
        """The robot's state changed: an event that does not belong to the new one is
        over."""
        self.state = state
        if self._last is not None and not self._current(self._last):
            self._last = None

    def set_fault(self, text: str) -> None:
        """A fault latched (its banner): the event line under it is no longer current."""
        # the window shows an e-stop at the press and again when the loop reports it:
        # one fault, one line in the history
        if text and text != self.fault:
            self._history.append(Event(text, True, self._clock(), None))
        self.fault = text
        self._last = None

    def clear_fault(self) -> None:
        self.fault = ""

    # -- what the window shows ---------------------------------------------------
    @property
    def last(self) -> Event | None:
        """The event line to show, or None."""
        return self._last

    def history(self) -> list[str]:
        """Every event kept, oldest first, one line each with its time."""
        return [event.line() for event in self._history]

    def _current(self, event: Event) -> bool:
        return event.states is None or self.state in event.states
