"""The event line says what is true now: "Start needs a registered patient…" said as the
robot connected gives way once the patient is confirmed (it stayed over a green Start); a
Start plan refusal leaves the line once the plan is changed (it stayed over the changed
plan); the plan's end line is a sentence before the next ("Plan complete (…) The
Parameters tab…" had no full stop); an assessment set up names only the robot buttons
that apply ("press Build, Connect and Start" to a connected robot, Connect greyed)."""

from __future__ import annotations

import pytest

from app.plans.runner import ENDED, PlanRunner
from core.plan import Block, Plan
from core.trial import THESIS_SUBJECT
from device.loop.states import State
from tests.ui.session import (
    click,
    open_window,
    register_patient,
    short_trial,
    window_with_plan,
)

pytestmark = pytest.mark.slow

WAIT_MS = 60_000
"""A bound for a hang, never a measure of speed."""
PLAN = Plan("Two blocks", (
    Block(shape="d", repetitions=1, duration_s=4.0, rest_s=1.0, name="D"),
    Block(shape="circle", repetitions=1, duration_s=4.0, rest_s=0.0, radius_m=0.08,
          name="Circle"),
))


class Console:
    """A console that only listens."""

    def __getattr__(self, _name):
        return lambda *args: None


def test_start_s_need_gives_way_once_met_and_an_assessment_names_the_buttons_that_apply(
        qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    register_patient(qtbot, win)
    tab = win.registration_tab
    tab.trial.setValue(tab.trial.value() + 1)  # a number edited: no longer confirmed
    tab.trial.setValue(tab.trial.value() - 1)
    assert win.registration is None
    short_trial(win)
    click(qtbot, win.robot.buttons["build"])
    qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=WAIT_MS)
    win.set_up_assessment("circle", 0)
    assert win.message.text().endswith("press Build, Connect and Start.")
    short_trial(win)
    click(qtbot, win.robot.buttons["build"])
    qtbot.waitUntil(lambda: win.state == State.BUILT and not win.stale(), timeout=WAIT_MS)
    click(qtbot, win.robot.buttons["connect"])
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=WAIT_MS)
    assert "Start needs a registered patient" in win.message.text()

    win.tabs.setCurrentWidget(tab)
    click(qtbot, tab.confirm)  # the patient confirmed: Start's need met
    qtbot.waitUntil(lambda: win.robot.buttons["start"].isEnabled(), timeout=WAIT_MS)
    assert "Start needs" not in win.message.text(), "the met need stayed on the line"
    assert win.message.text() == "Start when ready."
    assert "Start needs a registered patient" in "\n".join(win.messages.history())

    win.set_up_assessment("circle", 0)  # connected: Connect is greyed
    assert not win.robot.buttons["connect"].isEnabled()
    assert win.message.text().endswith("press Build and Start.")
    win.close()


def test_a_start_plan_refusal_leaves_the_line_once_the_plan_is_changed(
        qtbot, tmp_path, monkeypatch):
    win = window_with_plan(qtbot, tmp_path, monkeypatch, PLAN, WAIT_MS)
    click(qtbot, win.plan_tab.start_button)  # the robot not connected
    assert win.message.text().startswith("⚠ Start plan refused:")
    before = win.stored_plan.id
    win.plan_tab.table.item(0, 5).setText("5")  # block 1's pace, as typed in its cell
    qtbot.waitUntil(lambda: not win.plan_waiting() and win.stored_plan.id != before,
                    timeout=WAIT_MS)
    assert "Start plan refused" not in win.message.text(), "the refusal stayed"
    win.close()


def test_the_plan_s_end_line_is_a_sentence_before_the_form_s(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    register_patient(qtbot, win)
    code = win.patient.code
    runner = PlanRunner(PLAN, THESIS_SUBJECT, Console())
    runner.phase, runner.outcome = ENDED, "complete"  # as the run's last trial leaves it
    win.plan_runner = runner
    win.plan_form_before = (code, win.parameters_tab.parameters())
    win._plan_tick()  # what the plan's timer calls
    line = win.message.text()
    assert line.startswith("Plan complete (")
    assert "movements). The Parameters tab is back" in line
    win.close()
