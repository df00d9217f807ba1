"""The tabs that draw a trial (trajectory, force, joint angles, joint torques), fed a
simulated trial live in batches and as a finished view: their big numbers equal
app.trials.analysis on the same data and their curves hold the data."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.trials.analysis import analyse
from app.trials.headless import simulate
from core.metrics import DEFAULT_TORQUE_CUTOFF_HZ
from core.signal import lowpass
from core.trial import THESIS_SUBJECT
from tests.ui.shown import shown
from ui import theme
from ui.tabs import (
    VIEW_TABS,
    AnglesTab,
    ForceTab,
    InstructionsTab,
    TorquesTab,
    TrajectoryTab,
    ViewTab,
)
from ui.tabs.torques import help_words
from ui.views import samples
from ui.views.trialview import TrialView

PARAMETERS = THESIS_SUBJECT.replace(repetitions=2)


@pytest.fixture(scope="module")
def records():
    # A spastic patient pushes against the path at the corners: both colours appear.
    return simulate(PARAMETERS, patient="spastic", seed=1).records


@pytest.fixture(scope="module")
def metrics(records):
    channels = {name: records[name] for name in records.dtype.names}
    return analyse(channels, PARAMETERS).metrics


@pytest.fixture
def view(records):
    view = TrialView.from_records(records, PARAMETERS)
    view.finished = True
    return view


@pytest.fixture(autouse=True)
def themed(qapp):
    theme.apply_theme(qapp)


def exercise(records):
    return records[records["phase"] == 2]


def test_the_view_tabs_follow_the_protocol(qtbot):
    for cls in VIEW_TABS:
        tab = cls()
        qtbot.addWidget(tab)
        assert isinstance(tab, ViewTab)
    other = InstructionsTab()
    qtbot.addWidget(other)
    assert not isinstance(other, ViewTab)


def test_trajectory_numbers_and_path_live(qtbot, records, metrics):
    tab = shown(qtbot, TrajectoryTab())
    live = TrialView(PARAMETERS, initial_capacity=256)
    for i in range(0, len(records), 20):  # the window's timer between batches
        live.append(records[i:i + 20])
        tab.show_view(live)
    assert tab.rmse_x.text() == f"{metrics.rmse_x_m * 1000:.1f}"
    assert tab.rmse_y.text() == f"{metrics.rmse_y_m * 1000:.1f}"
    assert tab.directional.text() == f"{metrics.directional_performance_pct:.0f}"
    assert 0 < metrics.directional_performance_pct < 100

    x, y = tab.hand.getOriginalDataset()
    done = exercise(records)
    np.testing.assert_allclose(x, done["position"][:, 0] * 100)
    np.testing.assert_allclose(y, done["position"][:, 1] * 100)
    hx, hy = tab.hand_mark.getData()
    assert (hx[0], hy[0]) == pytest.approx(tuple(records["position"][-1] * 100))
    tx, ty = tab.target.getOriginalDataset()
    path = PARAMETERS.path().points(0.002) * 100
    np.testing.assert_allclose(np.column_stack((tx, ty)), path)
    # beneath the path, the error on each axis against time (thesis A.7), in mm
    for axis, line in enumerate(tab.error_curves):
        t, error = line.getOriginalDataset()
        np.testing.assert_allclose(t, done["time"])
        np.testing.assert_allclose(
            error, (done["position"][:, axis] - done["position_desired"][:, axis]) * 1000)
    rms = np.sqrt(np.mean(tab.error_curves[0].getOriginalDataset()[1] ** 2))
    assert rms == pytest.approx(metrics.rmse_x_m * 1000, rel=1e-6)


def test_a_long_trace_is_thinned_for_drawing_but_ends_at_the_hand(qtbot, records):
    tab = shown(qtbot, TrajectoryTab())
    copies = []
    for k in range(4):  # 16,000 exercise samples, as a 32 s trial
        copy = records.copy()
        copy["time"] += k * (records["time"][-1] + 0.002)
        copies.append(copy)
    long = np.concatenate(copies)
    view = TrialView.from_records(long, PARAMETERS)
    tab.show_view(view)
    x, y = tab.hand.getOriginalDataset()
    assert 1000 < len(x) <= samples.MAX_PATH_POINTS
    last = view.exercise.stop - 1
    assert (x[-1], y[-1]) == pytest.approx(tuple(view.column("position")[:, last] * 100))


def test_a_task_the_patient_paces_shows_no_error_from_the_task_s_clock(qtbot, records):
    """A reaching task's reference runs on the task's clock, not the patient's: the tab showed
    46 mm of "position error" and a directional performance for a healthy patient's free
    reaches. It shows the hand's path over the layout and says where the task's figures are;
    an exercise's numbers come back when it shows one."""
    tab = shown(qtbot, TrajectoryTab())
    task = TrialView.from_records(
        records, PARAMETERS.replace(assist="transparent", assessment="reaching"))
    tab.show_view(task)
    assert (tab.rmse_x.text(), tab.rmse_y.text(), tab.directional.text()) == ("–", "–", "–")
    assert "own pace" in tab.rmse_x.detail.text()
    assert tab.error_plot.isHidden()
    for line in tab.error_curves:
        t, _ = line.getOriginalDataset()
        assert t is None or len(t) == 0
    assert tab.desired_mark.getData()[0].size == 0
    x, _ = tab.hand.getOriginalDataset()
    assert len(x) == len(exercise(records))  # the hand's path is still drawn
    tab.show_view(TrialView.from_records(records, PARAMETERS))
    assert tab.rmse_x.text() != "–"
    assert not tab.error_plot.isHidden()


def test_trajectory_flip_and_cursor(qtbot, view):
    tab = shown(qtbot, TrajectoryTab())
    tab.show_view(view)
    item = tab.plot.getPlotItem()
    assert not item.getViewBox().xInverted()
    with qtbot.waitSignal(tab.flip_changed) as flipped:
        tab.flip_x.click()
    assert flipped.args == [True, False]
    assert item.getViewBox().xInverted()
    assert not item.getViewBox().yInverted()
    tab.set_flip(True, True)
    assert item.getViewBox().yInverted()

    tab.set_cursor(2.0)
    i = view.index_at(2.0)
    x, _ = tab.hand.getOriginalDataset()
    assert len(x) == i + 1  # the trace runs up to the cursor
    hx, hy = tab.hand_mark.getData()
    assert (hx[0], hy[0]) == pytest.approx(tuple(view.column("position")[:, i] * 100))


def test_force_segments_follow_the_within_mask(qtbot, view, records, metrics):
    tab = shown(qtbot, ForceTab())
    tab.show_view(view)
    ex = view.exercise
    min_run = round(samples.MERGE_RUNS_S / view.sample_period_s)
    mask = samples.merge_short_runs(view.within[ex], min_run)
    assert 0 < mask.sum() < mask.size
    force = exercise(records)["force"]
    for a in range(2):
        t, inside = tab.inside[a].getOriginalDataset()
        _, outside = tab.outside[a].getOriginalDataset()
        np.testing.assert_allclose(t, exercise(records)["time"])
        # Within samples are drawn blue and solid, the others vermillion and dashed; each
        # line also draws the sample after a change so the two meet.
        after_change = np.zeros_like(mask)
        after_change[1:] = mask[1:] != mask[:-1]
        np.testing.assert_allclose(inside[mask], force[mask, a])
        assert np.isnan(outside[mask & ~after_change]).all()
        np.testing.assert_allclose(outside[~mask], force[~mask, a])
        assert np.isnan(inside[~mask & ~after_change]).all()
    assert tab.inside[0].opts["pen"].color().name() == theme.WITHIN.lower()
    assert tab.outside[0].opts["pen"].style() != tab.inside[0].opts["pen"].style()
    assert tab.ranges[0].text() == f"{metrics.force_range_x_N:.2f}"
    assert tab.ranges[1].text() == f"{metrics.force_range_y_N:.2f}"
    assert tab.directional.text() == f"{metrics.directional_performance_pct:.0f}"

    tab.set_cursor(3.0)
    assert all(line.isVisible() and line.value() == pytest.approx(view.time[view.index_at(3.0)])
               for line in tab.cursors)


def test_angles_rom_and_curves(qtbot, view, records, metrics):
    tab = shown(qtbot, AnglesTab())
    tab.show_view(view)
    assert tab.rom[0].text() == f"{math.degrees(metrics.shoulder_rom_rad):.1f}°"
    assert tab.rom[1].text() == f"{math.degrees(metrics.elbow_rom_rad):.1f}°"
    isb = np.degrees(exercise(records)["subject_angle_isb"])
    for j in range(2):
        t, y = tab.curves[j].getOriginalDataset()
        np.testing.assert_allclose(y, isb[:, j])
        np.testing.assert_allclose(t, exercise(records)["time"])
    tab.set_cursor(1.0)
    assert tab.cursor_line.isVisible()


def test_torques_ranges_and_smoothing_toggle(qtbot, view, records, metrics):
    tab = shown(qtbot, TorquesTab())
    tab.show_view(view)
    assert tab.ranges[0].text() == f"{metrics.shoulder_torque_range_Nm:.2f}"
    assert tab.ranges[1].text() == f"{metrics.elbow_torque_range_Nm:.2f}"
    raw = exercise(records)["subject_torque"]
    _, y = tab.curves[0].getOriginalDataset()
    np.testing.assert_allclose(y, raw[:, 0])

    with qtbot.waitSignal(tab.smoothed, timeout=5000):
        tab.smoothing.click()
    smoothed = lowpass(raw, view.sample_period_s, DEFAULT_TORQUE_CUTOFF_HZ,
                       nan_policy="interpolate")
    _, y = tab.curves[0].getOriginalDataset()
    np.testing.assert_allclose(y, smoothed[:, 0], atol=1e-12)
    assert np.std(np.diff(y)) < 0.5 * np.std(np.diff(raw[:, 0]))
    assert tab.ranges[0].text() == f"{metrics.shoulder_torque_range_smoothed_Nm:.2f}"

    tab.smoothing.click()
    _, y = tab.curves[0].getOriginalDataset()
    np.testing.assert_allclose(y, raw[:, 0])


def test_the_robots_share_of_the_work_is_shown_live_and_equals_the_trials_metric(
        qtbot, records, metrics):
    """Fed in batches as the window feeds it, the running work equals the analysis's
    (core.work.mechanical_work over the whole exercise), and the Torques tab shows the
    robot's share in %: where the therapist sees the robot give way during a trial."""
    live = TrialView(PARAMETERS, initial_capacity=256)
    for i in range(0, len(records), 37):
        live.append(records[i:i + 37])
    robot, patient = live.work_J
    assert robot == pytest.approx(metrics.robot_work_J, rel=1e-9, abs=1e-12)
    assert patient == pytest.approx(metrics.patient_work_J, rel=1e-9, abs=1e-12)
    assert live.robot_work_share == pytest.approx(metrics.robot_work_share, rel=1e-9)
    tab = shown(qtbot, TorquesTab())
    tab.show_view(live)
    assert tab.work_share.text() == f"{metrics.robot_work_share * 100:.0f}"
    # the share is the help's: its work is the one shown with it
    assert live.help_J == pytest.approx(metrics.robot_help_work_J, rel=1e-9, abs=1e-12)
    assert help_words(metrics.robot_help_work_J) in tab.work_share.detail.text()
    # a transparent trial's motors only lighten the robot: no share of moving the handle
    tab.show_view(TrialView.from_records(records, PARAMETERS.replace(assist="transparent")))
    assert tab.work_share.text() == "–"
    assert "robot's own friction" in tab.work_share.detail.text()


def test_the_work_line_says_a_negative_help_as_holding_back_and_so_far_only_live(
        qtbot, records):
    """The Torques tab read "robot's help −0.22 J … over the exercise so far" beside a
    share of 0 % after the trial had ended: a negative help is the robot holding the hand
    back, and a finished trial's work is the whole exercise's, not "so far"."""
    assert help_words(-0.2249) == "the robot held the hand back 0.22 J"
    assert help_words(0.31) == "robot's help 0.31 J"
    assert help_words(-0.001) == "robot's help 0.00 J"
    assert help_words(math.nan) == "robot's help – J"
    live = TrialView(PARAMETERS, initial_capacity=256)
    live.append(records)
    tab = shown(qtbot, TorquesTab())
    tab.show_view(live)
    assert tab.work_share.detail.text().endswith("over the exercise so far")
    live.finished = True
    tab.show_view(live)
    detail = tab.work_share.detail.text()
    assert detail.endswith("over the exercise")
    assert "so far" not in detail
    assert help_words(live.help_J) in detail


def test_a_replayed_trial_s_work_is_its_file_s(qtbot, tmp_path):
    """A trial opened from its file sums the work as the live view does: the Torques tab of
    a replay said "robot 0.00 J, patient 0.00 J" (the view read no torque or joint angle)."""
    from app.trials.headless import save
    from app.trials.reader import read_trial

    path = tmp_path / "trial.h5"
    save(simulate(PARAMETERS.replace(repetitions=1), patient="healthy"), path)
    data = read_trial(path)
    view = TrialView.from_trial(data)
    robot, patient = view.work_J
    assert robot == pytest.approx(data.metrics["robot_work_J"], rel=1e-9)
    assert patient == pytest.approx(data.metrics["patient_work_J"], rel=1e-9)
    tab = shown(qtbot, TorquesTab())
    tab.show_view(view)
    assert tab.work_share.text() == f"{data.metrics['robot_work_share'] * 100:.0f}"


def test_live_smoothing_is_throttled(qtbot, records):
    tab = shown(qtbot, TorquesTab())
    tab.set_smoothing(True)
    live = TrialView(PARAMETERS)
    submitted = []
    tab.background.done.connect(lambda token, _result: submitted.append(token))
    for i in range(0, len(records), 50):
        live.append(records[i:i + 50])
        tab.show_view(live)
    qtbot.waitUntil(lambda: not tab.background.busy, timeout=5000)
    # Dozens of frames, but at most one smoothing a second (plus one waiting).
    assert 1 <= len(submitted) <= 2
    # The trial ends: the whole of it is smoothed once more, without waiting.
    live.finished = True
    with qtbot.waitSignal(tab.smoothed, timeout=5000):
        tab.show_view(live)
    assert submitted[-1] == (id(live), live.n, True)
    _, y = tab.curves[0].getOriginalDataset()
    assert len(y) == live.exercise.stop - live.exercise.start


def test_before_the_exercise_starts_the_numbers_are_dashes(qtbot, records):
    approach = records[:50].copy()
    approach["phase"] = 1  # moving to the start point
    view = TrialView(PARAMETERS)
    view.append(approach)
    trajectory = shown(qtbot, TrajectoryTab())
    force = shown(qtbot, ForceTab())
    angles = shown(qtbot, AnglesTab())
    for tab in (trajectory, force, angles):
        tab.show_view(view)
    assert trajectory.rmse_x.text() == "–"
    assert trajectory.directional.text() == "–"
    assert force.ranges[0].text() == "–"
    assert angles.rom[0].text() == "–"
    drawn, _ = force.inside[0].getOriginalDataset()
    assert drawn is None or len(drawn) == 0
    hx, _ = trajectory.hand_mark.getData()
    assert hx[0] == pytest.approx(approach["position"][-1, 0] * 100)
