"""The loop's state machine refuses commands out of order, with a reason."""

import pytest

from device.loop.states import ALLOWED, Command, State, refusal


@pytest.mark.parametrize(
    ("state", "command", "needle"),
    [
        (State.IDLE, Command.CONNECT, "build the trial first"),
        (State.IDLE, Command.START, "build and connect first"),
        (State.BUILT, Command.START, "connect to the robot first"),
        (State.CONNECTED, Command.STOP, "no trial is running"),
        (State.RUNNING, Command.BUILD, "stop the trial before changing"),
        (State.RUNNING, Command.DISCONNECT, "stop the trial before disconnecting"),
        (State.FAULTED, Command.START, "clear the fault"),
        (State.STOPPING, Command.START, "still being closed"),
    ],
)
def test_out_of_order_commands_are_refused_with_a_reason(state, command, needle):
    message = refusal(state, command)
    assert message.startswith(f"{command.value} refused:")
    assert needle in message


def test_estop_and_shutdown_are_accepted_everywhere():
    for state in State:
        assert refusal(state, Command.ESTOP) == ""
        assert refusal(state, Command.SHUTDOWN) == ""


def test_the_happy_path_is_allowed():
    path = [
        (State.IDLE, Command.BUILD), (State.BUILT, Command.CONNECT),
        (State.CONNECTED, Command.START), (State.RUNNING, Command.STOP),
        (State.CONNECTED, Command.DISCONNECT), (State.FAULTED, Command.CLEAR_FAULT),
    ]
    for state, command in path:
        assert refusal(state, command) == ""


def test_every_refusal_has_a_message():
    for state in State:
        for command in Command:
            if command not in ALLOWED[state]:
                assert len(refusal(state, command)) > 20
