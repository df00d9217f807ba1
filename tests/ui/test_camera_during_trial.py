"""The camera choice holds while a trial films: changed mid-trial, the camera the trial
began with was closed, its video cut short with nothing in the trial saying so; chosen
mid-trial, a camera filmed on screen what the trial did not record. The Parameters tab's
camera group is greyed from Start until the trial's file is closed, and says why."""

from __future__ import annotations

import pytest

from device.loop.states import State
from tests.ui.session import build_connect_start, open_window, register_patient, short_trial
from tests.ui.test_tabs_video import red_bar_clip


@pytest.fixture
def clip(tmp_path):
    # 100 s, played in real time: it runs on through Build, Connect and the trial however
    # slowly a loaded host gets there (a 10 s clip ended before Start once)
    return red_bar_clip(tmp_path / "clip.avi", frames=3000)


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
