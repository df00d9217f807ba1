"""A live trial as the console's window runs it, for the benches that measure the window's
side of it (bench/gui_load.py, bench/patient_screen.py): the real loop and recorder
processes behind a DeviceBridge (simulator, healthy virtual patient), the console's
heartbeat, and a 16 ms QTimer that takes the records into a TrialView and shows it."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from PySide6.QtCore import QTimer
from PySide6.QtWidgets import QApplication

from core.trial import TrialParameters
from device.loop.messages import BackendConfig
from device.recording.trialfile import SubjectInfo
from ui.device_bridge import DeviceBridge
from ui.views.trialview import TrialView


def spin(app: QApplication, seconds: float) -> None:
    """Run the event loop for `seconds` (a bench waits this way, never in sleep alone)."""
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        app.processEvents()
        time.sleep(0.002)


def feed_live_trial(app: QApplication, params: TrialParameters, path: Path,
                    show: Callable[[TrialView], None], *,
                    at_start: Callable[[], None] = lambda: None,
                    meanwhile: Callable[[float], None] = lambda elapsed_s: None,
                    ) -> tuple[float, int, TrialView]:
    """Build, connect and start a trial recorded to `path`, each 16 ms hand its new records
    to the live view and call `show(view)`, until the recorder closes the file. The
    measurement starts with the view (the trial's start), where `at_start` is called;
    `meanwhile(seconds since)` after each 50 ms of events. Returns (seconds measured,
    timer calls in them, the view)."""
    bridge = DeviceBridge()
    bridge.start()
    heartbeat = QTimer()
    heartbeat.timeout.connect(bridge.heartbeat)
    heartbeat.start(100)
    state = {"ended": False, "view": None, "ticks": 0}
    bridge.trial_started.connect(lambda *_: state.update(view=TrialView(params)))
    bridge.file_notice.connect(
        lambda kind, *_: state.update(ended=True) if kind == "closed" else None)
    path.parent.mkdir(parents=True, exist_ok=True)
    bridge.build(params, BackendConfig())
    spin(app, 2.0)
    bridge.connect()
    spin(app, 1.0)
    bridge.start_trial(str(path), SubjectInfo.from_parameters("PBENCH0", params))

    def repaint() -> None:
        records = bridge.take_records()
        view = state["view"]
        if view is None:
            return
        if len(records):
            view.append(records[records["phase"] > 0])
        show(view)
        state["ticks"] += 1

    timer = QTimer()
    timer.timeout.connect(repaint)
    timer.start(16)
    while state["view"] is None:
        spin(app, 0.05)
    at_start()
    started, ticks0 = time.perf_counter(), state["ticks"]
    while not state["ended"]:
        spin(app, 0.05)
        meanwhile(time.perf_counter() - started)
    elapsed = time.perf_counter() - started
    timer.stop()
    heartbeat.stop()
    bridge.close()
    return elapsed, state["ticks"] - ticks0, state["view"]
