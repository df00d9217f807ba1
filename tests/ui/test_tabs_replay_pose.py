"""Pose estimation from the Replay tab: a recorded trial's video run through the detector
off the GUI thread with a progress bar, the trial shown again with the camera's angles; a
video the model finds nobody in is refused in one line and the trial stays as it was."""

from __future__ import annotations

import pytest

from app.pose.store import read_pose
from app.pose.synthetic import film
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from tests.pose_film import ReplayDetector, write_video
from tests.trialfiles import edited
from ui import theme
from ui.tabs.replay import ReplayTab

ORIGIN = 9000.0


@pytest.fixture
def recorded(tmp_path):
    path = tmp_path / "trial.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), seed=7), path)
    with edited(path) as f:
        f["summary"].attrs["wall_time_origin_monotonic_s"] = ORIGIN
    filmed = film(read_trial(path), seed=5, origin_s=ORIGIN)
    write_video(path.with_suffix(".avi"), filmed.stamps_s, grey=lambda k: 80)
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


def test_a_registered_trial_s_pose_keeps_its_file_the_registry_s(qtbot, tab, tmp_path,
                                                                  monkeypatch):
    """The pose goes into the file after the trial ended: the registry records the file's
    new checksum, so exports and studies still read it as the trial's."""
    import device.camera.detector as detector
    from app.records.datadir import DataDir
    from app.records.registry import Registry
    from app.records.registry.provenance import file_checksum

    registry = Registry(DataDir(tmp_path / "data", "test"))
    code = registry.create_patient("Ada", "Lovelace").code
    parameters = THESIS_SUBJECT.replace(repetitions=1)
    begun = registry.begin_trial(code, parameters, backend="simulator")
    path = begun.path
    save(simulate(parameters, seed=7), path)
    with edited(path) as f:
        f["summary"].attrs["wall_time_origin_monotonic_s"] = ORIGIN
    filmed = film(read_trial(path), seed=5, origin_s=ORIGIN)
    write_video(path.with_suffix(".avi"), filmed.stamps_s, grey=lambda k: 80)
    registry.finish_trial(begun.trial_id, "complete", {}, checksum=file_checksum(path))
    before = registry.trial(begun.trial_id).checksum
    monkeypatch.setattr(detector, "MediaPipePose",
                        lambda side, video: ReplayDetector(filmed, side))
    tab.set_registry(registry)
    opened(qtbot, tab, path)
    with qtbot.waitSignal(tab.view_loaded, timeout=60000):
        tab.run_pose()
    assert read_pose(path) is not None
    assert registry.trial(begun.trial_id).checksum != before
    assert registry.verify_trial_file(begun.trial_id) is None
