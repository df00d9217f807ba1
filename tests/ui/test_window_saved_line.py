"""The therapist hears when a trial is saved (ui.views.saved): once its file is finished,
registered and read back, the message line and its History say so once, with the trial's
number, its file and where its report is; a trial whose finishing failed is said with its
cause and what becomes of it. Before, nothing was said when a trial was saved, and a failed
finish was the bare error, naming no trial."""

from __future__ import annotations

import pytest

from app.errors import AppError
from device.loop.states import State
from tests.ui.session import (
    build_connect_start,
    ended_window,
    register_patient,
    short_trial,
)

pytestmark = pytest.mark.slow

WAIT_MS = 60_000
"""A bound for a hang, never a measure of speed."""


@pytest.fixture
def win(qtbot, tmp_path, monkeypatch):
    yield from ended_window(qtbot, tmp_path, monkeypatch)


def _said(win, words: str) -> list[str]:
    return [line for line in win.messages.history() if words in line]


def test_a_saved_trial_is_said_once_with_its_file_and_report(qtbot, win):
    register_patient(qtbot, win)
    short_trial(win, 1.5)
    build_connect_start(qtbot, win)
    trial_id = win.trial_id
    qtbot.waitUntil(lambda: win.unsaved_trial == trial_id, timeout=WAIT_MS)
    trial = win.registry.trial(trial_id)
    said = _said(win, "Trial 1 of session 1 saved (complete)")
    assert len(said) == 1, win.messages.history()
    assert trial.file.rsplit("/", 1)[-1] in said[0]
    assert "registered and read back whole" in said[0]
    assert "Report tab" in said[0]
    assert not win.messages.last.problem
    assert win.message.text().startswith("Trial 1 of session 1 saved")


def test_a_trial_whose_finish_failed_is_said_with_its_cause(qtbot, win, monkeypatch):
    import app.trials.finalize as finalize

    def disk_gone(*_args, **_kwargs):
        raise AppError("the data disk is not mounted")

    monkeypatch.setattr(finalize, "finalize_trial", disk_gone)
    register_patient(qtbot, win)
    short_trial(win, 1.5)
    build_connect_start(qtbot, win)
    qtbot.waitUntil(lambda: win.state == State.CONNECTED and win.trial_id is None
                    and not win._finishing, timeout=WAIT_MS)
    qtbot.waitUntil(lambda: bool(_said(win, "was not saved")), timeout=WAIT_MS)
    (line,) = _said(win, "was not saved")
    assert "(session 1, trial 1) was not saved into the registry: the data disk is not " \
           "mounted" in line
    assert "finishes it from the file when it next starts" in line
    assert win.messages.last.problem
    assert not _said(win, "saved (")  # never said saved
