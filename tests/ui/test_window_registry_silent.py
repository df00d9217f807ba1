"""Start on a station whose network drops everything without a word (a pulled cable: nothing
ends, nothing answers; tests/netcut.py `silence`): the registry's answer is waited for up
to its bound (app.records.registry.postgres.deadline) on the job thread, and the window goes
on handling events meanwhile (ui.window.start). It froze for the whole wait while the robot
was connected: no repaint, no Stop, Disconnect or emergency-stop click handled, and the
loop faulted for its missed heartbeat. The trial is recorded on the station's standby, and
sent to the server once when the network is back."""

from __future__ import annotations

import threading

import pytest
from PySide6.QtCore import QTimer

from app.records.datadir import DataDir
from app.records.registry import Registry
from device.loop.states import State
from tests.ui.session import build_and_connect, click, open_window, register_patient, short_trial

pytestmark = pytest.mark.slow

WAIT_MS = 60_000
"""A bound for a hang, never a measure of speed."""


def test_start_on_a_silent_network_leaves_the_window_working_and_the_trial_is_sent_later(
        qtbot, tmp_path, monkeypatch, server_registries):
    from app.records.registry import database
    from app.records.registry.postgres import deadline
    from app.records.station import StationRegistry
    from tests.netcut import NetworkCut

    monkeypatch.setattr(database, "CONNECT_TIMEOUT_S", 2)  # libpq's least
    monkeypatch.setattr(deadline, "ANSWER_TIMEOUT_S", 1.0)
    url = server_registries.new()
    network = NetworkCut(url.port)
    station = StationRegistry(DataDir(tmp_path / "data", "test"), network.url(url),
                              station="robot-7")
    # The registry's begin_trial waits, before it asks the silent server, until the window
    # has handled an event posted before Start was pressed: the window handles events while
    # the trial is being registered exactly when that comes first. On a window that waits
    # for the registry on its own thread it never can: the wait gives up after 30 s.
    handled = threading.Event()
    handled_first: list[bool] = []
    begin = station.begin_trial

    def begin_after_an_event(*args, **kwargs):
        handled_first.append(handled.wait(30))
        return begin(*args, **kwargs)

    station.begin_trial = begin_after_an_event
    win = open_window(qtbot, tmp_path, monkeypatch, registry=station)
    try:
        register_patient(qtbot, win)
        code = win.patient.code
        short_trial(win, duration_s=1.5)
        build_and_connect(qtbot, win)
        assert not station.offline

        network.silence()  # the cable pulled
        QTimer.singleShot(0, handled.set)
        click(qtbot, win.robot.buttons["start"])
        start = win.robot.buttons["start"]
        assert start.text().startswith("Registering…")
        assert not start.isEnabled()
        assert win.robot.why.whole.endswith("Registering the trial: it starts once the "
                                            "registry answers")
        qtbot.waitUntil(lambda: bool(handled_first), timeout=WAIT_MS)
        assert handled_first == [True], "the window handled no event while registering"
        qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=WAIT_MS)
        assert station.offline  # the server's answer waited for, then the standby took it
        assert start.text().startswith("Start")
        qtbot.waitUntil(lambda: win.unsaved_trial is not None, timeout=WAIT_MS)
        (trial,) = station.trials_for_patient(code)
        assert (trial.status, trial.station) == ("complete", "robot-7")
        assert win.state == State.CONNECTED  # no fault: the loop heard the window throughout

        network.silent = False  # plugged in again: the old connections are gone
        network.cut()
        network.restore()
        win.check_station()  # the timer's tick, at once
        qtbot.waitUntil(lambda: not station.offline, timeout=WAIT_MS)
        win.check_station()  # a second tick sends nothing twice
        qtbot.waitUntil(lambda: not win._syncing, timeout=WAIT_MS)
    finally:
        win.closing_by_signal = True
        win.close()
        network.cut()
    other = Registry(DataDir(tmp_path / "elsewhere"), server=url, station="robot-8")
    trials = other.trials_for_patient(code)
    assert [(t.number, t.status, t.station) for t in trials] == [(1, "complete", "robot-7")]
