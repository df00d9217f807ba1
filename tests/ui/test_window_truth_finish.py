"""Start waits until the last trial is finished into the registry (one truth, the
finish): a Start pressed as soon as the last trial's file closed registered the next
trial before the last one's proposal was made, so that proposal stayed pending for good,
never decided by the trial after it, and the registry did not say whether it was taken."""

from __future__ import annotations

import pytest

from device.loop.states import State
from tests.ui.session import click, enabled, ended_window, register_patient, short_trial
from tests.ui.test_window_truth import _connected

pytestmark = pytest.mark.slow


@pytest.fixture
def win(qtbot, tmp_path, monkeypatch):
    yield from ended_window(qtbot, tmp_path, monkeypatch)


def test_the_next_start_decides_the_last_trial_s_proposal(qtbot, win):
    register_patient(qtbot, win)
    short_trial(win, 1.5)
    _connected(qtbot, win)
    click(qtbot, win.robot.buttons["start"])
    qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=60000)
    first = win.trial_id
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=60000)
    # Start as soon as it is green (F5 pressed the moment the trial ended)
    qtbot.waitUntil(lambda: "start" in enabled(win), timeout=60000)
    assert win.registry.proposal(first) is not None, "Start before the trial was saved"
    click(qtbot, win.robot.buttons["start"])
    qtbot.waitUntil(lambda: win.trial_id not in (None, first), timeout=60000)
    second = win.trial_id
    qtbot.waitUntil(lambda: win.unsaved_trial == second, timeout=60000)
    made = win.registry.proposal(first)
    assert made.decision == "kept"  # the same parameters again
    assert made.next_trial_id == second
    assert win.registry.pending_proposal(win.patient.code).trial_id == second
