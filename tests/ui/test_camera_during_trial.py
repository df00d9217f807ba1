"""The camera choice holds while a trial films: changed mid-trial, the camera the trial
began with was closed, its video cut short with nothing in the trial saying so; chosen
mid-trial, a camera filmed on screen what the trial did not record. The Parameters tab's
camera group is greyed from Start until the trial's file is closed, and says why."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from device.loop.states import State
from tests.ui.session import build_connect_start, open_window, register_patient, short_trial


@pytest.fixture
def clip(tmp_path):
    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), 30.0, (160, 120))
    for k in range(300):
        image = np.zeros((120, 160, 3), np.uint8)
        image[:, : k % 150 + 10] = (0, 0, 230)
        writer.write(image)
    writer.release()
    return path


@pytest.mark.slow
def test_the_camera_choice_holds_while_a_trial_films(qtbot, tmp_path, monkeypatch, clip):
    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        register_patient(qtbot, win)
        short_trial(win, duration_s=2.0)
        choice = win.parameters_tab.camera
        with qtbot.waitSignal(win.video.camera_opened, timeout=10000):
            choice.with_camera.setChecked(True)
            choice.source_edit.setText(str(clip))
        camera = win.video.camera
        assert choice.isEnabled()
        build_connect_start(qtbot, win)
        assert camera.recording
        assert not choice.isEnabled()
        assert "until this trial ends" in choice.hint.text()
        qtbot.waitUntil(lambda: win.trial_id is None, timeout=60000)
        assert choice.isEnabled()
        assert "saved beside the trial" in choice.hint.text()
        assert win.video.camera is camera
        assert not camera.recording
        assert win.state == State.CONNECTED
        video = win.trial_path.with_suffix(".mp4")
        assert video.exists()
        assert video.stat().st_size > 0
    finally:
        win.closing_by_signal = True
        win.close()
