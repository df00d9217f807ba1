"""The window as a station of a department's shared registry (issue 32): the therapist
registers a patient and runs a trial as on a console of its own; the trial is on the
server, with this station's name and its file's checksum, and the window's title says
where it records."""

import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.provenance import file_checksum
from tests.ui.session import build_connect_start, open_window, register_patient, short_trial

pytestmark = pytest.mark.slow


def test_a_station_records_a_trial_in_the_shared_registry(qtbot, tmp_path, monkeypatch,
                                                          server_registries):
    url = server_registries.new()
    station = Registry(DataDir(tmp_path / "data", "test"), server=url, station="robot-7")
    win = open_window(qtbot, tmp_path, monkeypatch, registry=station)
    try:
        assert win.windowTitle() == (
            "Rehabilitation robot console — station robot-7 · shared registry "
            f"127.0.0.1:{url.port}/{url.database}")
        assert url.password not in win.windowTitle()
        register_patient(qtbot, win)
        short_trial(win)
        build_connect_start(qtbot, win)
        qtbot.waitUntil(lambda: win.unsaved_trial is not None
                        and win.registry.trial(win.unsaved_trial).finished)
        trial_id = win.unsaved_trial
    finally:
        win.close()
    # another station reads it from the server
    other = Registry(DataDir(tmp_path / "elsewhere"), server=url, station="robot-8")
    (trial,) = other.trials_for_patient(other.patients()[0].code)
    assert (trial.id, trial.status, trial.station) == (trial_id, "complete", "robot-7")
    assert trial.checksum == file_checksum(station.trial_path(trial))
    assert trial.metrics["rmse_x_m"] > 0
    assert other.pending_proposal(trial.patient_code).trial_id == trial_id
