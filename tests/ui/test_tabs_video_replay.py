"""The Video tab following the Replay slider: the frame of the trial's video taken at the
cursor's time, with the keypoints `rehab pose` found on it; a trial without a video
replays without one."""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtGui import QColor

from app.pose.offline import estimate_pose
from app.pose.replay import ReplayVideo
from app.pose.synthetic import film
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.pose.keypoints import SHOULDER
from core.trial import THESIS_SUBJECT
from tests.pose_film import ReplayDetector, write_video
from tests.ui.shown import shown
from ui import theme
from ui.tabs import VideoTab


def grey(k: int) -> int:
    return 20 + (7 * k) % 200


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    path = tmp_path_factory.mktemp("replay") / "trial.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), seed=5), path)
    filmed = film(read_trial(path), seed=4)
    # frame k is a flat grey that tells its index
    write_video(path.with_suffix(".avi"), filmed.stamps_s, grey=grey)
    estimate_pose(path, ReplayDetector(filmed), video_start_s=filmed.true_frame_t_s[0])
    return path, filmed


@pytest.fixture
def tab(qtbot, qapp):
    theme.apply_theme(qapp)
    widget = VideoTab()
    shown(qtbot, widget, 800, 600)
    yield widget
    widget.close_camera()


def test_the_video_follows_the_slider_with_its_keypoints(tab, recorded):
    path, filmed = recorded
    video = ReplayVideo.open(read_trial(path))
    assert video is not None
    tab.show_replay(video)
    assert tab.pages.currentIndex() == 1
    for k in (10, 60, 30):  # forwards and back
        t = filmed.true_frame_t_s[k] + 0.005
        tab.seek(t)
        assert tab.replayed_frame() == k
        image = tab.picture.pixmap().toImage()
        corner = image.pixelColor(3, 3)
        assert abs(corner.red() - grey(k)) < 8  # the frame taken then, not another
        assert f"frame {k}" in tab.state.text()
    # the keypoints of a frame are drawn where pose estimation saw them
    seen = np.flatnonzero(np.isfinite(video.keypoints_px[:, SHOULDER]).all(axis=1))
    k = int(seen[seen >= 30][0])
    tab.seek(filmed.true_frame_t_s[k] + 0.005)
    assert tab.replayed_frame() == k
    scale = tab.picture.pixmap().width() / 640
    x, y = video.keypoints_px[k, SHOULDER] * scale
    colour = tab.picture.pixmap().toImage().pixelColor(round(float(x)), round(float(y)))
    assert abs(colour.red() - QColor(theme.YELLOW).red()) < 40
    assert abs(colour.blue() - QColor(theme.YELLOW).blue()) < 60
    tab.seek(-5.0)  # before the video
    assert tab.replayed_frame() == -1
    assert "no picture" in tab.state.text()
    tab.close_replay()
    assert tab.pages.currentIndex() == 0


def test_a_trial_without_a_video_replays_without_one(tmp_path):
    path = tmp_path / "plain.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), seed=6), path)
    assert ReplayVideo.open(read_trial(path)) is None


def test_a_pose_found_on_another_video_is_not_drawn_on_the_trials_own(tmp_path):
    """`rehab pose --video other.avi`: its frames, times and keypoints are that video's. The
    replay shows that video when it lies beside the trial; otherwise the trial's own video
    goes without them (they were drawn on its frames, at the wrong places and moments)."""
    path = tmp_path / "trial.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), seed=7), path)
    filmed = film(read_trial(path), seed=8)
    write_video(path.with_suffix(".avi"), filmed.stamps_s, grey=grey)  # the console's own
    other = tmp_path / "other.avi"
    write_video(other, filmed.stamps_s, size=(320, 240))
    estimate_pose(path, ReplayDetector(filmed), video_path=other,
                  video_start_s=filmed.true_frame_t_s[0])
    beside = ReplayVideo.open(read_trial(path))
    assert beside is not None
    assert beside.name == "other.avi"  # the video the keypoints belong to
    assert np.isfinite(beside.keypoints_px).any()
    beside.close()
    moved = tmp_path / "elsewhere"
    moved.mkdir()
    other.rename(moved / other.name)
    # the trial's own video has no clock origin here (a simulated trial): nothing to show;
    # never the other video's keypoints over this one's frames
    assert ReplayVideo.open(read_trial(path)) is None
