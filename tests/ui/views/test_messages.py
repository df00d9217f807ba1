"""The window's one message model: an event stays the current line only in the states it
belongs to; a fault replaces the line under it; the history keeps everything with its time."""

import datetime

from device.loop.states import State
from ui.views.messages import HISTORY_LENGTH, Messages


def clock():
    t = datetime.datetime(2026, 12, 1, 9, 0, 0)
    while True:
        yield t
        t += datetime.timedelta(seconds=1)


def messages() -> Messages:
    ticks = clock()
    return Messages(lambda: next(ticks))


def test_built_then_connected_drops_the_stale_connect_advice():
    m = messages()
    m.set_state(State.BUILT)
    m.say("Trial built. Connect to the robot, then Start.", states=(State.BUILT,))
    assert m.last.text.startswith("Trial built")
    m.set_state(State.CONNECTED)
    assert m.last is None  # no "Connect…" after connecting
    assert "Trial built" in m.history()[-1]


def test_a_new_emergency_stop_takes_the_fault_cleared_line_away():
    m = messages()
    m.set_state(State.CONNECTED)
    m.say("Fault cleared.", states=(State.CONNECTED,))
    m.set_fault("Emergency stop pressed — the motors are off.")
    m.set_fault("Emergency stop pressed — the motors are off.")  # the loop reports it too
    assert m.last is None
    assert sum("Emergency stop" in line for line in m.history()) == 1
    assert m.fault.startswith("Emergency stop")
    assert m.history()[-1].endswith("⚠ Emergency stop pressed — the motors are off.")


def test_an_event_without_states_stays_until_the_next_and_problems_are_marked():
    m = messages()
    m.say("Saved.")
    m.set_state(State.RUNNING)
    assert m.last.text == "Saved."
    m.say("Start refused: no patient", problem=True)
    assert m.last.problem
    assert m.history() == ["09:00:00  Saved.", "09:00:01  ⚠ Start refused: no patient"]


def test_the_history_is_bounded():
    m = messages()
    for k in range(HISTORY_LENGTH + 20):
        m.say(f"event {k}")
    lines = m.history()
    assert len(lines) == HISTORY_LENGTH
    assert lines[-1].endswith(f"event {HISTORY_LENGTH + 19}")


def test_a_reply_just_before_its_state_change_is_shown_until_the_robot_moves_on():
    m = messages()
    m.say("Trial built. Connect to the robot, then Start.", states=(State.BUILT,))
    assert m.last is not None  # said in IDLE, a moment before BUILT
    m.set_state(State.BUILT)
    assert m.last is not None
    m.set_state(State.CONNECTED)
    assert m.last is None
