"""Closing the window while Start's trial (or Start plan's run) is being begun in the
registry (ui.window.start, ui.window.plan): the window closes without waiting for the
registry's answer (on a silent network it waited up to the bounded wait,
app.records.registry.postgres.deadline, the window frozen), and what the registry begins
for it is taken back on the job thread as the answer comes: no trial left 'recording', no
run left 'running'. The registry's call answers only once the test lets it (`Held`): a
close that waits for it returns only when the call gives up, after 30 s."""

from __future__ import annotations

import threading

import pytest

from tests.ui.held import BOUND_S, Held
from tests.ui.session import build_and_connect, click, open_window, register_patient, short_trial
from tests.ui.test_window_plan import PLAN, connected_with_plan

pytestmark = pytest.mark.slow


def _closed(win) -> None:
    win.closing_by_signal = True
    win.close()


def _nothing_registered(registry, code: str) -> None:
    assert registry.unfinished_trials() == []
    assert registry.trials_for_patient(code) == []
    folder = registry.data_dir.trials_dir / code
    assert not folder.exists() or list(folder.iterdir()) == []


def test_closing_while_start_registers_does_not_wait_and_the_trial_is_taken_back(
        qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    register_patient(qtbot, win)
    short_trial(win)
    build_and_connect(qtbot, win)
    code, registry = win.patient.code, win.registry
    held = Held(monkeypatch, registry, "begin_trial")
    click(qtbot, win.robot.buttons["start"])
    assert win.registering()
    assert held.asked.wait(BOUND_S)
    _closed(win)
    assert held.waited == [], "the window waited for the registry's answer as it closed"
    held.release()
    win.jobs.shutdown()  # as Python does before the process ends: the job thread's last job
    assert held.waited == [True]
    _nothing_registered(registry, code)


def test_closing_before_the_start_s_answer_is_taken_takes_the_trial_back(qtbot, tmp_path,
                                                                          monkeypatch):
    """The registry answered, the answer on its way to the window's thread (not yet
    taken) as the window closes: the trial it registered is taken back all the same."""
    win = open_window(qtbot, tmp_path, monkeypatch)
    register_patient(qtbot, win)
    short_trial(win)
    build_and_connect(qtbot, win)
    code, registry = win.patient.code, win.registry
    answered = threading.Event()
    begin = registry.begin_trial

    def begin_and_say(*args, **kwargs):
        begun = begin(*args, **kwargs)
        answered.set()
        return begun

    monkeypatch.setattr(registry, "begin_trial", begin_and_say)
    click(qtbot, win.robot.buttons["start"])
    assert answered.wait(BOUND_S)  # the window's thread takes no event meanwhile
    assert win.registering()
    _closed(win)
    win.jobs.shutdown()
    _nothing_registered(registry, code)


def test_closing_while_start_plan_begins_its_run_does_not_wait_and_the_run_is_ended(
        qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    code = connected_with_plan(qtbot, win, PLAN)
    registry = win.registry
    held = Held(monkeypatch, registry, "begin_plan_run")
    click(qtbot, win.plan_tab.start_button)
    assert held.asked.wait(BOUND_S)
    _closed(win)
    assert held.waited == [], "the window waited for the registry's answer as it closed"
    held.release()
    win.jobs.shutdown()
    (run,) = registry.plan_runs_for_patient(code)
    assert (run.status, run.end_reason, run.steps) == (
        "stopped", "the console closed before the plan's first round", ())
    assert registry.trials_for_patient(code) == []
