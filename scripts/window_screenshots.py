"""Screenshots of the whole console window, every tab, during and after a real session on the
simulator (the loop and recorder processes run as in the clinic), on a laptop's screen and at
a large font:

    xvfb-run -a -s "-screen 0 1920x1080x24" .venv/bin/python scripts/window_screenshots.py

Writes docs/screenshots/window-<what>-1366x768.png (font scale 1, the window maximised on a
1366 × 768 laptop below its title bar) and window-<what>-font1.5.png (font scale 1.5 on a
1920 × 1080 screen). `--only 1366x768` or `--only font1.5` makes one set. Everything runs in a
temporary data folder with one fictional patient; nothing touches the clinic's data.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "screenshots"
CONFIGURATIONS = {
    # name: (width, height of the window, font scale)
    "1366x768": (1366, 738, 1.0),  # a laptop's screen below its title bar
    "font1.5": (1920, 1050, 1.5),
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", choices=sorted(CONFIGURATIONS))
    args = parser.parse_args(argv)
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance() or QApplication(sys.argv[:1])
    for name, (width, height, scale) in CONFIGURATIONS.items():
        if args.only in (None, name):
            with tempfile.TemporaryDirectory() as folder:
                session(app, Path(folder), name, width, height, scale)
    return 0


def session(app, folder: Path, suffix: str, width: int, height: int, scale: float) -> None:
    os.environ["REHAB_DATA_DIR"] = str(folder / "data")
    os.environ["REHAB_CONFIG_DIR"] = str(folder / "config")
    from PySide6.QtCore import Qt
    from PySide6.QtTest import QTest

    from app.records.datadir import locate_data_dir
    from app.records.registry import Registry
    from device.loop.states import State
    from ui import theme
    from ui.main_window import MainWindow

    theme.apply_theme(app, scale)
    data_dir = locate_data_dir()
    data_dir.ensure_layout()
    registry = Registry(data_dir)
    win = MainWindow(registry)
    win.resize(width, height)
    win.show()
    win.start_device()
    OUT.mkdir(parents=True, exist_ok=True)

    def wait(condition, timeout=60.0):
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                raise TimeoutError("the window did not get there in time")
            app.processEvents()
            time.sleep(0.01)

    def settle(seconds=0.4):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            app.processEvents()
            time.sleep(0.01)

    def shoot(name, tab=None):
        if tab is not None:
            win.tabs.setCurrentWidget(tab)
        settle()
        path = OUT / f"window-{name}-{suffix}.png"
        win.grab().save(str(path))
        print(path, f"{win.width()}x{win.height()}")

    def trial(level_during: int | None = None):
        if "build" in enabled():
            win.build()
            wait(lambda: win.state in (State.BUILT, State.CONNECTED) and not win.stale())
        if win.state == State.BUILT:
            win.connect_robot()  # as the button does (the simulator: 'Connecting the simulator…')
            wait(lambda: win.state == State.CONNECTED)
        settle(0.5)
        win.start_trial()
        wait(lambda: win.state == State.RUNNING)
        if level_during is not None:
            settle(1.5)
            p.assistance.setFocus()
            p.assistance.selectAll()
            QTest.keyClicks(p.assistance, str(level_during))
            QTest.keyClick(p.assistance, Qt.Key.Key_Return)

    def enabled():
        return {n for n, b in win.robot.buttons.items() if b.isEnabled()}

    shoot("instructions", win.instructions)
    reg = win.registration_tab
    win.tabs.setCurrentWidget(reg)
    reg.first_name.setText("Ada")
    reg.last_name.setText("Example")
    reg.body_mass.setValue(72.0)
    reg.upper_arm.setValue(30.0)
    reg.forearm.setValue(28.5)
    reg.shoulder_x.setValue(-12.0)
    reg.shoulder_y.setValue(73.0)
    reg.create_patient()
    wait(lambda: reg.selected_patient() is not None)
    reg.confirm_registration()
    wait(lambda: win.registration is not None)
    shoot("registration", reg)

    p = win.parameters_tab
    p.shoulder_x.setValue(12.0)
    p.refresh()
    shoot("parameters-unreachable", p)
    p.shoulder_x.setValue(-12.0)
    p.repetitions.setValue(4)  # 12 s: the live tabs are shot while the trial runs
    p.duration.setValue(3.0)
    p.refresh()
    shoot("parameters", p)

    trial(level_during=70)
    wait(lambda: "Assistance set to 70%" in win.message.text(), 10)
    settle(1.0)
    for name, tab in (("trajectory-live", win.trajectory), ("force-live", win.force),
                      ("angles-live", win.angles), ("torques-live", win.torques)):
        shoot(name, tab)
        if win.state != State.RUNNING:  # a "live" picture of a finished trial would lie
            raise RuntimeError(f"the trial ended before {name} was shot")
    shoot("video", win.video)
    wait(lambda: win.unsaved_trial is not None)
    wait(lambda: win.report.content is not None)
    shoot("report", win.report)
    shoot("emg", win.emg)
    live_emg(win, wait, settle, shoot)
    shoot("parameters-proposal", p)
    shoot("stale", win.trajectory)  # the level changed during the trial: Build first

    # two more trials, each taking the proposal: the Progress tab's staircase
    for _ in range(2):
        win.tabs.setCurrentWidget(p)  # the proposal is offered there (hidden elsewhere)
        settle(0.2)
        if not (p.use_proposal.isVisible() and p.use_proposal.isEnabled()):
            raise RuntimeError("no proposal offered after the trial")
        p.use_proposal.click()
        trial()
        first = win.unsaved_trial
        wait(lambda first=first: win.unsaved_trial is not None and win.unsaved_trial != first
             and win.state == State.CONNECTED)
    win.progress.set_patient(win.patient.code)
    wait(lambda: win.progress.progress is not None)
    shoot("progress", win.progress)

    first = registry.trials_for_patient(win.patient.code)[0]
    win.replay.open_file(registry.trial_path(first))
    wait(lambda: win.replay.view is not None)
    win.replay.set_cursor(2.5)
    win._on_cursor(2.5)
    shoot("replay", win.replay)
    shoot("force-replay", win.force)

    win.show_live()  # back to the last live trial under the banner
    win.emergency_stop()
    wait(lambda: win.state == State.FAULTED, 10)
    shoot("estop", win.trajectory)
    win.clear_fault()
    wait(lambda: win.state == State.CONNECTED, 10)
    win.closing_by_signal = True
    win.close()
    settle(0.5)


def live_emg(win, wait, settle, shoot) -> None:
    """The EMG tab streaming from a base station: the fake Trigno Control Utility of the
    device tests (its 16 channels, channel c a sine of c µV), the biceps's MVC recorded,
    the anterior deltoid's too short (flagged), the triceps's not yet; disconnected after,
    so that no later trial keeps EMG."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "trigno_server", ROOT / "tests" / "device" / "fakes" / "trigno_server.py")
    fake = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fake)
    emg = win.emg
    win.tabs.setCurrentWidget(emg)
    with fake.FakeTrignoServer() as server:
        emg.source_edit.setText("trigno:127.0.0.1")
        emg.source_ports = {"command_port": server.command_port,
                            "data_port": server.data_port}
        emg.connect_button.click()
        wait(lambda: len(emg.live_curves) == 3)
        emg.rest_seconds.setValue(0.0)
        for muscle, push_s in (("biceps", 2.0), ("anterior_deltoid", 0.6)):
            emg.push_seconds.setValue(push_s)
            emg.record_mvc(muscle)
            wait(lambda m=muscle: emg.guided is None and not emg.measurer.busy
                 and "MVC" in emg.mvc_labels[m].text())
        wait(lambda: emg.live_unit == "% MVC" and "not drawn" in emg.live_key.text())
        settle(3.0)  # the plot's whole 5 s
        shoot("emg-live", emg)
        emg.stop_live()


if __name__ == "__main__":
    sys.exit(main())
