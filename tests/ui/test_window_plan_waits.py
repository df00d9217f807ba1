"""The plan's registry calls on the job thread (ui.window.plan): reading the patient's plan,
copying a template, changing a block and beginning a run. On a shared registry whose
network drops everything each held the window for its bounded wait
(app.records.registry.postgres.deadline). Here each registry call answers only once the
test lets it (tests/ui/held.py): a window that waits for it on its own thread never returns to the
test, and the call gives up after 30 s (a bound for a hang, never a measure of speed).
Meanwhile the Plan tab says what it waits for and Start plan, Copy and the table wait; an
answer made stale (another patient chosen, the robot gone) is never shown nor run."""

from __future__ import annotations

import pytest
from PySide6.QtWidgets import QApplication

from app.plans.templates import load_template
from device.loop.states import State
from tests.ui.held import BOUND_S, Held
from tests.ui.session import click, ended_window, open_window, register_patient
from tests.ui.test_window_plan import PLAN, connected_with_plan, shown

pytestmark = pytest.mark.slow


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):
    yield from ended_window(qtbot, tmp_path, monkeypatch)


def _waits(win, words: str) -> None:
    tab = win.plan_tab
    assert tab.waiting == words
    assert tab.waiting_line.text() == words
    assert not tab.start_button.isEnabled()
    assert not tab.copy_button.isEnabled()
    assert not tab.table.isEnabled()


def test_the_plan_is_read_copied_and_changed_off_the_window_s_thread(qtbot, tmp_path,
                                                                    monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        register_patient(qtbot, win)
        shown(qtbot, win)
        code, tab = win.patient.code, win.plan_tab
        registry = win.registry
        # a template copied: saved, then read back
        saved = Held(monkeypatch, registry, "save_plan")
        tab.templates.setCurrentText("First session")
        click(qtbot, tab.copy_button)
        _waits(win, f"Copying the template to patient {code}…")
        saved.release()
        shown(qtbot, win)
        assert saved.waited == [True], "the window waited for the copy"
        assert tab.table.rowCount() == 3
        assert tab.start_button.isEnabled()
        assert tab.waiting_line.text() == ""
        first = registry.current_plan(code)
        # a block changed: Start plan cannot start the plan before it (the table shows the
        # change) nor a plan half saved
        changed = Held(monkeypatch, registry, "change_block")
        tab.table.item(1, 9).setText("30")  # the circle's rest, s
        _waits(win, "Saving the change to block 2…")
        win.start_plan()  # as if pressed
        assert tab.refusal.text().startswith("Start plan refused: the plan is not shown "
                                             "yet (Saving the change to block 2)")
        tab.table.item(0, 9).setText("45")  # another change, not by the greyed table
        assert tab.refusal.text().startswith("Not changed: the plan is not shown yet")
        assert tab.table.item(0, 9).text() == "60"  # the cell shows the plan again
        assert win.plan_runner is None
        changed.release()
        shown(qtbot, win)
        assert changed.waited == [True], "the window waited for the change"
        today = registry.current_plan(code)
        assert (today.based_on, today.plan.blocks[1].rest_s) == (first.id, 30.0)
        assert win.stored_plan == today
        assert tab.title.text().startswith(f"Plan {today.id} of patient {code}")
        # the plan read again
        read = Held(monkeypatch, registry, "current_plan")
        win.show_plan_of(code)
        _waits(win, f"Reading patient {code}'s plan…")
        read.release()
        shown(qtbot, win)
        assert read.waited == [True], "the window waited for the plan's read"
        assert tab.start_button.isEnabled()
    finally:
        win.close()


def test_a_plan_copied_for_a_patient_no_longer_chosen_is_not_shown(qtbot, tmp_path,
                                                                  monkeypatch):
    """The copy's answer comes after another patient was chosen: the tab shows that
    patient's plan as it is read, never the first patient's, which Start plan would run."""
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        register_patient(qtbot, win)
        shown(qtbot, win)
        first = win.patient.code
        other = win.registry.create_patient("Grace", "Hopper", body_mass_kg=60.0,
                                            upper_arm_m=0.29, forearm_m=0.27,
                                            shoulder_m=(-0.12, 0.73))
        saved = Held(monkeypatch, win.registry, "save_plan")
        read_other = Held(monkeypatch, win.registry, "current_plan", code=other.code)
        click(qtbot, win.plan_tab.copy_button)
        win.registration_tab.choose(other)  # her record read (on the job thread) after
        # the copy, then her plan asked for
        saved.release()
        # the copy saved and its plan read: its answer is given to the window before the
        # other's read begins
        qtbot.waitUntil(read_other.asked.is_set, timeout=BOUND_S * 1000)
        QApplication.processEvents()
        assert win.stored_plan is None, "the first patient's plan shown for the other"
        _waits(win, f"Reading patient {other.code}'s plan…")
        read_other.release()
        shown(qtbot, win)
        assert win.stored_plan is None
        assert win.plan_tab.title.text() == (f"Patient {other.code} has no plan yet: copy a "
                                             "template to them.")
        assert win.registry.current_plan(first).plan == load_template("endurance").plan
    finally:
        win.close()


@pytest.mark.parametrize("meanwhile", ["emergency stop", "another patient"])
def test_a_plan_run_begun_for_a_start_plan_that_cannot_go_on_is_ended(qtbot, window,
                                                                      monkeypatch, meanwhile):
    win = window
    code = connected_with_plan(qtbot, win, PLAN)
    begun = Held(monkeypatch, win.registry, "begin_plan_run")
    click(qtbot, win.plan_tab.start_button)
    _waits(win, "Starting the plan…")
    assert win.plan_runner is None
    if meanwhile == "emergency stop":
        win.emergency_stop()
        gone = "press clear fault"  # the emergency stop or the fault it latched
    else:
        other = win.registry.create_patient("Grace", "Hopper")
        win.registration_tab.choose(other)  # nobody confirmed while her record loads
        gone = "another patient"  # chosen before the plan started, or while it was begun
    begun.release()
    qtbot.waitUntil(lambda: [r.status for r in win.registry.plan_runs_for_patient(code)]
                    == ["stopped"], timeout=20000)
    shown(qtbot, win)
    assert begun.waited == [True]
    (run,) = win.registry.plan_runs_for_patient(code)
    assert run.steps == ()
    assert gone in run.end_reason.lower(), run.end_reason
    assert win.plan_runner is None
    assert win.registry.trials_for_patient(code) == []
    if meanwhile == "emergency stop":
        assert win.plan_tab.refusal.text().startswith("Start plan refused: ")
        # the loop latches the e-stop at its next tick and says so through its pipe: on a
        # stalled host that can come after the run's end (failed once in a parallel run)
        qtbot.waitUntil(lambda: win.state == State.FAULTED, timeout=20000)
