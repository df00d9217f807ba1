"""The Video tab: frames from a camera source (a synthetic video file here), the recording
state, and a clear message when no camera is in use or it cannot be opened."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from PySide6.QtGui import QColor

from tests.ui.shown import shown
from ui import theme
from ui.tabs import VideoTab


def red_bar_clip(path, frames: int = 60):
    """A 160 x 120 MJPG clip at 30 fps: a red bar growing frame by frame (BGR), from 10 px
    wide by 2 px a frame (back to 10 after 75 frames)."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), 30.0, (160, 120))
    for k in range(frames):
        image = np.zeros((120, 160, 3), np.uint8)
        image[:, : 2 * (k % 75) + 10] = (0, 0, 230)
        writer.write(image)
    writer.release()
    return path


@pytest.fixture
def clip(tmp_path):
    return red_bar_clip(tmp_path / "clip.avi")


@pytest.fixture
def tab(qtbot, qapp):
    theme.apply_theme(qapp)
    widget = VideoTab()
    shown(qtbot, widget, 800, 600)
    yield widget
    widget.close_camera()


def test_without_camera_the_tab_says_how_to_enable_one(tab):
    assert tab.pages.currentIndex() == 0
    text = tab.message.text()
    assert "No camera is in use" in text
    assert "With camera" in text
    assert "Parameters" in text


def test_frames_from_a_video_file_are_shown_with_the_recording_state(qtbot, tab, clip, tmp_path):
    with qtbot.waitSignal(tab.camera_opened, timeout=5000) as opened:
        tab.open_camera(str(clip))
    camera = opened.args[0]
    assert tab.camera is camera
    assert tab.pages.currentIndex() == 1
    qtbot.waitUntil(lambda: tab.shown_frames() >= 5, timeout=5000)
    image = tab.picture.pixmap().toImage()
    assert not image.isNull()
    assert image.width() > 0
    centre = image.pixelColor(image.width() // 2 - 2, image.height() // 2)
    left = image.pixelColor(2, image.height() // 2)
    assert left.red() > 180
    assert left.blue() < 60
    assert centre.isValid()
    assert "Not recording" in tab.state.text()

    camera.start_recording(tmp_path / "trial.mp4")
    qtbot.waitUntil(lambda: "Recording to trial.mp4" in tab.state.text(), timeout=3000)
    tab.close_camera()
    assert not camera.running
    assert not camera.recording
    assert tab.pages.currentIndex() == 0


def test_a_camera_that_cannot_open_is_explained(qtbot, tab, tmp_path):
    with qtbot.waitSignal(tab.camera_failed, timeout=5000) as failed:
        tab.open_camera(str(tmp_path / "missing.mp4"))
    assert "does not exist" in failed.args[0]
    assert "cannot be used" in tab.message.text()
    assert "does not exist" in tab.message.text()
    assert tab.camera is None


@pytest.fixture(scope="module")
def astronaut_clip(tmp_path_factory):
    from tests.astronaut import astronaut_clip

    return astronaut_clip(tmp_path_factory.mktemp("clip") / "astronaut.avi")


def test_the_pose_is_drawn_over_the_live_picture(qtbot, tab, astronaut_clip):
    """MediaPipe on the live frames on its own worker; the keypoints drawn in the theme's
    yellow at the shoulders, and the rate in the state line."""
    with qtbot.waitSignal(tab.camera_opened, timeout=5000):
        tab.open_camera(str(astronaut_clip))
    assert tab.live_pose is None
    tab.pose_box.setChecked(True)
    assert tab.live_pose is not None
    qtbot.waitUntil(lambda: tab.overlaid_frames() >= 3, timeout=30000)
    # the keypoints drawn on the picture shown: the worker's latest may already be newer
    # (it failed now and then on a loaded machine, the wrist having moved since)
    result = tab.drawn_pose
    pixmap = tab.picture.pixmap()
    scale = pixmap.width() / 512
    x, y = result.keypoints.xy_px[0] * scale
    colour = pixmap.toImage().pixelColor(round(float(x)), round(float(y)))
    yellow = QColor(theme.YELLOW)
    assert abs(colour.red() - yellow.red()) < 40
    assert abs(colour.green() - yellow.green()) < 40
    assert abs(colour.blue() - yellow.blue()) < 60
    qtbot.waitUntil(lambda: "pictures a second" in tab.state.text(), timeout=5000)
    live = tab.live_pose
    tab.pose_box.setChecked(False)
    assert tab.live_pose is None
    assert not live.running
    tab.close_camera()


def test_a_live_pose_the_os_will_not_put_behind_the_loop_says_so(qtbot, tab, astronaut_clip,
                                                                monkeypatch):
    """Where the OS refuses a lower priority, the pose still runs and the state line says
    it competes with the loop."""
    def refused(*_):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr("device.background.os.setpriority", refused)
    with qtbot.waitSignal(tab.camera_opened, timeout=5000):
        tab.open_camera(str(astronaut_clip))
    tab.pose_box.setChecked(True)
    qtbot.waitUntil(lambda: "pictures a second" in tab.state.text(), timeout=30000)
    qtbot.waitUntil(lambda: "competes with the loop" in tab.state.text(), timeout=5000)
    assert "could not lower the background work's priority" in tab.state.text()
    tab.pose_box.setChecked(False)
    tab.close_camera()


def test_a_live_pose_that_sees_no_arm_says_so(qtbot, tab, clip):
    """Nothing drawn and a rate alone read as working: with nobody in view the state line
    says the arm is not seen."""
    with qtbot.waitSignal(tab.camera_opened, timeout=5000):
        tab.open_camera(str(clip))  # red bars, nobody in them
    tab.pose_box.setChecked(True)
    qtbot.waitUntil(lambda: tab.live_pose is not None and tab.live_pose.latest() is not None,
                    timeout=60000)
    qtbot.waitUntil(lambda: "no arm in view" in tab.state.text(), timeout=5000)
    assert "turn the camera to the arm" in tab.state.text()
    tab.pose_box.setChecked(False)
