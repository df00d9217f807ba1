"""The Report tab shows the report of the trial on view, as the other tabs do: a trial
replayed from the patient's list (the registry's report, under the replay's strip), the
live trial's again once the therapist goes back to it, and the replayed one after a
restart. It kept the last live trial's report under a replay (or "The report appears here
once the trial is saved" after a restart), the replay's strip gone: the window showed one
trial replayed and another trial's report."""

from __future__ import annotations

import pytest

from tests.ui.session import click, window_with_trials
from ui.tabs.replay import load_view
from ui.tabs.report import WAITING

pytestmark = pytest.mark.slow

WAIT_MS = 30_000
"""A bound for a hang, never a measure of speed."""


@pytest.fixture
def two_trials(qtbot, tmp_path, monkeypatch):
    """A window whose patient has two registered trials, listed on the Replay tab."""
    win, begun = window_with_trials(qtbot, tmp_path, monkeypatch, WAIT_MS)
    yield win, begun
    win.close()


def _replay(qtbot, win, row: int) -> None:
    """Open the list's `row` (0: the newest) on the Replay tab, as the therapist does."""
    win.tabs.setCurrentWidget(win.replay)
    win.replay.trials.setCurrentRow(row)
    with qtbot.waitSignal(win.replay.view_loaded, timeout=WAIT_MS):
        click(qtbot, win.replay.open_selected)


def _report_of(qtbot, win, begun) -> None:
    """Wait for the Report tab to show the registry's report of `begun`, said by number."""
    trial = win.registry.trial(begun.trial_id)
    qtbot.waitUntil(lambda: win.report.content is not None
                    and win.report.content.source == begun.path, timeout=WAIT_MS)
    assert win.report.registry_trial() == begun.trial_id  # with its comparisons
    assert win.report.message.text() == \
        f"Report of session {trial.session_number}, trial {trial.number}"


def test_the_report_follows_the_replay_and_back_to_the_live_trial(qtbot, two_trials):
    win, (older, newer) = two_trials
    # the newer trial just ran live: the window shows it and its report (_finalized)
    win.live = win.shown_view = load_view(newer.path)
    win.live_report = newer.trial_id
    win.report.load_registry_trial(win.registry, newer.trial_id)
    _report_of(qtbot, win, newer)

    _replay(qtbot, win, 1)  # the older one
    win.tabs.setCurrentWidget(win.report)
    _report_of(qtbot, win, older)
    assert win.replay_strip.isVisible(), "the Report tab hid the replay's strip"

    click(qtbot, win.back_to_live)
    _report_of(qtbot, win, newer)
    assert not win.replay_strip.isVisible()


def test_after_a_restart_the_report_is_the_replayed_trial_s(qtbot, two_trials):
    win, (older, _newer) = two_trials
    win.tabs.setCurrentWidget(win.report)
    assert win.report.message.text() == WAITING  # nothing on view yet
    _replay(qtbot, win, 1)
    win.tabs.setCurrentWidget(win.report)
    _report_of(qtbot, win, older)
    assert win.replay_strip.isVisible()


def test_a_replay_loaded_while_the_report_is_shown_replaces_its_report(qtbot, two_trials):
    win, (older, newer) = two_trials
    _replay(qtbot, win, 0)
    win.tabs.setCurrentWidget(win.report)
    _report_of(qtbot, win, newer)
    with qtbot.waitSignal(win.replay.view_loaded, timeout=WAIT_MS):
        win.replay.open_file(older.path)  # a file: its report built from the file alone
    qtbot.waitUntil(lambda: win.report.content is not None
                    and win.report.content.source == older.path, timeout=WAIT_MS)
