"""A trial run in the window while a live EMG source streams (the fake Trigno Control
Utility): when the trial's file closes, its part of the EMG is stored in the file on the
trial's clock, and the source streams on. The real loop and recorder run behind."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from app.emg.importing import LIVE_MARGIN_S
from app.records.datadir import DataDir
from app.records.registry import Registry
from device.errors import RecordingError
from device.loop.states import State
from device.recording.emgfile import read_emg
from tests.ui.session import click, register_patient, short_trial
from ui.main_window import MainWindow

pytestmark = pytest.mark.slow

_spec = importlib.util.spec_from_file_location(
    "trigno_server", Path(__file__).parents[1] / "device" / "fakes" / "trigno_server.py")
fake = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fake)


def _stored(path) -> bool:
    try:
        return path is not None and read_emg(path) is not None
    except RecordingError:  # still being recorded
        return False


def test_live_emg_is_stored_with_the_trial_when_its_file_closes(qtbot, tmp_path, monkeypatch):
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    registry = Registry(DataDir(tmp_path / "data", "test"))
    win = MainWindow(registry, settings_path=tmp_path / "config" / "settings.json")
    qtbot.addWidget(win)
    win.show()
    win.start_device()
    with fake.FakeTrignoServer() as server:
        try:
            register_patient(qtbot, win)
            short_trial(win)
            emg = win.emg
            emg.source_edit.setText("trigno:127.0.0.1")
            emg.source_ports = {"command_port": server.command_port,
                                "data_port": server.data_port}
            click(qtbot, emg.connect_button)
            qtbot.waitUntil(lambda: emg.capture is not None, timeout=10000)
            click(qtbot, win.robot.buttons["build"])
            qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=120000)  # may compile
            click(qtbot, win.robot.buttons["connect"])
            qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=20000)
            click(qtbot, win.robot.buttons["start"])
            qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=10000)
            qtbot.waitUntil(lambda: win.state != State.RUNNING, timeout=60000)
            qtbot.waitUntil(lambda: "EMG stored with the trial" in win.message.text(),
                            timeout=60000)
            assert _stored(win.trial_path)
            stored = read_emg(win.trial_path)
            assert stored.samples.shape[1] == 16
            assert stored.attrs["source"] == "trigno:127.0.0.1"
            duration = 2.0 + 10.0  # at most: approach, exercise, hold
            assert stored.time_s[0] >= -LIVE_MARGIN_S - 0.01
            assert stored.time_s[-1] <= duration + LIVE_MARGIN_S
            # even on the monotonic clock; on the trial's clock too, except where the
            # simulator's ticks were late (its time is nominal, so a stall compresses there)
            step = np.diff(stored.time_s)
            assert (step >= 0).all()
            assert np.median(step) == pytest.approx(0.0135 / 26, rel=1e-3)
            assert emg.capture is not None
            assert emg.capture.running  # streams on
        finally:
            emg.stop_live()
            win.close()
