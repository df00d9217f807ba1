"""What the patient's screen showed is part of the trial's record (feedback changes how a
patient learns): the file says at its start whether the screen was open and with which
options, and at its tick each change the therapist made while the trial ran, end to end
through the window, the real loop and the recorder on the simulator."""

import pytest

from app.trials.reader import read_trial
from device.loop.states import State
from tests.ui.session import build_connect_start, open_window, register_patient, short_trial

pytestmark = pytest.mark.slow


def _shown(qtbot, win) -> list[dict]:
    """The file's patient_screen events of the trial just run."""
    qtbot.waitUntil(lambda: win.unsaved_trial is not None)
    assert win.state != State.RUNNING
    data = read_trial(win.registry.trial_path(win.registry.trial(win.unsaved_trial)))
    assert data.status == "complete"
    return [e for e in data.events if e["kind"] == "patient_screen"]


def test_the_file_says_what_the_patient_s_screen_showed_and_when_it_changed(
        qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        register_patient(qtbot, win)
        short_trial(win)
        win.set_patient_options(rotation_deg=90, previous_path=False)
        qtbot.waitExposed(win.open_patient_screen())
        build_connect_start(qtbot, win)
        win.set_patient_options(mirror=True)  # while the trial runs
        win.set_patient_options(mirror=True)  # no change: nothing recorded
        win.close_patient_screen()
        shown = _shown(qtbot, win)
        win.set_patient_options(show_numbers=True)  # between trials: no trial's record
    finally:
        win.close()
    start, mirrored, closed = shown
    assert start["tick"] == 0
    assert start["values"] == {"open": True, "mirror": False, "rotation_deg": 90,
                               "show_numbers": False, "previous_path": False, "sound": False}
    assert start["message"].startswith("patient's screen open: turned 90° anticlockwise")
    assert "path hidden" in start["message"]
    assert 0 <= mirrored["tick"] <= closed["tick"]
    assert mirrored["values"] == {**start["values"], "mirror": True}
    assert "mirrored" in mirrored["message"]
    assert closed["values"] == {**mirrored["values"], "open": False}
    assert closed["message"] == "patient's screen closed"


def test_a_trial_without_the_patient_s_screen_says_it_was_closed(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        register_patient(qtbot, win)
        short_trial(win, duration_s=1.5)
        build_connect_start(qtbot, win)
        shown = _shown(qtbot, win)
    finally:
        win.close()
    assert [(e["tick"], e["values"]["open"], e["message"]) for e in shown] == [
        (0, False, "patient's screen closed")]


def test_a_change_made_while_start_registers_is_what_the_file_says(qtbot, tmp_path,
                                                                   monkeypatch):
    """The screen changed after Start was pressed, before the registry answered (on a
    shared registry whose network drops everything, up to its bounded wait): the file said
    what the screen showed at the press, and no event the change, while the patient saw
    the change through the whole trial. The file now takes the screen as the trial starts."""
    from tests.ui.held import BOUND_S, Held
    from tests.ui.session import build_and_connect, click

    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        register_patient(qtbot, win)
        short_trial(win, duration_s=1.5)
        qtbot.waitExposed(win.open_patient_screen())
        build_and_connect(qtbot, win)
        held = Held(monkeypatch, win.registry, "begin_trial")
        click(qtbot, win.robot.buttons["start"])
        assert held.asked.wait(BOUND_S)
        assert win.registering()
        win.set_patient_options(mirror=True, rotation_deg=180)  # while it registers
        held.release()
        shown = _shown(qtbot, win)
        screen = win.patient_window.options
    finally:
        win.close()
    assert held.waited == [True]
    (start,) = shown
    assert start["tick"] == 0
    assert start["values"] == {"open": True, "mirror": True, "rotation_deg": 180,
                               "show_numbers": False, "previous_path": True, "sound": False}
    assert (screen.mirror, screen.rotation_deg) == (True, 180)  # what the patient saw
