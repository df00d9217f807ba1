"""Between trials a handle outside the exercise area is a state the window shows, not a
fault (docs/safety.md, H8): the real robot connects at its homing pose, outside most
exercises' areas, and every Connect latched WORKSPACE. The loop says where the handle is
(HandleArea); the window greys Start with that line on every tab, refuses a Start pressed
anyway in one line, and lets it go once the handle is inside."""

from __future__ import annotations

import pytest

from device.loop.states import State
from tests.ui.session import (
    build_and_connect,
    click,
    open_window,
    register_patient,
    short_trial,
)

OUTSIDE = ("handle outside the exercise area: guide it inside (now at 8.1, 48 cm; the area is "
           "x -40 to -10 cm, y 10 to 50 cm)")


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    win.closing_by_signal = True  # closed with its trial running: no question asked
    yield win
    win.close()


@pytest.mark.slow
def test_the_window_holds_start_while_the_loop_says_the_handle_is_outside(qtbot, window):
    win = window
    register_patient(qtbot, win)
    short_trial(win)
    build_and_connect(qtbot, win)
    qtbot.waitUntil(lambda: win.robot.buttons["start"].isEnabled(), timeout=10000)
    win.bridge.handle_area.emit(OUTSIDE)  # as the loop's HandleArea arrives
    assert not win.robot.buttons["start"].isEnabled()
    assert win.robot.why.toolTip() == "H" + OUTSIDE[1:]
    assert win.robot.buttons["start"].toolTip() == "H" + OUTSIDE[1:]
    win.start_trial()  # F5 pressed anyway
    assert win.message.text().endswith(f"Start refused: {OUTSIDE}.")
    assert win.state == State.CONNECTED
    assert win.trial_id is None
    win.bridge.handle_area.emit("")  # guided inside
    assert win.robot.buttons["start"].isEnabled()
    assert win.robot.why.toolTip() == ""
    click(qtbot, win.robot.buttons["start"])
    qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=10000)
    # a state between trials only: while a trial runs the loop's fault speaks
    win.bridge.handle_area.emit(OUTSIDE)
    assert win.handle_outside == ""
