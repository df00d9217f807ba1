"""The Plan tab shows the blocks as the plan's run runs them: the console's proposal after
a trial applies to a later block of the same exercise (app.plans.runner), and the table
said the plan's 4 s a lap while the robot ran block 3 at the proposal's 4.5 s. The changed
cells are marked, a line under the table names them, and after the run the table shows
what ran, also once the stored plan is read again. No loop runs: the runner is the window's
as Start plan makes it, its blocks changed as a proposal changes them."""

from __future__ import annotations

import pytest

from app.plans.runner import PlanRunner
from core.plan import Block, Plan
from core.trial import THESIS_SUBJECT
from tests.ui.session import window_with_plan

pytestmark = pytest.mark.slow

WAIT_MS = 30_000
"""A bound for a hang, never a measure of speed."""
PACE = 5  # the table's "Pace (s a lap)" column

PLAN = Plan("Three blocks", (
    Block(shape="d", repetitions=1, duration_s=4.0, rest_s=1.0, name="D"),
    Block(shape="circle", repetitions=1, duration_s=4.0, rest_s=1.0, radius_m=0.08,
          name="Circle"),
    Block(shape="d", repetitions=1, duration_s=4.0, rest_s=0.0, name="D again"),
))


class Console:
    """A console that only listens (the runner never gets past its first Build here)."""

    def __getattr__(self, _name):
        return lambda *args: None


def test_the_table_shows_the_blocks_as_the_run_runs_them(qtbot, tmp_path, monkeypatch):
    win = window_with_plan(qtbot, tmp_path, monkeypatch, PLAN, WAIT_MS)
    code = win.patient.code
    tab = win.plan_tab
    assert tab.table.item(2, PACE).text() == "4"
    stored = tab.plan

    runner = PlanRunner(stored, THESIS_SUBJECT, Console())
    # the proposal after block 1's trial, taken for block 3 (the same exercise)
    runner.blocks[2] = runner.blocks[2].replace(duration_s=4.5, assistance_level=0.4)
    win.plan_runner = runner
    win._plan_tick()  # what the plan's timer and each of the loop's answers call
    assert tab.table.item(2, PACE).text() == "4.5", "the table said the plan's pace"
    assert tab.table.item(2, PACE).font().bold()
    assert not tab.table.item(0, PACE).font().bold()
    line = tab.run_changes.text()
    assert line.startswith("Changed in this run by the console's proposal: block 3, ")
    assert "pace (s a lap) 4.5 (planned 4)" in line
    assert "level (%) 40" in line
    assert "block 1" not in line
    assert "block 2" not in line

    # the run over: the stored plan read again, the table still says what ran
    win.plan_runner = None
    win.show_plan_of(code)
    qtbot.waitUntil(lambda: not win.plan_waiting(), timeout=WAIT_MS)
    assert tab.table.item(2, PACE).text() == "4.5"
    # another plan (a block changed in the table is saved as a new plan): its own blocks
    win.registry.save_plan(code, Plan(PLAN.name, (*PLAN.blocks[:2],
                                                  PLAN.blocks[2].replace(rest_s=2.0))))
    win.show_plan_of(code)
    qtbot.waitUntil(lambda: not win.plan_waiting() and tab.plan != stored, timeout=WAIT_MS)
    assert tab.table.item(2, PACE).text() == "4"
    assert tab.run_changes.text() == ""
    win.close()
