"""A trial recorded offline whose file's name another station's trial has on the server
(app.records.station.secondname; docs/stations.md, Offline stations, "A file's name taken").

A trial's file is named by its patient, session, number and start to the second
(app.records.datadir.trial_stem), and the registry keeps each name once. Two stations whose
clocks differ (a patient moved from robot-1 to robot-2, robot-2's clock behind) make the
same name for the patient's trial N: robot-1 recorded it offline, robot-2 online. The sync
was refused for good, the station never online again. The station's registry is the
department's server (PostgreSQL) and its standby this station's SQLite registry: each test
runs through both."""

from __future__ import annotations

import datetime
import errno
import os
import re
import shutil

import pytest

from app.errors import AppError
from app.exports.plan import (
    registry_facts,
    sources_from_folder,
    sources_from_registry,
    verified_sources,
)
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.postgres import seals
from app.records.registry.provenance import file_checksum
from app.records.station import StationRegistry, renumber
from app.records.station.mirror import standby_path
from app.records.trialplace import (
    FILE_AT_STATION,
    FILE_OF_ANOTHER,
    FILE_OK,
    HDF5_SIGNATURE,
    file_to_read,
)
from app.records.trialstore import store_pending
from app.reports.build import content_for_registry_trial
from app.reports.progress import file_note, progress
from core.trial import THESIS_SUBJECT
from tests.netcut import NetworkCut

PARAMS = THESIS_SUBJECT.replace(duration_s=2.0)


@pytest.fixture
def department(server_registries, tmp_path):
    """(the registry's URL, the network to it, robot-1's data folder, robot-2's registry)."""
    url = server_registries.new()
    network = NetworkCut(url.port)
    robot_2 = Registry(DataDir(tmp_path / "robot-2"), server=url, station="robot-2")
    yield url, network, DataDir(tmp_path / "robot-1"), robot_2
    network.cut()


def _filed_trial(registry, code, metrics, **given):
    """A finished trial with an HDF5 file of its own (its signature first, as Replay and
    Progress look for), its SHA-256 kept as the window keeps it."""
    begun = registry.begin_trial(code, PARAMS, backend="simulator", **given)
    path = registry.trial_path(begun.trial_id)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(HDF5_SIGNATURE + f"trial {begun.trial_id} {metrics}".encode())
    registry.finish_trial(begun.trial_id, "complete", metrics, checksum=file_checksum(path))
    return begun


def _one_second():
    """Two starts in one second of UTC: robot-1's, and robot-2's a minute later by the
    wall clock, its own clock a minute behind."""
    second = (datetime.datetime.now(datetime.UTC) - datetime.timedelta(minutes=5)).replace(
        microsecond=0)
    return second.replace(microsecond=250_000), second.replace(microsecond=750_000)


def _one_trial_offline(department):
    """robot-1 records trial 1 online, then, the network cut, trial 2 offline: (station,
    code, that trial, a start in the same second for another trial of the name)."""
    url, network, data, _robot_2 = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Di", "Sample").code
    _filed_trial(station, code, {"rmse_x_mm": 1.0})
    network.cut()
    ours, theirs = _one_second()
    mine = _filed_trial(station, code, {"rmse_x_mm": 2.0}, started_at=ours)
    return station, code, mine, theirs


def _taken_offline(department):
    """robot-1 records trial 1 online, trial 2 offline; robot-2 records trial 2 meanwhile,
    its file of the same name. (station, code, robot-1's offline trial, robot-2's)."""
    _url, network, _data, robot_2 = department
    station, code, mine, theirs = _one_trial_offline(department)
    other = _filed_trial(robot_2, code, {"rmse_x_mm": 9.0}, started_at=theirs)
    assert robot_2.trial(other.trial_id).file == station.trial(mine.trial_id).file  # one name
    network.restore()
    return station, code, mine, other


def test_a_renumbered_trial_whose_file_name_another_station_has_arrives_under_a_second_name(
        department, tmp_path):
    """Failed before: the sync refused ('duplicate key value violates unique constraint
    trials_file_key'), the station offline for good. Now the trial arrives as trial 3 under
    the name trial 3 gives, a second name (a hard link) of the same file in robot-1's data
    folder; the file recorded is untouched under its own name; the renumbering and the
    second name are sealed corrections; the trial store and Replay find the file by it and
    verify its checksum; a sync whose answer was lost is not sent twice."""
    url, _network, data, robot_2 = department
    station, code, mine, other = _taken_offline(department)
    recorded = station.trial(mine.trial_id)
    original = data.resolve(recorded.file)
    content, inode = original.read_bytes(), original.stat().st_ino
    sent = standby_path(data).with_name("as-sent.sqlite3")
    shutil.copy(standby_path(data), sent)

    synced = station.try_sync()
    assert synced is not None, station.sync_problem
    assert not station.offline
    direct = Registry(data, server=url, station="robot-1")
    on_server = direct.trials_for_patient(code)
    assert [(t.number, t.station) for t in on_server] == [
        (1, "robot-1"), (2, "robot-2"), (3, "robot-1")]
    ours = on_server[2]
    assert ours.file == data.trial_file(code, 1, 3, recorded.started_at)
    assert on_server[1].file == recorded.file  # robot-2's keeps its name
    linked = data.resolve(ours.file)
    assert linked.samefile(original)  # a second name of the one file, nothing copied
    assert (original.read_bytes(), original.stat().st_ino) == (content, inode)  # untouched
    assert direct.verify_trial_file(ours) is None
    assert ours.checksum == recorded.checksum
    assert ours.metrics["rmse_x_mm"] == 2.0

    started = robot_2.trial(other.trial_id).started_at
    took = f"station robot-2 recorded trial 2 (begun {started:%Y-%m-%d %H:%M} UTC) meanwhile"
    assert renumber.said(synced.renumbered) == f"trial 2 of session 1 is now trial 3: {took}"
    kept = [(c.field, c.old_value, c.new_value, c.corrected_by, c.reason)
            for c in direct.corrections(code)]
    assert [k[:4] for k in kept] == [
        ("trial_number", {"trial_id": ours.id, "session": 1, "trial": 2},
         {"trial_id": ours.id, "session": 1, "trial": 3}, "station robot-1"),
        ("trial_file", {"trial_id": ours.id, "file": recorded.file},
         {"trial_id": ours.id, "file": ours.file}, "station robot-1")]
    assert kept[0][4] == (
        "recorded on station robot-1 while the shared registry was unreachable, as trial 2 "
        f"of session 1 (its file {recorded.file} keeps that number in its name; registered "
        f"under the second name {ours.file}, below); {took}; sent at the sync as trial 3")
    assert kept[1][4] == (
        f"the file {recorded.file} of the trial recorded on station robot-1 while the shared "
        "registry was unreachable has the name of station robot-2's trial 2 of session 1 "
        f"(begun {started:%Y-%m-%d %H:%M:%S} UTC), which the registry keeps once: registered "
        f"under {ours.file}, the name its numbers give, a second name of the same file in "
        "station robot-1's data folder (the file itself unchanged)")
    with direct._read() as conn:
        seals.verify(conn, "the shared registry")

    store = tmp_path / "store"
    store.mkdir(mode=0o700)
    copied = store_pending(direct, store)
    assert copied.problems == []
    assert ours.id in [t.id for t in copied.trials]
    assert (store / ours.file).read_bytes() == content
    assert not (store / recorded.file).exists()  # robot-2's name there stays robot-2's
    assert direct.verify_trial_file(ours.id) is None  # here and in the store
    assert file_to_read(direct, direct.trial(ours.id)) == (linked, "")
    # robot-2's trial has the name of robot-1's own file here: never opened for it (it
    # was, robot-1's recording shown as robot-2's trial), found at robot-2 or in the store
    theirs = direct.trial(other.trial_id)
    assert progress(direct, code).file_states == (FILE_OK, FILE_AT_STATION, FILE_OK)
    with pytest.raises(AppError, match="on station robot-2, not yet in the trial store"):
        file_to_read(direct, theirs)
    assert store_pending(robot_2, store).problems == []
    assert file_to_read(direct, direct.trial(other.trial_id))[0] == store / theirs.file

    # the commit arrived but its answer did not: the station still holds the same records
    shutil.copy(sent, standby_path(data))
    station.offline_reason = "the answer to the last sync was lost"
    again = station.try_sync()
    assert (again.added, again.changed, again.renumbered) == ({}, {}, ())  # not sent again
    assert len(direct.trials_for_patient(code)) == 3
    assert len(direct.corrections(code)) == 2
    assert sorted(p.name for p in original.parent.iterdir()) == sorted(
        data.resolve(t.file).name for t in [*on_server[:1], recorded, ours])  # no third


def test_a_second_name_taken_in_the_data_folder_by_another_file_is_never_written_over(
        department):
    """The name the trial's new number gives holds another file here (put there by hand):
    the sync is refused in one line naming it, nothing replaced or left, the trial waits;
    the file moved away, it goes through."""
    url, _network, data, _robot_2 = department
    station, code, mine, _other = _taken_offline(department)
    recorded = station.trial(mine.trial_id)
    there = data.resolve(data.trial_file(code, 1, 3, recorded.started_at))
    there.write_bytes(b"someone's file")

    assert station.try_sync() is None
    assert station.offline
    assert f"{there} holds another file" in station.sync_problem
    assert there.read_bytes() == b"someone's file"
    assert [t.number for t in Registry(data, server=url).trials_for_patient(code)] == [1, 2]

    there.unlink()
    assert station.try_sync() is not None, station.sync_problem
    assert Registry(data, server=url).verify_trial_file(
        Registry(data, server=url).trials_for_patient(code)[2]) is None


def test_where_the_data_folder_cannot_link_the_second_name_is_a_checked_copy(
        department, monkeypatch):
    """A file system without hard links: a copy made aside, its SHA-256 the checksum kept,
    put in place never over a file; the file recorded untouched."""
    url, _network, data, _robot_2 = department
    station, code, mine, _other = _taken_offline(department)
    original = station.trial_path(mine.trial_id)
    content = original.read_bytes()

    def no_links(*_args, **_kwargs):
        raise OSError(errno.EPERM, "Operation not permitted")
    monkeypatch.setattr(os, "link", no_links)
    assert station.try_sync() is not None, station.sync_problem
    direct = Registry(data, server=url)
    ours = direct.trials_for_patient(code)[2]
    copy = data.resolve(ours.file)
    assert not copy.samefile(original)
    assert copy.read_bytes() == original.read_bytes() == content
    assert direct.verify_trial_file(ours) is None


def test_this_stations_own_trial_left_recording_under_the_name_is_finished_as_lost(
        department):
    """The name's holder is robot-1's own trial, registered on the server as the network
    dropped (its answer lost) and registered again offline in the same second: the trial
    recorded there is sent under its second name, and the row left recording is finished
    in the sync as recording lost, saying why; left recording, the station's next start
    finalized it from the file of its name, this trial's, writing that row's metrics into
    it."""
    url, network, data, _robot_2 = department
    station, code, mine, theirs = _one_trial_offline(department)
    direct = Registry(data, server=url, station="robot-1")
    lost = direct.begin_trial(code, PARAMS, backend="simulator", started_at=theirs)
    assert lost.file == station.trial(mine.trial_id).file
    content = station.trial_path(mine.trial_id).read_bytes()
    network.restore()

    synced = station.try_sync()
    assert synced is not None, station.sync_problem
    left = direct.trial(lost.trial_id)
    assert left.status == "recording_lost"
    assert left.end_reason.startswith("registered as the network dropped, its answer lost")
    assert direct.unfinished_trials() == []  # nothing for the next start to finalize
    (sent,) = [t for t in direct.trials_for_patient(code) if t.number == 3]
    assert sent.file != lost.file
    assert data.resolve(sent.file).read_bytes() == content
    assert direct.verify_trial_file(sent) is None
    assert direct.corrections(code)[-1].reason.endswith("is finished as recording lost")


def test_a_row_finished_as_recording_lost_opens_no_other_trials_recording(department,
                                                                          tmp_path):
    """The row finished as recording lost has the name of the file the station recorded
    for the trial sent under its second name: chosen in Progress or History and opened in
    Replay (or `rehab report`), it opened that trial's recording as its own. It has no
    file of its own: Progress says so, and Replay and the report refuse it, naming whose
    recording the file of its name is; that trial still opens, here and from the store."""
    url, network, data, robot_2 = department
    station, code, _mine, theirs = _one_trial_offline(department)
    direct = Registry(data, server=url, station="robot-1")
    lost = direct.begin_trial(code, PARAMS, backend="simulator", started_at=theirs)
    network.restore()
    assert station.try_sync() is not None, station.sync_problem
    (sent,) = [t for t in direct.trials_for_patient(code) if t.number == 3]
    said = (r"session 1, trial 2 \(id \d+\) was recorded as lost and has no file of its "
            rf"own: the file of its name is the recording of session 1, trial 3 \(id "
            rf"{sent.id}\)")
    for registry in (direct, station, robot_2):  # this station, offline or not, and another
        with pytest.raises(AppError, match=said):
            file_to_read(registry, registry.trial(lost.trial_id))
    with pytest.raises(AppError, match=said):
        content_for_registry_trial(direct, lost.trial_id)
    assert file_to_read(direct, sent) == (data.resolve(sent.file), "")
    states = dict(zip(progress(direct, code).trial_id.tolist(),
                      progress(direct, code).file_states, strict=True))
    assert states[lost.trial_id] == FILE_OF_ANOTHER
    assert states[sent.id] == FILE_OK
    assert file_note(FILE_OF_ANOTHER, "robot-1") == (
        "no file of its own: the file of its name is another trial's recording")

    store = tmp_path / "store"
    store.mkdir(mode=0o700)
    assert store_pending(direct, store).problems == []
    assert file_to_read(robot_2, robot_2.trial(sent.id))[0] == store / sent.file
    with pytest.raises(AppError, match=said):
        file_to_read(robot_2, robot_2.trial(lost.trial_id))
    # an export, a study, a reanalysis: the same recording was read as the lost row's too
    failed, notes = [], []
    exported = verified_sources(sources_from_registry(direct, code), failed, notes)
    assert [s.trial_id for s in exported] == [t.id for t in direct.trials_for_patient(code)
                                             if t.id != lost.trial_id]
    (refused,) = failed
    assert re.search(said, refused.reason)
    # a folder export of the data folder (its registry's facts beside each file): the first
    # name and the second are one recording, exported once as the trial it is, never twice
    # and never with the lost row's figures
    found = sources_from_folder(data.trials_dir, known=registry_facts(direct))
    named = {os.path.realpath(data.resolve(t.file)): t
             for t in direct.trials_for_patient(code) if t.id != lost.trial_id}
    assert sorted(os.path.realpath(s.path) for s in found) == sorted(named)
    for source in found:
        assert source.figures == tuple(named[os.path.realpath(source.path)].metrics.items())
