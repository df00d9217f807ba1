"""What a therapist does in the window, for the tests that drive a whole session: press a
robot button, register a patient, set up a short trial, build, connect and start it."""

from __future__ import annotations

from PySide6.QtCore import Qt

from tests.fake_trigno import fake_trigno  # noqa: F401  (the UI tests take it from here)
from ui.main_window import MainWindow


def enabled(win: MainWindow) -> set[str]:
    return {name for name, b in win.robot.buttons.items() if b.isEnabled()}


def click(qtbot, button) -> None:
    assert button.isEnabled(), button.text()
    qtbot.mouseClick(button, Qt.MouseButton.LeftButton)


def register_patient(qtbot, win: MainWindow) -> None:
    tab = win.registration_tab
    win.tabs.setCurrentWidget(tab)
    qtbot.keyClicks(tab.first_name, "Ada")
    qtbot.keyClicks(tab.last_name, "Lovelace")
    tab.body_mass.setValue(70.0)
    tab.upper_arm.setValue(30.0)
    tab.forearm.setValue(28.0)
    tab.shoulder_x.setValue(-12.0)
    tab.shoulder_y.setValue(73.0)
    click(qtbot, tab.create_button)
    qtbot.waitUntil(lambda: tab.selected_patient() is not None, timeout=5000)
    click(qtbot, tab.confirm)
    qtbot.waitUntil(lambda: win.registration is not None, timeout=5000)


def short_trial(win: MainWindow, duration_s: float = 2.0) -> None:
    """One lap of `duration_s` (with at least 1 s of approach before it and 0.5 s of hold
    after). 1.5 s where the test waits for the trial's end and its length is not what is
    tested (the shortest whose 10 cm D or circle stays within the path's speed limit,
    core.trial_check.MAX_PATH_SPEED_M_S); 2 s where the test acts while the trial runs."""
    p = win.parameters_tab
    p.repetitions.setValue(1)
    p.duration.setValue(duration_s)
    p.refresh()


def build_and_connect(qtbot, win: MainWindow) -> None:
    """Build and Connect as the therapist presses them, each once its state allows (built:
    the loop's state and the window's answer to Build, which come in either order);
    returns connected, the trial not started."""
    from device.loop.states import State

    click(qtbot, win.robot.buttons["build"])
    qtbot.waitUntil(lambda: win.state == State.BUILT and win.built is not None,
                    timeout=60000)
    click(qtbot, win.robot.buttons["connect"])
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=60000)


def build_connect_start(qtbot, win: MainWindow) -> None:
    """Build, Connect and Start as the therapist presses them, each once its state
    allows; returns with the trial running."""
    from device.loop.states import State

    build_and_connect(qtbot, win)
    click(qtbot, win.robot.buttons["start"])
    qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=10000)


def ended_window(qtbot, tmp_path, monkeypatch):
    """A fixture's window (`yield from`): open_window's, then a trial a failed test left
    running ended as Stop ends it, and the window closed."""
    from device.loop.states import State

    win = open_window(qtbot, tmp_path, monkeypatch)
    yield win
    if win.state == State.RUNNING:
        win.bridge.stop()
        qtbot.waitUntil(lambda: win.state not in (State.RUNNING, State.STOPPING),
                        timeout=60000)
    win.closing_by_signal = True
    win.close()


def open_window(qtbot, tmp_path, monkeypatch, *, start_device: bool = True,
                registry=None) -> MainWindow:
    """The console's window on a fresh registry (or `registry`) and settings under
    `tmp_path`, shown, its loop started unless asked not to (a test of tabs alone needs
    none)."""
    from app.records.datadir import DataDir
    from app.records.registry import Registry

    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    registry = registry or Registry(DataDir(tmp_path / "data", "test"))
    win = MainWindow(registry, settings_path=tmp_path / "config" / "settings.json")
    qtbot.addWidget(win)
    win.show()
    if start_device:
        win.start_device()
    return win


def window_with_trials(qtbot, tmp_path, monkeypatch, wait_ms: int, n: int = 2):
    """A window with no loop whose patient has `n` registered trials, listed on the Replay
    tab: (the window, the trials begun)."""
    from core.trial import THESIS_SUBJECT
    from tests.app.assessments.registered import register

    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    register_patient(qtbot, win)
    code = win.patient.code
    begun = [register(win.registry, code, {}, task="", parameters=THESIS_SUBJECT)
             for _ in range(n)]
    win.read_proposal_and_trials(code)
    qtbot.waitUntil(lambda: win.reading_after == 0, timeout=wait_ms)
    assert win.replay.trials.count() == n
    return win, begun


def window_with_plan(qtbot, tmp_path, monkeypatch, plan, wait_ms: int) -> MainWindow:
    """A window with no loop whose patient has `plan`, shown on the Plan tab."""
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    register_patient(qtbot, win)
    win.registry.save_plan(win.patient.code, plan)
    win.show_plan_of(win.patient.code)
    qtbot.waitUntil(lambda: not win.plan_waiting(), timeout=wait_ms)
    return win
