"""The patient's screen beside a live trial (issue 30), end to end: the console's window,
the real loop and recorder processes on the simulator, the patient's window open on it. Every
frame the screen showed during the trial is kept with the trial time of its sample; after the
trial, the file the recorder wrote must hold the hand and the reference exactly where the
screen drew them at those times, and "Go!" must have shown from the exercise's first sample
for GO_SHOWN_S, never before it."""

import numpy as np
import pytest

from app.trials.reader import read_trial
from device.loop.pipeline import PHASE_EXERCISE
from device.loop.states import State
from tests.ui.session import build_connect_start, open_window, register_patient, short_trial
from ui.views.patient_screen import GO_SHOWN_S

pytestmark = pytest.mark.slow


def test_the_screen_beside_a_live_trial_shows_what_the_file_holds(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        register_patient(qtbot, win)
        short_trial(win)
        patient = win.open_patient_screen()
        qtbot.waitExposed(patient, timeout=20000)
        shown = []
        original = patient.show_view

        def show_view(view, *args):
            original(view, *args)
            frame = patient.frame
            if frame.sample >= 0:
                shown.append((float(view.time[frame.sample]), frame))

        patient.show_view = show_view
        build_connect_start(qtbot, win)
        qtbot.waitUntil(lambda: win.unsaved_trial is not None, timeout=120000)
        assert win.state != State.RUNNING
        trial = win.registry.trial(win.unsaved_trial)
        data = read_trial(win.registry.trial_path(trial))
    finally:
        win.close()
    assert data.status == "complete"
    # how many frames the 16 ms repaint showed depends on this machine's pace: every one
    # is checked, and at least one fell in the exercise
    time = data.time
    t0 = float(time[np.flatnonzero(data.channels["phase"] == PHASE_EXERCISE)[0]])
    for t, frame in shown:
        i = int(np.searchsorted(time, t))
        assert time[i] == t  # a sample of the file
        np.testing.assert_array_equal(frame.cursor_m, data.channels["position"][i])
        np.testing.assert_array_equal(frame.target_m, data.channels["position_desired"][i])
        assert frame.go == (t0 <= t < t0 + GO_SHOWN_S)
        if t >= t0:
            assert frame.exercise_started_s == t0
    assert any(t >= t0 for t, _ in shown)
