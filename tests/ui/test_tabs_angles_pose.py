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
from core.trial import THESIS_SUBJECT
from tests.pose_film import ReplayDetector, write_video
from ui import theme
from ui.tabs import AnglesTab
from ui.views.trialview import TrialView


@pytest.fixture(scope="module")
def posed(tmp_path_factory):
    path = tmp_path_factory.mktemp("posed") / "trial.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), seed=3), path)
    filmed = film(read_trial(path), seed=2)
    write_video(path.with_suffix(".avi"), filmed.stamps_s, grey=lambda k: 0)
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
    assert tab.legend_names() == ["shoulder", "elbow", "shoulder, camera", "elbow, camera"]
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
    # in the therapist's words, not a shell command (issue 27 #14)
    assert "Joint angles from the video" in tab.camera_note.text()
    assert "rehab" not in tab.camera_note.text()
    assert tab.camera_curves[0].getOriginalDataset()[0] is None or \
        len(tab.camera_curves[0].getOriginalDataset()[0]) == 0
    # the legend names no camera curve that is not drawn (it named both on every trial)
    assert tab.legend_names() == ["shoulder", "elbow"]


def test_a_researcher_compares_solver_and_camera_with_reference_angles(qtbot, qapp, posed,
                                                                       tmp_path, monkeypatch):
    """Table 3.4's validation as a tool in the window: the button takes a CSV of reference
    angles and the panel gives the solver's and the camera's error against it; a bad CSV
    is one line that says what the file needs."""
    from PySide6.QtCore import Qt
    from PySide6.QtWidgets import QFileDialog

    from app.pose.offline import compare_with_reference, reference_lines

    theme.apply_theme(qapp)
    tab = AnglesTab()
    qtbot.addWidget(tab)
    tab.show()
    assert not tab.reference_button.isEnabled()  # nothing shown yet
    data = read_trial(posed)
    tab.show_view(TrialView.from_trial(data))
    assert tab.reference_button.isEnabled()
    # the goniometer read the solver's own angles, 1° high, every 0.5 s
    times = np.arange(0.5, data.time[-1] - 0.5, 0.5)
    isb = np.degrees(np.column_stack([
        np.interp(times, data.time, data.channels["subject_angle_isb"][:, j]) for j in (0, 1)]))
    good = tmp_path / "goniometer.csv"
    good.write_text("time_s,shoulder_deg,elbow_deg\n" + "".join(
        f"{t:.3f},{a + 1.0:.4f},{b + 1.0:.4f}\n" for t, (a, b) in zip(times, isb, strict=True)))
    monkeypatch.setattr(QFileDialog, "getOpenFileName",
                        staticmethod(lambda *a, **k: (str(good), "CSV files (*.csv)")))
    qtbot.mouseClick(tab.reference_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: "other − reference" in tab.reference_note.text(), timeout=20000)
    text = tab.reference_note.text()
    for line in reference_lines(compare_with_reference(posed, good)):
        assert line in text
    assert "solver: shoulder 1.00° RMSE, -1.00° bias" in text
    assert "camera: shoulder" in text

    bad = tmp_path / "bad.csv"
    bad.write_text("when,shoulder,elbow\n1,2,3\n")
    monkeypatch.setattr(QFileDialog, "getOpenFileName",
                        staticmethod(lambda *a, **k: (str(bad), "CSV files (*.csv)")))
    qtbot.mouseClick(tab.reference_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: theme.PROBLEM_SIGN in tab.reference_note.text(), timeout=20000)
    assert "must name frame or time_s, and shoulder_deg and elbow_deg" in \
        tab.reference_note.text()
    assert "\n" not in tab.reference_note.text()
