"""The Joint angles tab with a trial whose video went through `rehab pose`: the camera's
angles drawn beside the solver's, gaps kept, and Table 3.4's RMSE and bias in the panel;
without a pose group the panel says how to get one."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.pose.offline import estimate_pose
from app.pose.store import read_pose
from app.pose.synthetic import film
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.pose.keypoints import ArmKeypoints
from core.trial import THESIS_SUBJECT
from ui import theme
from ui.tabs import AnglesTab
from ui.views.trialview import TrialView


class ReplayDetector:
    """Reports what a known camera saw of the trial, frame after frame (app.pose.synthetic)."""

    side = "right"

    def __init__(self, filmed):
        self.filmed, self.calls = filmed, 0

    def detect(self, image_bgr):
        k = ArmKeypoints(self.filmed.keypoints_px[self.calls], self.filmed.visibility[self.calls])
        self.calls += 1
        return k

    def close(self):
        pass


@pytest.fixture(scope="module")
def posed(tmp_path_factory):
    import cv2

    from device.camera.capture import TIMESTAMPS_HEADER, timestamps_path

    path = tmp_path_factory.mktemp("posed") / "trial.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), seed=3), path)
    filmed = film(read_trial(path), seed=2)
    video = path.with_suffix(".avi")
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter.fourcc(*"MJPG"), 30.0, (640, 480))
    for _ in range(filmed.stamps_s.size):
        writer.write(np.zeros((480, 640, 3), np.uint8))
    writer.release()
    timestamps_path(video).write_text(TIMESTAMPS_HEADER + "".join(
        f"{k},{s:.6f}\n" for k, s in enumerate(filmed.stamps_s)))
    estimate_pose(path, ReplayDetector(filmed), video_start_s=filmed.true_frame_t_s[0])
    return path


def test_the_camera_is_drawn_beside_the_solver_with_its_agreement(qtbot, qapp, posed):
    theme.apply_theme(qapp)
    tab = AnglesTab()
    qtbot.addWidget(tab)
    tab.resize(1280, 800)
    tab.show()
    data = read_trial(posed)
    view = TrialView.from_trial(data)
    assert view.pose is not None
    tab.show_view(view)
    pose = read_pose(posed)
    t, y = tab.camera_curves[0].getOriginalDataset()
    ex = view.exercise
    inside = (data.time >= view.time[ex][0]) & (data.time <= view.time[ex][-1])
    np.testing.assert_allclose(t, data.time[inside])
    np.testing.assert_allclose(y, np.degrees(pose["angle_isb"][inside, 0]), equal_nan=True)
    assert np.isnan(y).any()  # gaps are drawn as gaps
    text = tab.camera_note.text()
    rmse = math.degrees(pose["attrs"]["camera_vs_solver_elbow_rmse_rad"])
    assert f"Elbow: {rmse:.1f}° RMSE" in text
    assert "Table 3.4" in text
    assert "Shoulder moved up to" in text


def test_without_a_pose_the_panel_says_how_to_get_one(qtbot, qapp, tmp_path):
    theme.apply_theme(qapp)
    path = tmp_path / "plain.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), seed=4), path)
    tab = AnglesTab()
    qtbot.addWidget(tab)
    view = TrialView.from_trial(read_trial(path))
    assert view.pose is None
    tab.show_view(view)
    assert "rehab pose" in tab.camera_note.text()
    assert tab.camera_curves[0].getOriginalDataset()[0] is None or \
        len(tab.camera_curves[0].getOriginalDataset()[0]) == 0
