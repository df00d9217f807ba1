"""The loop's state machine: which command each state accepts, and why it refuses the rest.

    idle ──build──▶ built ──connect──▶ connected ──start──▶ running ──stop──▶ stopping ──▶ connected
                      ▲                    │                                          (file closed)
                      └────disconnect──────┘
    any state with the motors powered ──fault──▶ faulted ──clear fault──▶ connected (or built)

Build may be repeated from built or connected to change the trial's parameters between trials.
E-stop is accepted in every state (in a state without motors it is a no-op that is still
latched, so a trial cannot start until the therapist clears it).
"""

from __future__ import annotations

import enum


class State(enum.IntEnum):
    """Loop states; the numeric value is what the record's `state` channel stores."""

    IDLE = 0
    BUILT = 1
    CONNECTED = 2
    RUNNING = 3
    STOPPING = 4
    FAULTED = 5

    @property
    def label(self) -> str:
        return _LABELS[self]

    @property
    def ticking(self) -> bool:
        """A backend is connected: the loop ticks every period."""
        return self in TICKING


_LABELS = {
    State.IDLE: "Idle",
    State.BUILT: "Built",
    State.CONNECTED: "Connected",
    State.RUNNING: "Running",
    State.STOPPING: "Stopping",
    State.FAULTED: "Fault",
}


class Command(enum.Enum):
    BUILD = "build"
    CONNECT = "connect"
    DISCONNECT = "disconnect"
    START = "start"
    STOP = "stop"
    ESTOP = "e-stop"
    CLEAR_FAULT = "clear fault"
    SET_ASSISTANCE = "set assistance level"
    SHUTDOWN = "shutdown"


TICKING = frozenset({State.CONNECTED, State.RUNNING, State.STOPPING, State.FAULTED})
"""The states with a backend connected: the loop ticks every period in these."""

_EVERY_STATE = tuple(State)

TRANSITIONS: dict[tuple[State, Command], State] = {
    (State.IDLE, Command.BUILD): State.BUILT,
    (State.BUILT, Command.BUILD): State.BUILT,
    (State.CONNECTED, Command.BUILD): State.CONNECTED,
    (State.BUILT, Command.CONNECT): State.CONNECTED,
    (State.CONNECTED, Command.DISCONNECT): State.BUILT,
    (State.FAULTED, Command.DISCONNECT): State.BUILT,
    (State.CONNECTED, Command.START): State.RUNNING,
    (State.RUNNING, Command.STOP): State.STOPPING,
    (State.FAULTED, Command.CLEAR_FAULT): State.CONNECTED,
    # a live change of the running trial's level; between trials the level is the
    # built trial's own (issue 27: a change kept for later trials ran them unseen)
    (State.RUNNING, Command.SET_ASSISTANCE): State.RUNNING,
    # a level, read every tick (device.loop.client), not a command that moves the state
    **{(state, Command.ESTOP): state for state in _EVERY_STATE},
    **{(state, Command.SHUTDOWN): State.IDLE for state in _EVERY_STATE},
}
"""Where each command allowed in a state leads when it succeeds (a command that fails
leaves the state as it was). Faults are not commands: any ticking state goes to FAULTED
when the supervisor latches one; the loop's own events (a trial complete, its file
closed) are in device.loop.process."""

ALLOWED: dict[State, frozenset[Command]] = {
    state: frozenset(command for (where, command) in TRANSITIONS if where == state)
    for state in State
}
"""The commands each state accepts (TRANSITIONS' keys)."""

_WHY = {
    (State.IDLE, Command.CONNECT): "build the trial first (press Build)",
    (State.IDLE, Command.START): "build and connect first",
    (State.BUILT, Command.START): "connect to the robot first (press Connect)",
    (State.BUILT, Command.STOP): "no trial is running",
    (State.BUILT, Command.DISCONNECT): "the robot is not connected",
    (State.CONNECTED, Command.CONNECT): "already connected",
    (State.CONNECTED, Command.STOP): "no trial is running",
    (State.RUNNING, Command.BUILD): "stop the trial before changing its parameters",
    (State.RUNNING, Command.START): "a trial is already running",
    (State.RUNNING, Command.CONNECT): "already connected and running",
    (State.RUNNING, Command.DISCONNECT): "stop the trial before disconnecting",
    (State.STOPPING, Command.START): "the last trial is still being closed; wait a moment",
    (State.FAULTED, Command.START): "a fault is latched; check the patient, then clear the fault",
    (State.FAULTED, Command.BUILD): "a fault is latched; clear it first",
    (State.FAULTED, Command.CONNECT): "a fault is latched; clear it first",
    **{(state, Command.SET_ASSISTANCE): "no trial is running: the next trial runs the "
       "level it is built with (set it in the form and press Build)"
       for state in (State.IDLE, State.BUILT, State.CONNECTED, State.STOPPING, State.FAULTED)},
}


def refusal(state: State, command: Command) -> str:
    """Why `command` is refused in `state`, or '' when it is allowed."""
    if command in ALLOWED[state]:
        return ""
    reason = _WHY.get((state, command), f"not possible while {state.label.lower()}")
    return f"{command.value} refused: {reason}."
