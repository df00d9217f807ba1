"""The registry's reads after a trial (the next numbers after Start's answer; the trial's
patient, the proposal to offer, the Replay list and the numbers after it is finished) are
made on the window's job thread (ui.window.after_trial). On the window's thread each could
hold it up to the registry's bounded wait on a station whose network went silent
(docs/stations.md, A silent network). Start waits until they are shown: the next trial takes
the next number and the proposal is decided by it."""

from __future__ import annotations

import threading

import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from device.loop.states import State
from tests.ui.session import build_and_connect, click, open_window, register_patient, short_trial
from ui.views.readiness import SAVING

pytestmark = pytest.mark.slow

WAIT_MS = 60_000
"""A bound for a hang, never a measure of speed."""

READS = ("suggest_registration", "sessions", "trials", "invalid_trials", "next_trial_number",
         "pending_proposal", "trial", "trials_for_patient")


def test_the_reads_after_a_trial_hold_start_not_the_window(qtbot, tmp_path, monkeypatch):
    registry = Registry(DataDir(tmp_path / "data", "test"))
    calls: list[tuple[str, bool]] = []  # (the read, made on the window's thread)
    hold, release = threading.Event(), threading.Event()

    def watched(name):
        read = getattr(registry, name)

        def call(*args, **kwargs):
            main = threading.current_thread() is threading.main_thread()
            calls.append((name, main))
            # a silent server, until the test lets it answer; the trial's finishing itself
            # (on the job thread before the reads, `_finishing`) is answered at once
            if hold.is_set() and not main and not win._finishing:
                release.wait(60)
            return read(*args, **kwargs)
        return call

    win = open_window(qtbot, tmp_path, monkeypatch, registry=registry)
    try:
        register_patient(qtbot, win)
        short_trial(win, duration_s=1.5)
        build_and_connect(qtbot, win)
        for name in READS:
            setattr(registry, name, watched(name))
        click(qtbot, win.robot.buttons["start"])
        qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=WAIT_MS)
        qtbot.waitUntil(lambda: getattr(win, "reading_after", 0) == 0, timeout=WAIT_MS)
        assert win.registration.trial_number == 2  # Start's answer: the next number shown
        hold.set()  # from now on the registry answers only when the test lets it
        # the trial finished into the registry, and the reads after it begun
        qtbot.waitUntil(lambda: not win._finishing and win.trial_id is None and any(
            name == "pending_proposal" for name, _ in calls), timeout=WAIT_MS)
        assert [name for name, main in calls if main] == [], \
            "the registry was read on the window's thread after a trial"
        assert win.reading_after == 1  # the window handles events while they wait
        assert win.unsaved_trial is None  # the trial is done once all is shown
        start = win.robot.buttons["start"]
        assert not start.isEnabled()
        assert SAVING in win.robot.why.whole  # Start waits for them
        release.set()
        qtbot.waitUntil(lambda: win.reading_after == 0, timeout=WAIT_MS)
        assert win.unsaved_trial is not None
        assert start.isEnabled()
        assert win.registration.trial_number == 2
        assert win.registration_tab.trial.value() == 2
        assert win.replay.trials.count() == 1
        assert {name for name, _ in calls} >= {"pending_proposal", "trials_for_patient",
                                                "suggest_registration"}
        assert [name for name, main in calls if main] == []
    finally:
        release.set()
        win.closing_by_signal = True
        win.close()
