"""The trial is registered under the patient and the numbers the Registration tab shows
confirmed (one truth, the patient chooser): another patient chosen or a number edited
after Confirm used to leave the window's registration as it was, so Start stayed green
and registered the trial under the patient chosen since with the numbers confirmed for
the one before, or under a session the tab no longer showed."""

from __future__ import annotations

import pytest

from device.loop.states import State
from tests.ui.session import click, enabled, ended_window, register_patient, short_trial
from tests.ui.test_window_truth import _connected

pytestmark = pytest.mark.slow


@pytest.fixture
def win(qtbot, tmp_path, monkeypatch):
    yield from ended_window(qtbot, tmp_path, monkeypatch)


def _new_patient(qtbot, win):
    """A second patient with the first one's measurements (the form does not change, so
    the trial built stays what it shows), registered but not confirmed."""
    tab = win.registration_tab
    win.tabs.setCurrentWidget(tab)
    qtbot.keyClicks(tab.first_name, "Grace")
    qtbot.keyClicks(tab.last_name, "Hopper")
    for box, value in ((tab.body_mass, 70.0), (tab.upper_arm, 30.0), (tab.forearm, 28.0),
                       (tab.shoulder_x, -12.0), (tab.shoulder_y, 73.0)):
        box.setValue(value)
    click(qtbot, tab.create_button)
    qtbot.waitUntil(lambda: getattr(tab.selected_patient(), "first_name", "") == "Grace",
                    timeout=60000)
    return tab.selected_patient()


def test_start_waits_for_confirm_after_the_registration_changed(qtbot, win):
    register_patient(qtbot, win)  # Ada, session 1, trial 1, confirmed
    ada = win.patient
    tab = win.registration_tab
    short_trial(win)
    _connected(qtbot, win)
    assert "start" in enabled(win)

    # a new session typed, not confirmed: Start would register session 1
    tab.session.setValue(2)
    assert tab.registration() is None
    assert "start" not in enabled(win)
    assert "Registration tab" in win.robot.why.whole
    win.start_trial()  # as F5 would
    assert win.trial_id is None
    assert not win.registry.trials_for_patient(ada.code)

    # Confirm refuses session 2 of a patient with none (Start would: a gap); session 1 again
    with qtbot.assertNotEmitted(tab.registered):
        click(qtbot, tab.confirm)
        qtbot.waitUntil(lambda: tab.trial_problem.isVisible(), timeout=60000)
    assert "session 2 would leave a gap; use 1" in tab.trial_problem.text()
    tab.session.setValue(1)
    assert tab.registration() is None

    # another patient chosen, not confirmed: Start would register Grace under Ada's numbers
    click(qtbot, tab.confirm)
    qtbot.waitUntil(lambda: "start" in enabled(win), timeout=60000)
    grace = _new_patient(qtbot, win)
    assert win.patient == grace
    assert not win.stale()
    assert "start" not in enabled(win)
    win.start_trial()
    assert win.trial_id is None
    assert not win.registry.trials_for_patient(grace.code)

    # confirmed: Start registers what the tab shows
    tab.session.setValue(1)
    with qtbot.waitSignal(tab.registered, timeout=60000):
        click(qtbot, tab.confirm)
    qtbot.waitUntil(lambda: "start" in enabled(win), timeout=60000)
    shown = tab.registration()
    assert shown.patient_code == grace.code
    click(qtbot, win.robot.buttons["start"])
    qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=60000)
    trial_id = win.trial_id
    qtbot.waitUntil(lambda: win.unsaved_trial == trial_id, timeout=60000)
    trial = win.registry.trial(trial_id)
    assert (trial.patient_code, trial.session_number, trial.number) == (
        grace.code, shown.session_number, shown.trial_number)


def test_a_patient_chosen_during_a_trial_is_not_offered_its_proposal(qtbot, win):
    """The proposal after a trial is its patient's: one chosen while the trial ran was
    offered the trial's patient's proposal (Use the proposal put it into their form)."""
    register_patient(qtbot, win)
    ada = win.patient
    p = win.parameters_tab
    p.repetitions.setValue(2)
    p.duration.setValue(2.0)
    p.refresh()
    _connected(qtbot, win)
    click(qtbot, win.robot.buttons["start"])
    qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=60000)
    trial_id = win.trial_id
    grace = _new_patient(qtbot, win)
    qtbot.waitUntil(lambda: win.unsaved_trial == trial_id, timeout=60000)
    assert win.registry.proposal(trial_id) is not None  # Ada's, waiting for her next trial
    assert win.registry.pending_proposal(ada.code) is not None
    assert win.registry.pending_proposal(grace.code) is None
    assert win.patient == grace
    assert p.proposal.isHidden(), p.proposal_text.text()
