"""Screenshots of the whole console window, one per tab, during and after a real session on
the simulator (the loop and recorder processes run as in the clinic).

    xvfb-run -a -s "-screen 0 1600x1000x24" .venv/bin/python scripts/window_screenshots.py

Writes docs/screenshots/window-*.png. Everything runs in a temporary data folder with one
fictional patient; nothing touches the clinic's data.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "screenshots"


def main() -> int:
    with tempfile.TemporaryDirectory() as folder:
        os.environ["REHAB_DATA_DIR"] = str(Path(folder) / "data")
        os.environ["REHAB_CONFIG_DIR"] = str(Path(folder) / "config")
        from PySide6.QtWidgets import QApplication

        from app.records.datadir import locate_data_dir
        from app.records.registry import Registry
        from device.loop.states import State
        from ui import theme
        from ui.main_window import MainWindow

        app = QApplication.instance() or QApplication(sys.argv[:1])
        theme.apply_theme(app)
        data_dir = locate_data_dir()
        data_dir.ensure_layout()
        registry = Registry(data_dir)
        win = MainWindow(registry)
        win.resize(1500, 940)
        win.show()
        win.start_device()
        OUT.mkdir(parents=True, exist_ok=True)

        def wait(condition, timeout=30.0):
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
            path = OUT / f"window-{name}.png"
            win.grab().save(str(path))
            print(path)

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
        p.repetitions.setValue(2)
        p.refresh()
        shoot("parameters", p)

        win.build()
        wait(lambda: win.state == State.BUILT)
        win.bridge.connect()
        wait(lambda: win.state == State.CONNECTED)
        settle(0.5)
        win.start_trial()
        wait(lambda: win.state == State.RUNNING)
        settle(5.0)
        for name, tab in (("trajectory-live", win.trajectory), ("force-live", win.force),
                          ("angles-live", win.angles), ("torques-live", win.torques)):
            shoot(name, tab)
        wait(lambda: win.unsaved_trial is not None, 60)
        wait(lambda: win.report.content is not None)
        shoot("report", win.report)
        win.progress.set_patient(win.patient.code)
        wait(lambda: win.progress.progress is not None)
        shoot("progress", win.progress)
        trial = registry.trials_for_patient(win.patient.code)[0]
        win.replay.open_file(registry.trial_path(trial))
        wait(lambda: win.replay.view is not None)
        win.replay.set_cursor(3.0)
        shoot("replay", win.replay)
        shoot("force-replay", win.force)
        shoot("video", win.video)
        win.emergency_stop()
        wait(lambda: win.state == State.FAULTED, 5)
        shoot("estop", win.trajectory)
        win.clear_fault()
        wait(lambda: win.state == State.CONNECTED, 5)
        win.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
