"""Replay's trial opened from the patient's list: the registry read that finds its file
runs on the window's job thread (ui.jobs), as the Assessments tab's figures do
(tests/ui/test_window_assessments_waits.py). It ran on the window's thread, and the list
marking the trial shown read the registry once per row there too: on a shared registry
whose network went silent each call held the window for its bounded wait. Here each
registry call answers only once the test lets it (tests/ui/held.py): a window that waits
for it on its own thread never returns to the test (the call gives up after 30 s, a
bound for a hang, never a measure of speed). Meanwhile the tab says "Loading…"; an answer
no longer wanted is never shown; a registry gone is said with its cause; closing does
not wait."""

from __future__ import annotations

import pytest
from PySide6.QtCore import Qt

from app.errors import RegistryUnreachable
from tests.ui.held import BOUND_S, Held
from tests.ui.session import click, window_with_trials
from ui.tabs.replay import LOADING

pytestmark = pytest.mark.slow

WAIT_MS = int(BOUND_S * 1000)
"""A bound for a hang, never a measure of speed."""


@pytest.fixture
def listed(qtbot, tmp_path, monkeypatch):
    """A window on the Replay tab, its patient's two trials listed (the newest first)."""
    win, begun = window_with_trials(qtbot, tmp_path, monkeypatch, WAIT_MS)
    win.tabs.setCurrentWidget(win.replay)
    yield win, begun
    win.close()


def _ask_open(qtbot, win, row: int, held: Held) -> None:
    """Open the list's `row` as the therapist does, the registry's answer held."""
    win.replay.trials.setCurrentRow(row)
    click(qtbot, win.replay.open_selected)
    qtbot.waitUntil(held.asked.is_set, timeout=WAIT_MS)
    assert held.waited == [], "the window read the trial on its own thread"
    assert win.replay.info.text().startswith(LOADING)


def test_a_trial_is_opened_off_the_window_thread(qtbot, listed, monkeypatch):
    win, begun = listed
    held = Held(monkeypatch, win.registry, "trial")
    _ask_open(qtbot, win, 1, held)  # the oldest
    with qtbot.waitSignal(win.replay.view_loaded, timeout=WAIT_MS) as loaded:
        held.release()
    assert loaded.args[0].source == begun[0].path
    assert held.waited == [True], "the window read the registry on its own thread"
    assert win.replay.trials.currentRow() == 1  # marked without reading the registry


def test_an_answer_no_longer_wanted_is_not_shown(qtbot, listed, monkeypatch):
    """The first trial asked for, then the other opened as a file meanwhile: the first's
    answer is dropped, the file's view stays."""
    win, begun = listed
    held = Held(monkeypatch, win.registry, "trial")
    _ask_open(qtbot, win, 1, held)
    shown = []
    win.replay.view_loaded.connect(lambda view: shown.append(view.source))
    win.replay.open_file(begun[1].path)
    qtbot.waitUntil(lambda: shown == [begun[1].path], timeout=WAIT_MS)
    held.release()
    qtbot.waitUntil(lambda: held.waited == [True], timeout=WAIT_MS)
    after: list[object] = []
    win.jobs.run(lambda: None, after.append)  # answered after the held read's answer
    qtbot.waitUntil(lambda: after == [None], timeout=WAIT_MS)
    assert not win.replay.opening()
    assert shown == [begun[1].path]
    assert win.replay.view.source == begun[1].path


def test_a_registry_gone_is_said_with_what_to_do(qtbot, listed, monkeypatch):
    win, _ = listed

    def unreachable(_trial_id):
        raise RegistryUnreachable("cannot reach the registry's server (test)")

    monkeypatch.setattr(win.registry, "trial", unreachable)
    win.replay.trials.setCurrentRow(0)
    with qtbot.waitSignal(win.replay.load_failed, timeout=WAIT_MS) as failed:
        click(qtbot, win.replay.open_selected)
    said = ("The trial could not be read from the registry: cannot reach the registry's "
            "server (test). Open it again.")
    assert failed.args[0] == said
    assert win.replay.info.text().endswith(said)
    assert not win.replay.opening()


def test_closing_while_a_trial_is_read_does_not_wait(qtbot, listed, monkeypatch):
    win, _ = listed
    held = Held(monkeypatch, win.registry, "trial")
    _ask_open(qtbot, win, 0, held)
    win.close()
    assert held.waited == [], "closing waited for the trial's read"
    held.release()
    win.jobs.shutdown(wait=True)  # the job thread ends after the read
    assert held.waited == [True]


def test_the_list_s_rows_hold_their_files(qtbot, listed):
    """Each row knows its trial's file (the mark needs no registry read)."""
    win, begun = listed
    paths = [win.replay.trials.item(r).data(Qt.ItemDataRole.UserRole + 1)
             for r in range(2)]
    assert paths == [begun[1].path, begun[0].path]


def test_the_list_read_again_meanwhile_keeps_or_says_the_trial_asked_for(qtbot, listed,
                                                                         monkeypatch):
    """The list read again while a trial is being found (after a trial, the same patient's
    ids kept): the trial still opens. Read again after a station's sync (the ids may be
    the server's now): the ask is dropped, and the tab says so; it said "Loading…" for
    ever."""
    win, begun = listed
    code = win.patient.code
    held = Held(monkeypatch, win.registry, "trial")
    _ask_open(qtbot, win, 1, held)
    # the window's list after a trial
    win.replay.set_patient(code, win.registry.trials_for_patient(code))
    with qtbot.waitSignal(win.replay.view_loaded, timeout=WAIT_MS) as loaded:
        held.release()
    assert loaded.args[0].source == begun[0].path

    held = Held(monkeypatch, win.registry, "trial")
    _ask_open(qtbot, win, 0, held)
    win.replay.show_loading(code)  # the list read again after a sync
    assert not win.replay.opening()
    assert win.replay.info.text() == ("The list of trials is being read again: choose the "
                                      "trial again once it is shown.")
    held.release()
    after: list[object] = []
    win.jobs.run(lambda: None, after.append)
    qtbot.waitUntil(lambda: after == [None], timeout=WAIT_MS)
    assert win.replay.view.source == begun[0].path  # the one shown before, kept
