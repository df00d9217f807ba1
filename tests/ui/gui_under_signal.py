"""`rehab gui` as the therapist runs it, driven to a running trial by itself: the window's
own entry point (ui.launcher) with a patient chosen, a long D built, connected and
started through its buttons; prints one JSON line when the trial runs. Run by
tests/ui/test_gui_signals.py in a process group of its own, which it then signals.

    REHAB_DATA_DIR=… REHAB_CONFIG_DIR=… python tests/ui/gui_under_signal.py
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def main() -> int:
    from PySide6.QtCore import QTimer

    from device.loop.states import State
    from ui import launcher
    from ui.main_window import MainWindow

    def steps(win):
        tab = win.registration_tab
        tab.choose(win.registry.patients()[0])
        while tab.selected_patient() is None:  # read on the job thread
            yield
        tab.confirm.click()
        while win.registration is None:
            yield
        win.parameters_tab.repetitions.setValue(20)
        win.parameters_tab.refresh()
        for button, state in (("build", State.BUILT), ("connect", State.CONNECTED),
                              ("start", State.RUNNING)):
            while not win.robot.buttons[button].isEnabled():
                yield
            win.robot.buttons[button].click()
            while win.state != state:
                yield
        print(json.dumps({"trial_id": win.trial_id, "path": str(win.trial_path),
                          "ring": win.bridge.client.ring.name}), flush=True)

    interrupted = MainWindow.finish_interrupted_trials

    def started(win) -> None:
        interrupted(win)
        walk = steps(win)
        timer = QTimer(win)
        timer.timeout.connect(lambda: next(walk, None))
        timer.start(20)
        win._driver = timer

    MainWindow.finish_interrupted_trials = started
    return launcher.main(["gui"])


if __name__ == "__main__":
    sys.exit(main())
