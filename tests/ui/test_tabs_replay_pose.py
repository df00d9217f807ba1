"""Pose estimation from the Replay tab: a recorded trial's video run through the detector
off the GUI thread with a progress bar, the trial shown again with the camera's angles; a
video the model finds nobody in is refused in one line and the trial stays as it was."""

from __future__ import annotations

import cv2
import h5py
import numpy as np
import pytest

from app.pose.store import read_pose
from app.pose.synthetic import film
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.pose.keypoints import ArmKeypoints
from core.trial import THESIS_SUBJECT
from device.camera.capture import TIMESTAMPS_HEADER, timestamps_path
from ui import theme
from ui.tabs.replay import ReplayTab

ORIGIN = 9000.0


class ReplayDetector:
    """Reports what a known camera saw of the trial (app.pose.synthetic), frame by frame."""

    def __init__(self, filmed, side="right"):
        self.filmed, self.side, self.calls = filmed, side, 0

    def detect(self, image_bgr):
        k = ArmKeypoints(self.filmed.keypoints_px[self.calls], self.filmed.visibility[self.calls])
        self.calls += 1
        return k

    def close(self):
        pass


@pytest.fixture
def recorded(tmp_path):
    path = tmp_path / "trial.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), seed=7), path)
    with h5py.File(path, "r+") as f:
        f["summary"].attrs["wall_time_origin_monotonic_s"] = ORIGIN
    filmed = film(read_trial(path), seed=5, origin_s=ORIGIN)
    video = path.with_suffix(".avi")
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter.fourcc(*"MJPG"), 30.0, (640, 480))
    for _ in range(filmed.stamps_s.size):
        writer.write(np.full((480, 640, 3), 80, np.uint8))
    writer.release()
    timestamps_path(video).write_text(TIMESTAMPS_HEADER + "".join(
        f"{k},{s:.6f}\n" for k, s in enumerate(filmed.stamps_s)))
    return path, filmed


@pytest.fixture
def tab(qtbot, qapp):
    theme.apply_theme(qapp)
    widget = ReplayTab()
    qtbot.addWidget(widget)
    widget.show()
    return widget


def opened(qtbot, tab, path):
    with qtbot.waitSignal(tab.view_loaded, timeout=20000) as loaded:
        tab.open_file(path)
    return loaded.args[0]


def test_pose_from_the_replay_tab_with_progress(qtbot, tab, recorded, monkeypatch):
    path, filmed = recorded
    import device.camera.detector as detector

    monkeypatch.setattr(detector, "MediaPipePose",
                        lambda side, video: ReplayDetector(filmed, side))
    view = opened(qtbot, tab, path)
    assert view.pose is None
    assert tab.pose_button.isEnabled()
    with qtbot.waitSignal(tab.view_loaded, timeout=60000) as loaded:
        tab.run_pose()
        assert not tab.pose_button.isEnabled()
        assert tab.pose_progress.isVisible()
    view = loaded.args[0]
    assert view.pose is not None
    assert not tab.pose_progress.isVisible()
    assert "Joint angles tab" in tab.pose_status.text()
    assert read_pose(path) is not None


def test_the_real_model_finding_nobody_is_said_in_one_line(qtbot, tab, recorded):
    path, _ = recorded
    before = path.read_bytes()
    opened(qtbot, tab, path)
    with qtbot.waitSignal(tab.pose_job.failed, timeout=120000):
        tab.run_pose()
    assert "only 0 frames have both a visible wrist" in tab.pose_status.text()
    assert "\n" not in tab.pose_status.text()
    assert tab.pose_button.isEnabled()
    assert path.read_bytes() == before


def test_a_trial_without_a_video_offers_no_pose(qtbot, tab, tmp_path):
    path = tmp_path / "plain.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), seed=8), path)
    opened(qtbot, tab, path)
    assert not tab.pose_button.isEnabled()
    assert "No video" in tab.pose_status.text()
