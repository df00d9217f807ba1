"""What the window's station timer asks of an online station (ui/window/station.py): every
KEEP_CURRENT_EVERY ticks between trials, keep the standby's copy of the current patient
current (app.records.station.StationRegistry.keep_current: what other stations recorded for
them meanwhile, tests/app/records/postgres/test_station_offline.py), never during a trial,
and one request at a time on the job thread."""

from __future__ import annotations

from types import SimpleNamespace
from unittest.mock import MagicMock

from device.loop.states import State
from ui.window.station import KEEP_CURRENT_EVERY, StationStatus


def _window(registry):
    win = SimpleNamespace(registry=registry, state=State.CONNECTED, trial_id=None,
                          plan_runner=None, _syncing=False, _ticks_online=0,
                          _store_problem="", _show_reach=lambda offline: None, queued=[],
                          registering=lambda: False)
    win.jobs = SimpleNamespace(run=lambda work, done: win.queued.append((work, done)))
    win._kept_current = lambda result: StationStatus._kept_current(win, result)
    return win


def _run_queued(win):
    while win.queued:
        work, done = win.queued.pop(0)
        done(work())


def test_an_online_station_keeps_its_current_patient_current_between_trials_only():
    registry = MagicMock()
    registry.offline = False
    win = _window(registry)
    for _ in range(2 * KEEP_CURRENT_EVERY):
        StationStatus.check_station(win)
        _run_queued(win)
    assert registry.keep_current.call_count == 2
    registry.try_sync.assert_not_called()

    win.state = State.RUNNING  # a trial runs: the job thread is the trial's
    for _ in range(2 * KEEP_CURRENT_EVERY):
        StationStatus.check_station(win)
        _run_queued(win)
    assert registry.keep_current.call_count == 2

    win.state = State.CONNECTED
    win.registering = lambda: True  # a Start's trial being registered: the job thread's
    for _ in range(2 * KEEP_CURRENT_EVERY):
        StationStatus.check_station(win)
        _run_queued(win)
    assert registry.keep_current.call_count == 2
    win.registering = lambda: False

    win.state = State.CONNECTED  # one at a time: a slow answer is not asked again
    for _ in range(2 * KEEP_CURRENT_EVERY):
        StationStatus.check_station(win)
    assert len(win.queued) == 1
    _run_queued(win)
    assert registry.keep_current.call_count == 3


def test_an_offline_station_tries_to_sync_instead():
    registry = MagicMock()
    registry.offline = True
    registry.try_sync.return_value = None
    registry.sync_problem = ""
    win = _window(registry)
    win._synced = lambda synced: setattr(win, "_syncing", False)
    for _ in range(KEEP_CURRENT_EVERY):
        StationStatus.check_station(win)
        _run_queued(win)
    assert registry.try_sync.call_count == KEEP_CURRENT_EVERY
    registry.keep_current.assert_not_called()
