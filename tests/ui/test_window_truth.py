"""The window never lies about what the robot runs (issue 27): Start runs only what the
form shows (#1), the banner is the latch in every state (#3), a typed level reaches the
robot only when committed (#4), the level says what it means in each mode (#6). The real
loop and recorder processes run behind the window where the loop is part of the claim."""

from __future__ import annotations

from pathlib import Path

import pytest
from PySide6.QtCore import Qt

from app.trials.reader import read_trial
from device.loop.states import State
from device.safety.faults import Fault
from tests.ui.session import (
    click,
    enabled,
    ended_window,
    open_window,
    register_patient,
    short_trial,
)


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):
    yield from ended_window(qtbot, tmp_path, monkeypatch)


def _connected(qtbot, win) -> None:
    click(qtbot, win.robot.buttons["build"])
    qtbot.waitUntil(lambda: win.state == State.BUILT and win.built is not None,
                    timeout=60000)
    click(qtbot, win.robot.buttons["connect"])
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=60000)


def _type(qtbot, field, text: str, *, commit: bool = True) -> None:
    field.setFocus()
    field.selectAll()
    qtbot.keyClicks(field, text)
    if commit:
        qtbot.keyClick(field, Qt.Key.Key_Return)


def _flag(win) -> bool:
    """The loop's e-stop line as the loop reads it (the shared flag)."""
    return bool(win.bridge.client.estop_flag.value)


@pytest.mark.slow
def test_start_runs_only_what_the_form_shows(qtbot, window):
    """Issue 27 #1: after Build, a figure eight the patient cannot reach (Build greyed)
    left Start green, and it ran the circle built before; taking the proposal did the
    same with the old level. Now any change after Build greys Start, on every tab, with
    the reason; Build again makes it green."""
    win, p = window, window.parameters_tab
    register_patient(qtbot, win)
    short_trial(win)
    p.shape.setCurrentIndex(p.shape.findData("circle"))
    p.refresh()
    _connected(qtbot, win)
    start = win.robot.buttons["start"]
    assert start.isEnabled()

    def stale_everywhere() -> None:
        assert not start.isEnabled()
        assert "parameters changed since Build: press Build" in start.toolTip()
        for index in range(win.tabs.count()):  # the robot bar is on every tab
            win.tabs.setCurrentIndex(index)
            assert win.robot.why.isVisible()
            assert win.robot.why.whole.endswith(
                "Start is greyed: parameters changed since Build: press Build")

    # a shape the arm cannot reach: Build greys, Start greys (it ran the circle before)
    p.shape.setCurrentIndex(p.shape.findData("figure8"))
    p.refresh()
    assert p.problem()
    assert not win.robot.buttons["build"].isEnabled()
    assert not start.isEnabled()
    assert "Build needs the form fixed" in win.robot.buttons["build"].toolTip()
    # back to what was built: the same trial again, Start green without a Build
    p.shape.setCurrentIndex(p.shape.findData("circle"))
    p.refresh()
    assert start.isEnabled()
    assert win.robot.why.whole == ""

    # any field, committed: stale at once, before the check's debounce
    _type(qtbot, p.radius, "9")
    stale_everywhere()
    _type(qtbot, p.radius, "10")
    assert start.isEnabled()
    # the robot choice and the patient's force are part of what runs
    p.patient_kind.setCurrentIndex(p.patient_kind.findData("weak"))
    stale_everywhere()
    p.patient_kind.setCurrentIndex(p.patient_kind.findData("healthy"))
    assert start.isEnabled()

    # taking the proposal is a change like any other
    from app.trials.progression import propose

    p.show_proposal(propose(p.parameters(), {"led_pct": 88.0}, "complete"))
    click(qtbot, p.use_proposal)
    assert p.parameters().assistance_level == pytest.approx(0.9)
    stale_everywhere()

    # F5 with a number still being typed: the number is on the screen, so it counts
    assert win.built_setup.parameters.assistance_level == pytest.approx(1.0)
    click(qtbot, win.robot.buttons["build"])
    qtbot.waitUntil(lambda: start.isEnabled(), timeout=60000)
    _type(qtbot, p.radius, "7", commit=False)
    assert start.isEnabled()  # not yet committed: nothing changed
    win.start_trial()  # F5 / the click: commits the field first, then refuses
    assert "Start refused: parameters changed since Build" in win.message.text()
    assert win.state == State.CONNECTED
    assert win.trial_id is None
    assert p.radius.value() == pytest.approx(7.0)


@pytest.mark.slow
def test_the_banner_is_the_latch_in_every_state(qtbot, window):
    """Issue 27 #3: Esc with nothing connected, then Clear fault: the clear was refused
    ("not possible while idle"), the e-stop released, and a whole trial then ran under
    "Emergency stop pressed". Now the banner, the buttons and the loop's flag agree after
    every press and clear: in Idle, Built, Connected (a fault in the loop), and after a
    Disconnect while faulted."""
    win = window
    register_patient(qtbot, win)
    short_trial(win, duration_s=1.5)

    def agree() -> None:
        latched = _flag(win) or win.state == State.FAULTED
        assert win.banner.isVisible() == latched
        if latched:
            assert not {"build", "connect", "start"} & enabled(win)
            assert "Clear fault" in win.robot.why.whole

    # Idle: held, said, Build waits; Clear releases it for good
    qtbot.keyClick(win.tabs, Qt.Key.Key_Escape)
    assert _flag(win)
    assert win.banner.isVisible()
    assert Fault.ESTOP.banner() in win.banner_text.text()
    agree()
    win.build()  # F2 while held: refused in words, nothing built
    assert "Build waits: the emergency stop is pressed" in win.message.text()
    assert win.state == State.IDLE
    click(qtbot, win.clear_button)
    assert not _flag(win)
    assert not win.banner.isVisible()
    agree()
    assert "build" in enabled(win)

    # Built: the same (nothing connected reads the flag)
    click(qtbot, win.robot.buttons["build"])
    qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=60000)
    win.emergency_stop()
    agree()
    assert "connect" not in enabled(win)
    click(qtbot, win.clear_button)
    agree()
    assert "connect" in enabled(win)

    # Connected: the loop latches a fault; the banner goes only when the loop clears it
    click(qtbot, win.robot.buttons["connect"])
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=60000)
    win.emergency_stop()
    qtbot.waitUntil(lambda: win.state == State.FAULTED, timeout=5000)
    agree()
    click(qtbot, win.clear_button)
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=5000)
    agree()
    assert not win.banner.isVisible()
    assert "start" in enabled(win)

    # faulted, then disconnected: the fault goes with the connection, the e-stop held
    # stays held until cleared
    win.emergency_stop()
    qtbot.waitUntil(lambda: win.state == State.FAULTED, timeout=5000)
    click(qtbot, win.robot.buttons["disconnect"])
    qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=5000)
    agree()
    assert win.banner.isVisible()  # still held
    click(qtbot, win.clear_button)
    agree()
    assert not win.banner.isVisible()
    # a trial then runs without a banner and without a fault
    click(qtbot, win.robot.buttons["connect"])
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=60000)
    click(qtbot, win.robot.buttons["start"])
    qtbot.waitUntil(lambda: win.unsaved_trial is not None, timeout=60000)
    trial = win.registry.trials_for_patient(win.patient.code)[0]
    assert trial.status == "complete"
    agree()


@pytest.mark.slow
def test_a_dead_loop_is_the_banner_and_nothing_can_be_cleared(qtbot, window):
    import os
    import signal

    win = window
    short_trial(win)
    _connected(qtbot, win)
    os.kill(win.bridge.client.loop_pid, signal.SIGKILL)
    qtbot.waitUntil(lambda: win.banner.isVisible(), timeout=10000)
    assert "restart the console" in win.banner_text.text().lower()
    assert not win.clear_button.isEnabled()
    win.clear_fault()  # nothing to clear: the banner stays
    assert win.banner.isVisible()
    assert not {"build", "connect", "start"} & enabled(win)
    assert "restart the console" in win.robot.why.whole


@pytest.mark.slow
def test_a_typed_level_reaches_the_robot_once_committed(qtbot, window):
    """Issue 27 #4: typing 60 during a trial set 6 % and then 60 %, and the file recorded
    both. Now keystrokes change nothing; Enter sends 60 % once; the arrows send each
    step."""
    win, p = window, window.parameters_tab
    register_patient(qtbot, win)
    p.repetitions.setValue(3)
    p.duration.setValue(2.0)
    p.refresh()
    _connected(qtbot, win)
    sent = []
    real = win.bridge.set_assistance
    win.bridge.set_assistance = lambda level: (sent.append(level), real(level))
    click(qtbot, win.robot.buttons["start"])
    qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=10000)
    _type(qtbot, p.assistance, "60", commit=False)
    assert sent == []
    qtbot.keyClick(p.assistance, Qt.Key.Key_Return)
    assert sent == [pytest.approx(0.6)]
    qtbot.keyClick(p.assistance, Qt.Key.Key_Up)  # the arrows commit each step
    assert sent == [pytest.approx(0.6), pytest.approx(0.65)]
    qtbot.waitUntil(lambda: "Assistance set to 65%" in win.message.text(), timeout=10000)
    qtbot.waitUntil(lambda: win.unsaved_trial is not None, timeout=60000)
    trial = win.registry.trials_for_patient(win.patient.code)[0]
    data = read_trial(win.registry.trial_path(trial))
    levels = [e["values"]["level"] for e in data.events if e["kind"] == "assistance"]
    assert levels == [pytest.approx(0.6), pytest.approx(0.65)]
    # the live level was that trial's (issue 27 #2): the next runs what Build takes
    assert win.state == State.CONNECTED
    assert "start" not in enabled(win)
    assert "parameters changed since Build" in win.robot.why.whole
    click(qtbot, win.robot.buttons["build"])
    qtbot.waitUntil(lambda: "start" in enabled(win), timeout=60000)
    assert win.built.assistance_level == pytest.approx(0.65)


def test_the_level_says_what_it_means_in_each_mode(qtbot, tmp_path, monkeypatch):
    """Issue 27 #6: "Assistance %" meant help along the path in one mode and the share of a
    correct push given way to in the other, and no tooltip said which."""
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    p = win.parameters_tab
    label = p.labels["assistance"]
    p.assist.setCurrentIndex(p.assist.findData("as-needed"))
    assert label.text() == "Help along the path"
    assert "falls behind" in p.assistance.toolTip()
    assert "Enter" in p.assistance.toolTip()
    p.assist.setCurrentIndex(p.assist.findData("thesis"))
    assert label.text() == "Give way to a correct push"
    assert "right direction" in p.assistance.toolTip()
    assert label.toolTip() == p.assistance.toolTip()
    win.close()


@pytest.mark.slow
def test_the_trial_built_is_the_one_the_loop_took(qtbot, window):
    """A second Build pressed before the first was answered: the first answer was taken
    as the second's, so when the loop refused the second (another robot while connected)
    the window held it as built and Start ran the first, registered as the second (the
    registry said 70 % on the hardware, the file 40 % on the simulator)."""
    win, p = window, window.parameters_tab
    register_patient(qtbot, win)
    short_trial(win)
    _connected(qtbot, win)
    answers = []
    win.bridge.replied.connect(lambda command, ok, _m: answers.append((command, ok)))
    p.assistance.setValue(40)
    win.build()  # the simulator at 40 %
    p.assistance.setValue(70)
    p.hardware.setChecked(True)
    p.settings_path.setText(str(Path(__file__).parents[2] / "resources" /
                                "hardware.example.toml"))
    p.refresh()
    win.build()  # before the first is answered: refused, the robot is connected
    qtbot.waitUntil(lambda: answers == [("build", True), ("build", False)], timeout=60000)
    assert win.built.assistance_level == pytest.approx(0.4)
    assert win.built_backend.kind == "simulator"
    assert win.stale()
    assert "start" not in enabled(win)
