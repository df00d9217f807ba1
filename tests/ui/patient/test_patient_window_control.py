"""The therapist's window keeps control of the patient's screen: it opens from the
console, never takes the keyboard (the e-stop keys still reach the console), closes
cleanly on its own and with the console (issue 30)."""

import pytest
import shiboken6
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QApplication

from tests.ui.session import open_window
from ui.patient.window import PatientWindow
from ui.views.patient_screen import CUE_WAIT, PatientOptions


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    win.activateWindow()
    qtbot.waitUntil(lambda: QApplication.activeWindow() is win, timeout=20000)
    yield win
    win.close()


@pytest.mark.parametrize("key", [Qt.Key.Key_Escape, Qt.Key.Key_Space])
def test_the_e_stop_keys_reach_the_console_with_the_patient_screen_open(qtbot, window, key,
                                                                        monkeypatch):
    sent = []  # what the loop's e-stop flag was given (no loop runs in this test)
    monkeypatch.setattr(window.bridge, "estop", sent.append)
    patient = window.open_patient_screen()
    qtbot.waitExposed(patient, timeout=20000)
    assert patient.windowFlags() & Qt.WindowType.WindowDoesNotAcceptFocus
    assert patient.testAttribute(Qt.WidgetAttribute.WA_ShowWithoutActivating)
    assert QApplication.activeWindow() is window  # showing it took nothing from the console
    assert not patient.isActiveWindow()
    assert not window.latch.estop_held
    target = QApplication.focusWidget() or window
    assert target.window() is window
    qtbot.keyClick(target, key)
    assert window.latch.estop_held  # the emergency stop pressed from the console's keys
    assert sent == [True]
    # and even a key sent to the patient's window stops the robot (application shortcut)
    window.clear_fault()
    assert not window.latch.estop_held
    qtbot.keyClick(patient, Qt.Key.Key_Escape)
    assert window.latch.estop_held


def test_the_patient_screen_closes_on_its_own_and_opens_again(qtbot, window):
    patient = window.open_patient_screen()
    qtbot.waitExposed(patient, timeout=20000)
    with qtbot.waitSignal(patient.closed, timeout=20000):
        patient.close()
    assert window.patient_window is None
    again = window.open_patient_screen()
    assert again is not patient
    assert again.isVisible()
    assert again.frame.cue == CUE_WAIT  # no trial: it waits, drawing the built exercise


def test_the_patient_screen_closes_with_the_console(qtbot, window):
    window.set_patient_options(mirror=True, rotation_deg=90)
    patient = window.open_patient_screen()
    assert patient.options == PatientOptions(mirror=True, rotation_deg=90)
    qtbot.waitExposed(patient, timeout=20000)
    with qtbot.waitSignal(patient.closed, timeout=20000):
        window.close()
    assert window.patient_window is None
    assert not shiboken6.isValid(patient)  # closed and deleted, nothing left behind


def test_f11_puts_the_patient_screen_full_screen_and_back(qtbot, window):
    patient = window.open_patient_screen()
    qtbot.waitExposed(patient, timeout=20000)
    qtbot.keyClick(QApplication.focusWidget() or window, Qt.Key.Key_F11)
    qtbot.waitUntil(patient.isFullScreen, timeout=20000)
    qtbot.keyClick(QApplication.focusWidget() or window, Qt.Key.Key_F11)
    qtbot.waitUntil(lambda: not patient.isFullScreen(), timeout=20000)
    assert QApplication.activeWindow() is window


def test_bad_options_are_refused_in_one_line():
    with pytest.raises(ValueError, match="rotation 45: give 0, 90, 180 or 270"):
        PatientOptions(rotation_deg=45)
    with pytest.raises(ValueError, match="unknown patient screen option colour"):
        PatientOptions.from_dict({"colour": "red"})
    with pytest.raises(ValueError, match="option mirror = 'yes': give true or false"):
        PatientOptions.from_dict({"mirror": "yes"})
    assert PatientOptions.from_dict(PatientOptions(sound=True).to_dict()) == \
        PatientOptions(sound=True)


def test_the_patient_window_alone_waits_without_a_trial(qtbot):
    patient = PatientWindow()
    qtbot.addWidget(patient)
    patient.show_parameters(None)
    patient.grab()
    shown = ("cursor", "target", "attention", "top", "message")
    assert {k: patient.painted[k] for k in shown} == {
        "cursor": None, "target": None, "attention": None, "top": ("", "", ""),
        "message": "Please wait"}
    assert "plan" not in patient.painted


@pytest.mark.parametrize(("side", "mirror", "turn", "edge"), [
    ("left", False, 0, "left"), ("right", False, 0, "right"), ("left", True, 0, "right"),
    ("left", False, 90, "bottom"), ("right", False, 180, "left")])
def test_the_neglected_side_is_cued_on_the_edge_of_the_screen_towards_it(
        qtbot, side, mirror, turn, edge):
    """The trial's neglect_side (the patient's; left is the robot's +x, docs/frames.md)
    puts the cue on the screen's edge toward it, as the screen is turned."""
    from core.trial import THESIS_SUBJECT
    from ui.patient.window import ATTENTION

    patient = PatientWindow(PatientOptions(mirror=mirror, rotation_deg=turn))
    qtbot.addWidget(patient)
    patient.resize(800, 600)
    params = THESIS_SUBJECT.replace(shape="targets", centre_m=(-0.2, 0.35), radius_m=0.08,
                                    n_targets=5)
    patient.show_parameters(params.replace(neglect_side=side))
    image = patient.grab().toImage()
    assert patient.painted["attention"] == edge
    area = patient.screen_layout().table
    x = {"left": area.left + 2, "right": area.left + area.width - 3}.get(edge, area.centre[0])
    y = {"top": area.top + 2, "bottom": area.top + area.height - 3}.get(edge, area.centre[1])
    assert image.pixelColor(round(x), round(y)) == ATTENTION
    # the targets themselves lie on that side of home, on the screen
    where = patient.placement()
    drawn = where.to_px(patient.scene.targets_m) - where.to_px(params.centre_m)
    axis, sign = {"left": (0, -1), "right": (0, 1), "top": (1, -1), "bottom": (1, 1)}[edge]
    assert (sign * drawn[:, axis] >= -1e-6).all()
    patient.show_parameters(params)
    patient.grab()
    assert patient.painted["attention"] is None


def test_the_patient_screen_s_options_are_kept_for_the_next_start(qtbot, tmp_path, monkeypatch):
    first = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    first.set_patient_options(mirror=True, rotation_deg=180, previous_path=False)
    first.close()
    again = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    assert again.patient_options == PatientOptions(mirror=True, rotation_deg=180,
                                                   previous_path=False)
    assert again.open_patient_screen().options == again.patient_options
    again.close()


def test_saved_options_that_no_longer_read_are_said_and_not_used(qtbot, tmp_path, monkeypatch):
    import json

    settings = tmp_path / "config" / "settings.json"
    settings.parent.mkdir(parents=True)
    settings.write_text(json.dumps({"patient_screen": {"rotation_deg": 45}}))
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    assert win.patient_options == PatientOptions()
    assert ("The patient's screen's saved options were not used (patient screen rotation 45: "
            "give 0, 90, 180 or 270 (degrees))") in win.message.text()
    win.close()


def test_the_therapist_is_told_when_the_patient_s_letters_are_too_small(qtbot, window):
    patient = window.open_patient_screen()
    qtbot.waitExposed(patient, timeout=20000)
    mm_per_px = patient.mm_per_px()
    # a window too short for 20 mm letters, then one tall enough
    small = round(0.5 * 20.0 / mm_per_px / 0.7 * 1.3 / 0.14)
    patient.resize(4 * small, small)
    qtbot.waitUntil(lambda: "too small to read from 1.5 m" in window.message.text(),
                    timeout=20000)
    assert "put it full screen (F11)" in window.message.text()
    big = round(1.2 * 20.0 / mm_per_px / 0.7 * 1.3 / 0.14)
    patient.resize(2 * big, big)
    qtbot.waitUntil(lambda: "readable from 1.5 m" in window.message.text(), timeout=20000)
    assert not patient.screen_layout().letter_mm < 20.0


class _EndedPlan:
    """A plan runner whose run has just ended (app.plans.runner.PlanRunner's part the
    window reads)."""

    phase = "ended"
    trial_id = None

    def __init__(self, outcome: str) -> None:
        from core.plan import Block, Plan

        self.outcome = outcome
        self.plan = Plan("Session", (Block(shape="d", repetitions=1, duration_s=4.0),))
        self.blocks = self.plan.blocks  # as the run ran them (the window's Plan tab shows them)

    def tick(self, now: float) -> None:
        pass

    def state(self, now: float):
        from app.plans.runner import PlanState

        return PlanState("ended", 2, 2, "Path game", 3, 3, 2, 0, 54, 54, 0.0, 0.0,
                         self.outcome, "")


@pytest.mark.parametrize(("outcome", "words"), [("complete", "Session complete. Well done!"),
                                                ("stopped", "Stopped")])
def test_the_session_s_end_stays_on_the_patient_s_screen_until_the_next_build(
        qtbot, window, outcome, words):
    """The runner is let go as the plan ends, and the screen then showed only the last
    trial's end ("Well done! Score 20"): the session's end in the patient's words was
    never seen. It stays until the next trial is built."""
    from core.trial import THESIS_SUBJECT

    patient = window.open_patient_screen()
    qtbot.waitExposed(patient, timeout=20000)
    window.plan_runner = _EndedPlan(outcome)
    window._plan_tick()
    assert window.plan_runner is None
    window._feed_patient_screen()
    assert patient.plan is not None
    assert patient.plan.centre == words
    window._feed_patient_screen()  # and on the next repaint
    assert patient.plan.centre == words
    window.built = THESIS_SUBJECT  # the next Build
    window._feed_patient_screen()
    assert patient.plan is None


def _mid_trial_view(tmp_path):
    """A live view of a two-lap D as the window holds it in lap 2, while lap 1's result
    shows (no loop: the file's samples up to that moment)."""
    import numpy as np

    from app.trials.headless import simulate_to_file
    from app.trials.reader import read_trial
    from core.trial import THESIS_SUBJECT
    from device.recording.record import RECORD_DTYPE
    from ui.views.trialview import VIEW_CHANNELS, TrialView

    params = THESIS_SUBJECT.replace(repetitions=2, duration_s=2.0, assist="as-needed")
    path = tmp_path / "trial.h5"
    simulate_to_file(params, path, patient="healthy", seed=3)
    data = read_trial(path)
    rows = np.zeros(data.n_samples, dtype=[(c, RECORD_DTYPE.fields[c][0])
                                           for c in VIEW_CHANNELS])
    for name in VIEW_CHANNELS:
        rows[name] = data.channels[name]
    rows = rows[rows["phase"] > 0]
    exercise = rows["time"][rows["phase"] == 2][0]
    view = TrialView(data.parameters)
    view.append(rows[rows["time"] <= exercise + 2.3])
    return view


def _message(window) -> str:
    window._repaint()
    window.patient_window.grab()
    return window.patient_window.painted["message"]


def test_the_e_stop_says_stopped_on_the_patient_s_screen_at_once(qtbot, window, tmp_path,
                                                                monkeypatch):
    """Pressed mid-trial in the real window, the e-stop's banner came at once but the
    patient's screen went on saying "Lap 2 of 2" and the last lap's "Lap 1 done!" for
    0.4 s (measured under Xvfb), until the loop's first faulted record reached the live
    view: the robot gone limp under a screen that said all was well. It now follows the
    window's latch, as the banner does; Clear fault gives the trial's own words back.
    Here no record arrives after the press (no loop runs): the latch alone must say it."""
    from ui.views.patient_screen import CUE_STOPPED

    view = _mid_trial_view(tmp_path)
    monkeypatch.setattr(window.bridge, "estop", lambda on: None)
    window.live, window.built = view, view.parameters
    patient = window.open_patient_screen()
    qtbot.waitExposed(patient, timeout=20000)
    assert _message(window).startswith("Done!")  # the first lap's, the second under way
    window.emergency_stop()
    assert _message(window) == CUE_STOPPED
    assert not patient.frame.go
    assert not patient.frame.success
    window.clear_fault()
    assert _message(window).startswith("Done!")  # the first lap's, the second under way
    window.emergency_stop()  # with nothing shown but the exercise waiting, too
    window.live = None
    assert _message(window) == CUE_STOPPED


def test_a_trial_stopped_early_says_stopped_not_its_last_result(qtbot, window, tmp_path):
    """Stop pressed in lap 2 of 3 (seen under Xvfb): the patient's screen kept "Lap 2 of
    3", "0:07 left" and "Lap 1 done! Right on the path" until the next Build, as though the
    trial were still going. A trial the loop ended early now says "Stopped"; a complete
    one keeps its own end; the next trial starts clean."""
    from ui.views.patient_screen import CUE_STOPPED

    view = _mid_trial_view(tmp_path)
    window.live, window.built = view, view.parameters
    patient = window.open_patient_screen()
    qtbot.waitExposed(patient, timeout=20000)
    assert _message(window).startswith("Done!")  # the first lap's, the second under way
    window.bridge.trial_ended.emit(str(tmp_path / "trial.h5"), "stopped_early", {})
    assert _message(window) == CUE_STOPPED
    window.bridge.trial_started.emit(str(tmp_path / "next.h5"), 500, 1500)
    assert _message(window) != CUE_STOPPED
    window.bridge.trial_ended.emit(str(tmp_path / "next.h5"), "complete", {})
    assert _message(window) != CUE_STOPPED
