"""Replay at one station opens a trial another station recorded (issue 32): from the shared
trial store's copy, checked against the checksum kept at the trial's end, saying so and
marking its row; a trial not yet copied is said to be on its station, not lost
(app.records.trialplace). Two stations on the tests' PostgreSQL server, each with its own
data folder. Before, Replay looked only in this station's data folder."""

from __future__ import annotations

import datetime

import pytest
from PySide6.QtCore import Qt

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.station import StationRegistry
from app.records.trialstore import store_pending
from app.trials.finalize import finalize_trial
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT
from tests.netcut import NetworkCut
from tests.ui.shown import shown
from ui.tabs import ReplayTab

PARAMS = THESIS_SUBJECT.replace(duration_s=2.0)
WAIT_MS = 30_000
"""A bound for a hang, never a measure of speed."""


def _finished(registry, code, **given):
    begun = registry.begin_trial(code, PARAMS, backend="simulator", **given)
    save(simulate(PARAMS, patient="healthy"), begun.path, subject_code=code)
    return registry.trial(finalize_trial(registry, begun.trial_id).trial_id)


@pytest.fixture
def robot_1(server_registries, tmp_path):
    """Robot-1's registry; its patient has two trials robot-2 recorded: the first copied
    into robot-2's trial store, the second not yet."""
    url = server_registries.new()
    robot_1 = Registry(DataDir(tmp_path / "robot-1"), server=url, station="robot-1")
    robot_2 = Registry(DataDir(tmp_path / "robot-2"), server=url, station="robot-2")
    code = robot_1.create_patient("Ada", "Example").code
    stored = _finished(robot_2, code)
    store = tmp_path / "department" / "robot-2"
    store.mkdir(parents=True)
    assert store_pending(robot_2, store).problems == []
    waiting = _finished(robot_2, code)
    return robot_1, code, robot_1.trial(stored.id), waiting, store


def _open_row(qtbot, tab, row: int) -> None:
    tab.trials.setCurrentRow(row)
    qtbot.mouseClick(tab.open_selected, Qt.MouseButton.LeftButton)


def test_replay_opens_another_station_s_trial_from_the_store(qtbot, robot_1):
    registry, code, stored, waiting, store = robot_1
    tab = shown(qtbot, ReplayTab(registry))
    tab.set_patient(code)
    assert tab.trials.count() == 2  # the newest first: the trial not yet copied
    assert tab.trials.item(1).text().split("\n")[0].endswith(" — complete — at robot-2")

    with qtbot.waitSignal(tab.view_loaded, timeout=WAIT_MS) as loaded:
        _open_row(qtbot, tab, 1)
    copy = store / stored.file
    assert loaded.args[0].source == copy
    assert f"Read from the trial store's copy {copy}." in tab.info.text()
    assert tab.trials.currentRow() == 1  # its row marked, though read from elsewhere
    assert not tab.pose_button.isEnabled()  # the store's proven copy is never written
    # the store keeps no video: whether one was recorded is not known here, and it would
    # be at robot-2 (it said "No video was recorded with this trial")
    assert "No video was recorded" not in tab.pose_status.text()
    assert "a video of this trial, if one was recorded, is at station robot-2" in \
        tab.pose_status.text()

    with qtbot.waitSignal(tab.load_failed, timeout=WAIT_MS) as failed:
        _open_row(qtbot, tab, 0)
    assert failed.args[0].startswith(
        f"The file of session 1, trial {waiting.number} (id {waiting.id}) is on station "
        "robot-2, not yet in the trial store: open it at robot-2")
    assert failed.args[0] in tab.info.text()


def test_a_row_finished_as_recording_lost_opens_nothing_in_replay(qtbot, server_registries,
                                                                  tmp_path):
    """Robot-1's Start registered trial 2 on the server as the network dropped (its answer
    lost), registered it again offline in the same second and recorded it there; the sync
    sent that one as trial 3 under a second name of its file and finished the row left
    recording as recording lost, under the first name. Chosen in Replay, the lost row
    opened trial 3's recording as its own. It now opens nothing and says why."""
    url = server_registries.new()
    network = NetworkCut(url.port)
    try:
        data = DataDir(tmp_path / "robot-1")
        station = StationRegistry(data, network.url(url), station="robot-1")
        code = station.create_patient("Di", "Sample").code
        _finished(station, code)
        network.cut()
        second = (datetime.datetime.now(datetime.UTC)
                  - datetime.timedelta(minutes=5)).replace(microsecond=0)
        recorded = _finished(station, code, started_at=second.replace(microsecond=250_000))
        direct = Registry(data, server=url, station="robot-1")
        lost = direct.begin_trial(code, PARAMS, backend="simulator",
                                  started_at=second.replace(microsecond=750_000))
        assert lost.file == recorded.file  # one name
        network.restore()
        assert station.try_sync() is not None, station.sync_problem
    finally:
        network.cut()
    tab = shown(qtbot, ReplayTab(direct))
    tab.set_patient(code)
    rows = [tab.trials.item(i).data(Qt.ItemDataRole.UserRole)
            for i in range(tab.trials.count())]
    loaded, failed = [], []
    tab.view_loaded.connect(loaded.append)
    tab.load_failed.connect(failed.append)
    _open_row(qtbot, tab, rows.index(lost.trial_id))
    qtbot.waitUntil(lambda: bool(loaded or failed), timeout=WAIT_MS)
    assert not loaded  # nothing of another trial shown as this one
    assert failed[0].startswith(
        f"Session 1, trial 2 (id {lost.trial_id}) was recorded as lost and has no file of "
        "its own: the file of its name is the recording of session 1, trial 3")
    assert failed[0] in tab.info.text()
