"""The window copies each finished trial into the station's shared trial store (the setting
trial_store; issue 32, app.records.trialstore): a store that is not there is said once and
the trial waits; once it is there, the waiting trial is copied, checked and recorded."""

import pytest

from app.records.settings import Settings, save_settings
from tests.ui.session import build_connect_start, open_window, register_patient, short_trial

pytestmark = pytest.mark.slow


def test_a_trial_waits_for_the_store_and_is_copied_when_it_returns(qtbot, tmp_path,
                                                                   monkeypatch):
    store = tmp_path / "department" / "robot-1"  # not mounted yet
    save_settings(Settings(trial_store=str(store)), tmp_path / "config" / "settings.json")
    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        register_patient(qtbot, win)
        short_trial(win, duration_s=1.5)
        build_connect_start(qtbot, win)
        qtbot.waitUntil(lambda: any("is not there (is the network folder mounted?)" in line
                                    for line in win.messages.history()))
        trial = win.registry.trial(win.unsaved_trial)
        assert trial.checksum is not None
        assert trial.stored_in is None

        store.mkdir(parents=True)  # the share is mounted again
        win.check_station()  # the timer's tick, at once
        qtbot.waitUntil(lambda: win.registry.trial(trial.id).stored_in == str(store))
        qtbot.waitUntil(lambda: any("The trial store took the waiting trials (1 copied"
                                    in line for line in win.messages.history()))
        copy = store / trial.file
        assert copy.read_bytes() == win.registry.trial_path(trial).read_bytes()
        assert win.registry.verify_trial_file(trial.id) is None
    finally:
        win.close()
