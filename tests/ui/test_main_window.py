"""A whole session driven as a therapist would: register a patient, enter parameters (one
refused as unreachable), Build, Connect, Start on the simulator, let the trial run, Save;
then the file, the report, the progress and the replay; e-stop from every tab; buttons
out of order disabled. The real loop and recorder processes run behind the window."""

from pathlib import Path

import numpy as np
import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QPlainTextEdit

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.loop.states import State
from device.safety.faults import Fault
from tests.ui.session import (
    build_connect_start,
    click,
    enabled,
    open_window,
    register_patient,
    short_trial,
)
from tests.ui.shown import shown
from ui.main_window import MainWindow

pytestmark = pytest.mark.slow


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    yield win
    win.close()


def test_a_whole_session(qtbot, window, tmp_path, caplog):
    caplog.set_level("INFO", logger="ui.main_window")
    win = window
    assert enabled(win) == {"build"}  # nothing out of order before Build
    register_patient(qtbot, win)

    # Parameters: the thesis's printed shoulder is refused with its numbers
    p = win.parameters_tab
    win.tabs.setCurrentWidget(p)
    p.shoulder_x.setValue(12.0)
    p.refresh()
    assert "67.6 cm from the shoulder; this arm reaches" in p.problem()
    shown = [label.text() for label in p.errors.values() if label.isVisible()]
    assert any("67.6 cm" in text for text in shown)
    assert "build" not in enabled(win)
    p.shoulder_x.setValue(-12.0)
    short_trial(win)
    assert p.problem() == ""
    assert "build" in enabled(win)

    click(qtbot, win.robot.buttons["build"])
    qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=20000)
    assert enabled(win) >= {"connect", "build"}
    assert "start" not in enabled(win)
    click(qtbot, win.robot.buttons["connect"])
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=20000)
    assert {"start", "disconnect"} <= enabled(win)
    assert not {"connect", "stop"} & enabled(win)
    click(qtbot, win.robot.buttons["start"])
    qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=10000)
    assert enabled(win) == {"stop"}
    assert win.built.assist == "as-needed"  # the window's default mode
    # the therapist lowers the assistance while the trial runs: the robot takes it live
    win.tabs.setCurrentWidget(p)
    p.assistance.setFocus()
    p.assistance.selectAll()
    qtbot.keyClicks(p.assistance, "40")
    qtbot.keyClick(p.assistance, Qt.Key.Key_Return)
    # said once the loop has taken it
    qtbot.waitUntil(lambda: "Assistance set to 40%" in win.message.text(), timeout=5000)
    # live view fills while the trial runs
    qtbot.waitUntil(lambda: win.live is not None and win.live.n > 200, timeout=10000)
    # the trial completes, is finalised, and the report is shown
    qtbot.waitUntil(lambda: win.unsaved_trial is not None, timeout=30000)
    assert win.tabs.currentWidget() is win.report
    # the console proposes the next trial's settings in the Parameters tab
    assert not win.parameters_tab._proposal_group.isHidden()
    assert win.registry.proposal(win.unsaved_trial).decision == "pending"
    qtbot.waitUntil(lambda: win.report.content is not None, timeout=10000)
    lines = "\n".join(win.report.lines())
    assert "%" in lines

    trials = win.registry.trials_for_patient(win.patient.code)
    assert len(trials) == 1
    trial = trials[0]
    assert trial.status == "complete"
    assert trial.metrics["rmse_x_m"] < 0.005  # robot and virtual patient followed the D
    assert trial.metrics["rmse_y_m"] < 0.005
    data = read_trial(win.registry.trial_path(trial))
    assert data.status == "complete"
    assert data.n_samples > 1000
    assert np.isfinite(data.channels["subject_torque"][data.channels["phase"] == 2]).all()
    import h5py

    with h5py.File(win.registry.trial_path(trial), "r") as f:  # the live trial's group
        assert f["assistance"].attrs["mode"] == "as-needed"
        assert f["assistance/feedforward_N"].shape == (1, 20)
    changes = [e for e in data.events if e["kind"] == "assistance"]
    assert changes
    assert changes[-1]["values"]["level"] == pytest.approx(0.4)

    # the clinic's events are in the log: connect, start, the end of the trial
    for needle in ("→ connected", "trial started", "trial ended"):
        assert needle in caplog.text.lower(), needle
    click(qtbot, win.robot.buttons["save"])
    qtbot.waitUntil(lambda: win.unsaved_trial is None, timeout=20000)
    reports = list((tmp_path / "data" / "reports").rglob("*.pdf"))
    assert len(reports) == 1
    # beside it, the trial as MATLAB data named as its trial file (thesis A.3)
    mat = reports[0].parent / win.registry.trial_path(trial).with_suffix(".mat").name
    assert mat.exists()
    import scipy.io

    assert "timeseries" in scipy.io.loadmat(mat)

    # progress lists the trial; replay opens it and every plot tab follows the cursor
    win.tabs.setCurrentWidget(win.progress)
    qtbot.waitUntil(lambda: win.progress.progress is not None
                    and len(win.progress.progress.trials) == 1, timeout=10000)
    win.tabs.setCurrentWidget(win.replay)
    with qtbot.waitSignal(win.replay.view_loaded, timeout=10000):
        win.replay.open_file(win.registry.trial_path(trial))
    assert win.shown_view is win.replay.view
    win.replay.set_cursor(1.0)


def test_emergency_stop_from_every_tab(qtbot, window):
    win = window
    short_trial(win)
    click(qtbot, win.robot.buttons["build"])
    qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=20000)
    click(qtbot, win.robot.buttons["connect"])
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=20000)
    for index in range(win.tabs.count()):
        win.tabs.setCurrentIndex(index)
        key = Qt.Key.Key_Escape if index % 2 == 0 else Qt.Key.Key_Space
        qtbot.keyClick(win.tabs.currentWidget(), key)
        qtbot.waitUntil(lambda: win.state == State.FAULTED, timeout=5000)
        assert win.fault_code == Fault.ESTOP
        assert win.banner.isVisible()
        assert "start" not in enabled(win)
        click(qtbot, win.clear_button)
        qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=5000)
        assert not win.banner.isVisible()


def test_no_display_message_is_one_line(monkeypatch, capsys):
    from ui.launcher import main

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.delenv("QT_QPA_PLATFORM", raising=False)
    assert main(["gui"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "no display found" in err[0]


def test_window_remembers_its_parameters(qtbot, tmp_path, monkeypatch):
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    settings = tmp_path / "config" / "settings.json"
    registry = Registry(DataDir(tmp_path / "data", "test"))
    win = MainWindow(registry, settings_path=settings)
    qtbot.addWidget(win)
    win.parameters_tab.radius.setValue(8.0)
    win.parameters_tab.refresh()
    tab = win.parameters_tab
    tab.patient_kind.setCurrentIndex(tab.patient_kind.findData("weak"))
    win.close()
    again = MainWindow(registry, settings_path=settings)
    qtbot.addWidget(again)
    assert again.parameters_tab.parameters().radius_m == pytest.approx(0.08)
    # the virtual patient chosen survives a restart (it went back to Healthy)
    assert again.parameters_tab.backend().patient_kind == "weak"
    again.close()
    assert Path(settings).exists()


def test_space_types_in_text_fields_but_stops_the_robot_elsewhere(qtbot, tmp_path, monkeypatch):
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    win = MainWindow(Registry(DataDir(tmp_path / "data", "test")),
                     settings_path=tmp_path / "config" / "settings.json")
    qtbot.addWidget(win)
    pressed = []
    monkeypatch.setattr(win.bridge, "estop", lambda held=True: pressed.append(held))
    win.show()
    win.activateWindow()  # application shortcuts act in the application's active window
    qtbot.waitUntil(win.isActiveWindow, timeout=2000)
    field = win.registration_tab.first_name
    win.tabs.setCurrentWidget(win.registration_tab)
    field.setFocus()
    qtbot.keyClick(field, Qt.Key.Key_Space)
    assert field.text() == " "
    assert pressed == []
    qtbot.keyClick(win.tabs, Qt.Key.Key_Space)
    assert pressed == [True]
    qtbot.keyClick(field, Qt.Key.Key_Escape)  # Esc stops the robot even while typing
    assert pressed == [True, True]
    win.close()


def test_trials_a_crash_left_recording_are_finished_and_announced(qtbot, tmp_path,
                                                                  monkeypatch):
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    registry = Registry(DataDir(tmp_path / "data", "test"))
    code = registry.create_patient("Ada", "Lovelace", body_mass_kg=91.0).code
    begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator")
    win = MainWindow(registry, settings_path=tmp_path / "config" / "settings.json")
    qtbot.addWidget(win)
    win.show()
    win.finish_interrupted_trials()
    qtbot.waitUntil(lambda: "interrupted" in win.message.text(), timeout=5000)
    assert "was interrupted and its file is missing" in win.message.text()
    assert registry.trial(begun.trial_id).status == "recording_lost"
    win.close()


def test_a_dead_recorder_stops_the_trial_and_the_window_finishes_it(qtbot, window):
    """kill -9 of the recorder mid-trial: the fault names the recorder, and the trial is
    finished in the registry from what reached its file (recording lost), not left
    'recording' until the next start."""
    import os
    import signal

    win = window
    register_patient(qtbot, win)
    p = win.parameters_tab
    p.repetitions.setValue(20)
    p.refresh()
    build_connect_start(qtbot, win)
    trial_path = win.trial_path
    qtbot.waitUntil(lambda: trial_path.exists(), timeout=20000)
    os.kill(win.bridge.client.recorder_pid, signal.SIGKILL)
    qtbot.waitUntil(lambda: win.state == State.FAULTED, timeout=10000)
    assert "recorder stopped" in win.banner_text.text()
    qtbot.waitUntil(lambda: win.unsaved_trial is not None, timeout=20000)
    trial = win.registry.trials_for_patient(win.patient.code)[0]
    assert trial.status == "recording_lost"
    # the file cannot hold the fault (its recorder is gone): the registry keeps its words
    assert "recorder stopped" in trial.end_reason


def test_three_trials_in_a_row_with_the_host_stalling_50_ms(qtbot, window, monkeypatch):
    """A shared clinic PC stalls the loop for 50 ms now and then (injected: one read every
    0.5 s of loop time sleeps 50 ms). On the simulator a late tick is recorded and shown
    but ends nothing: three Starts in one window session give three complete trials, each
    recording its stalls, each registered with its own number."""
    import ui.window.trial as window_trial
    from device.loop.messages import BackendConfig

    def stalling(**kwargs):
        return BackendConfig(**kwargs, fault_scenario="stalls", fault_at_s=0.2,
                             fault_options=(("sleep_s", 0.05), ("every_s", 0.5)))

    monkeypatch.setattr(window_trial, "BackendConfig", stalling)
    win = window
    register_patient(qtbot, win)
    short_trial(win, duration_s=1.5)
    click(qtbot, win.robot.buttons["build"])
    qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=20000)
    click(qtbot, win.robot.buttons["connect"])
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=20000)
    for n in (1, 2, 3):
        click(qtbot, win.robot.buttons["start"])
        qtbot.waitUntil(lambda: win.unsaved_trial is not None, timeout=60000)
        click(qtbot, win.robot.buttons["save"])
        qtbot.waitUntil(lambda: win.unsaved_trial is None, timeout=20000)
        qtbot.waitUntil(lambda: "start" in enabled(win), timeout=20000)
        trials = win.registry.trials_for_patient(win.patient.code)
        assert len(trials) == n
    assert [t.status for t in trials] == ["complete"] * 3
    # the status bar still names the robot, not the last state change's reason
    assert "simulator" in win.backend_label.text()
    assert "trial file" not in win.backend_label.text()
    assert len({t.number for t in trials}) == 3
    for trial in trials:
        data = read_trial(win.registry.trial_path(trial))
        assert data.status == "complete"
        assert np.nanmax(data.channels["lateness"]) >= 0.04  # the stalls are in the file


def test_messages_and_banners_never_grow_the_window_or_hide_the_emergency_stop(
        qtbot, tmp_path, monkeypatch):
    """A 1000 px screen: twenty long messages and banners later the window is as tall as
    before and the emergency stop is inside it, where the mouse finds it. With the
    console's theme, as `rehab gui` starts it (without it the window's fonts are smaller
    and the first fault banner, which took no place while hidden, grew it 1016 -> 1078 px);
    it fits a 1366 x 768 laptop's screen below its title bar."""
    from PySide6.QtWidgets import QApplication

    from ui import theme

    theme.apply_theme(QApplication.instance())
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    registry = Registry(DataDir(tmp_path / "data", "test"))
    win = MainWindow(registry, settings_path=tmp_path / "config" / "settings.json")
    shown(qtbot, win, 1280, 940)
    height = win.height()
    assert win.minimumSizeHint().height() <= 768 - 30
    long = "The control loop ran late and this sentence goes on and on " * 6

    def fault(text: str) -> None:  # as the loop reports one: the fault, then its state
        win._on_fault(int(Fault.LATE_TICK), text, {})
        win._on_state(int(State.FAULTED), text)

    win._say(long)
    fault(long)  # the banner takes its fixed place
    hint = win.minimumSizeHint().height()
    for k in range(20):
        win._say(f"{k}: {long}", problem=k % 2 == 0)
        fault(f"{k}: {long}")
        qtbot.wait(1)
    assert win.height() == height
    assert win.minimumSizeHint().height() == hint
    estop = win.robot.estop
    corner = estop.mapTo(win, estop.rect().bottomRight())
    assert win.rect().contains(corner)
    assert win.banner_text.toolTip().endswith(long)  # the whole text is one hover away
    assert win.message.text() == ""  # a banner takes the event line under it away
    win._say(f"after: {long}")
    assert win.message.toolTip().endswith(long)
    assert win.height() == height
    dialog = win.show_history()
    assert "19: The control loop" in dialog.findChild(QPlainTextEdit).toPlainText()
    win.close()


def test_start_says_what_it_waits_for_and_the_estop_has_one_wording(qtbot, window):
    """Built and connected with no patient registered: Start is greyed and says why (its
    tooltip and the event line); the e-stop's banner uses the supervisor's words."""
    win = window
    short_trial(win)
    click(qtbot, win.robot.buttons["build"])
    qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=20000)
    assert win.message.text().startswith("Trial built")
    click(qtbot, win.robot.buttons["connect"])
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=20000)
    start = win.robot.buttons["start"]
    assert not start.isEnabled()
    assert "registered patient" in start.toolTip()
    assert "Start needs a registered patient" in win.message.text()
    assert "Connect to the robot" not in win.message.text()  # the stale advice is gone
    win.emergency_stop()
    assert "release" not in win.banner_text.text()
    assert Fault.ESTOP.banner() in win.banner_text.text()
    qtbot.waitUntil(lambda: win.state == State.FAULTED, timeout=5000)
    assert Fault.ESTOP.banner() in win.banner_text.text()


def test_every_tab_fits_a_laptop_screen_without_cutting_its_panel(qtbot, tmp_path,
                                                                  monkeypatch):
    """At 1366 × 738 (a laptop below its title bar), with the console's theme: the side
    panels and forms scroll instead of growing the window, and none is cut at its right
    edge (the EMG tab's MVC protocol hid its Record buttons under the panel's edge)."""
    from PySide6.QtCore import Qt
    from PySide6.QtWidgets import QApplication, QScrollArea

    from ui import theme

    theme.apply_theme(QApplication.instance())
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    win = MainWindow(Registry(DataDir(tmp_path / "data", "test")),
                     settings_path=tmp_path / "config" / "settings.json")
    shown(qtbot, win, 1366, 738)
    assert win.height() == 738
    for index in range(win.tabs.count()):
        win.tabs.setCurrentIndex(index)
        QApplication.processEvents()
        for area in win.tabs.currentWidget().findChildren(QScrollArea):
            if (area.isVisible() and area.widget() is not None and
                    area.horizontalScrollBarPolicy() == Qt.ScrollBarPolicy.ScrollBarAlwaysOff):
                needed = area.widget().minimumSizeHint().width()
                assert needed <= area.viewport().width(), win.tabs.tabText(index)
    win.close()


def test_the_first_window_fits_the_screen_it_opens_on(qtbot, tmp_path, monkeypatch):
    """With no size remembered the window opened at 1400 × 900, on a 1366 × 768 laptop too:
    where no window manager moves it (a kiosk, Xvfb), the robot buttons and the emergency
    stop were below the screen's edge. It takes the screen's free area, less a title bar,
    where that is smaller."""
    from PySide6.QtCore import QSize

    from ui.window.settings import TITLE_BAR_PX, first_size

    assert first_size(QSize(1920, 1080)) == QSize(1400, 900)
    assert first_size(QSize(1366, 768)) == QSize(1366, 768 - TITLE_BAR_PX)
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    win = MainWindow(Registry(DataDir(tmp_path / "data", "test")),
                     settings_path=tmp_path / "config" / "settings.json")
    qtbot.addWidget(win)
    free = win.screen().availableGeometry().size()
    least = win.minimumSizeHint()
    assert win.width() <= max(free.width(), least.width())
    assert win.height() <= max(free.height() - TITLE_BAR_PX, least.height())
    win.close()
