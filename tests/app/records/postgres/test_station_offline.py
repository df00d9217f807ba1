"""A station keeps recording when the shared registry cannot be reached, and sends what it
recorded when it returns, without duplicates or losses (issue 32; app.records.station).
The network between the station and the tests' server is a relay the test cuts and
restores (tests/netcut.py): the station's connections end and new ones are refused, as when
the server or the network goes down."""

from __future__ import annotations

import dataclasses
import datetime
import shutil

import pytest

from app.errors import RegistryUnreachable
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.postgres import seals
from app.records.registry.provenance import file_checksum
from app.records.station import (
    LOGIN_REFUSED,
    SYNC_REFUSED,
    UNREACHABLE,
    StationRegistry,
    renumber,
)
from app.records.station.mirror import standby_path
from app.records.station.waiting import keep_refusal
from app.records.store import StationStore
from core.trial import THESIS_SUBJECT
from tests.netcut import NetworkCut

PARAMS = THESIS_SUBJECT.replace(duration_s=2.0)


@pytest.fixture
def department(server_registries, tmp_path):
    """(the registry's URL, the network to it, a station's data folder)."""
    url = server_registries.new()
    network = NetworkCut(url.port)
    yield url, network, DataDir(tmp_path / "robot-1")
    network.cut()


def _trial(registry, code, metrics=None, *, finish=True):
    begun = registry.begin_trial(code, PARAMS, backend="simulator")
    if finish:
        registry.finish_trial(begun.trial_id, "complete", metrics or {"rmse_x_mm": 1.5})
    return begun


def _as_recorded(trials):
    """What a trial's record says, its id aside (the server gives its own)."""
    return [dataclasses.replace(t, id=0) for t in trials]


def test_a_session_goes_on_offline_and_arrives_whole_when_the_server_returns(department):
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    assert isinstance(station, StationStore)  # and so a RecordStore: the window's registry
    code = station.create_patient("Ada", "Example").code
    first = _trial(station, code)
    assert not station.offline

    assert station.offline_cause == ""
    network.cut()  # the server goes away mid-session
    second = _trial(station, code, {"rmse_x_mm": 2.5})
    assert station.offline
    assert "cannot be reached" in station.offline_reason
    assert station.offline_cause == UNREACHABLE
    third = _trial(station, code, {"rmse_x_mm": 3.5})
    station.record_proposal(third.trial_id, {"assistance_level": 0.4})
    station.add_note(code, 1, "good effort after the break", author="therapist A")
    assert [(t.session_number, t.number) for t in station.trials_for_patient(code)] == \
        [(1, 1), (1, 2), (1, 3)]  # numbered as the server would
    recorded = station.trials_for_patient(code)
    assert station.try_sync() is None  # still unreachable: nothing lost, still offline
    assert station.offline

    network.restore()
    synced = station.try_sync()
    assert synced.trials == 2
    assert not station.offline
    assert station.offline_cause == ""
    direct = Registry(data, server=url, station="robot-1")
    on_server = direct.trials_for_patient(code)
    assert _as_recorded(on_server) == _as_recorded(recorded)
    assert on_server[0].id == first.trial_id
    assert [t.station for t in on_server] == ["robot-1"] * 3
    assert [n.text for n in direct.notes(code)] == ["good effort after the break"]
    proposal = direct.proposal(on_server[2].id)
    assert proposal.proposal == {"assistance_level": 0.4}
    assert synced.trial_ids == {second.trial_id: on_server[1].id,
                                third.trial_id: on_server[2].id}

    assert station.try_sync() is None  # online: nothing more to send, nothing twice
    fourth = _trial(station, code)
    assert [t.number for t in direct.trials_for_patient(code)] == [1, 2, 3, 4]
    assert direct.trial(fourth.trial_id).status == "complete"


def test_a_session_a_scale_opened_offline_arrives_once_with_its_trials(department):
    """The Fugl-Meyer taken before the first trial while the server is down opens the
    session on the station; the trials go on in it; the sync sends one session, with its
    scale and its trials, and nothing twice."""
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Ada", "Example").code
    _trial(station, code)  # session 1, online
    network.cut()
    scale = station.record_scale(code, 2, "fugl_meyer", total=24, rater="K. Lee")
    assert station.offline
    begun = station.begin_trial(code, PARAMS, backend="simulator", session_number=2)
    station.finish_trial(begun.trial_id, "complete", {"rmse_x_mm": 2.0})
    assert (scale.session_number, begun.session_number, begun.trial_number) == (2, 2, 1)
    network.restore()
    synced = station.try_sync()
    assert synced is not None, station.sync_problem
    assert (synced.added["sessions"], synced.added["scales"], synced.trials) == (1, 1, 1)
    direct = Registry(data, server=url, station="robot-1")
    assert [(s.number, s.n_trials) for s in direct.sessions(code)] == [(1, 1), (2, 1)]
    assert [(e.session_number, e.total) for e in direct.scale_entries(code)] == [(2, 24)]
    assert station.try_sync() is None  # online: nothing more to send, nothing twice
    assert len(direct.sessions(code)) == 2


def test_with_nothing_to_send_the_station_is_back_only_when_the_server_answers(department):
    """Found trying the window as a therapist: a station that went offline on a read, with
    nothing recorded since, said "the shared registry is back" while it was still cut off
    (the sync had nothing to send, so it never asked the server)."""
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Kim", "Sample").code
    network.cut()
    assert station.trial_summaries(code) == []  # answered by the standby
    assert station.offline
    assert station.try_sync() is None
    assert station.offline
    network.restore()
    synced = station.try_sync()
    assert (synced.added, synced.changed) == ({}, {})
    assert not station.offline


def test_a_trial_begun_online_and_finished_offline_is_finished_on_the_server(department):
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Bo", "Sample").code
    begun = _trial(station, code, finish=False)
    network.cut()
    station.finish_trial(begun.trial_id, "stopped_early", {"rmse_x_mm": 4.0},
                         reason="the patient asked to stop")
    assert station.offline
    assert station.try_sync() is None  # still cut
    network.restore()
    assert station.try_sync().changed == {"trials": 1}
    trial = Registry(data, server=url).trial(begun.trial_id)
    assert (trial.status, trial.end_reason) == ("stopped_early", "the patient asked to stop")


def test_a_trial_open_when_the_server_returns_is_sent_after_it_ends(department):
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Cy", "Sample").code
    network.cut()
    begun = _trial(station, code, finish=False)
    network.restore()
    assert station.try_sync() is None  # a trial is running: never mid-trial
    station.finish_trial(begun.trial_id, "complete", {})
    assert station.try_sync().trials == 1


def _filed_trial(registry, code, metrics, **given):
    """A finished trial with a file of its own, its SHA-256 kept as the window keeps it."""
    begun = registry.begin_trial(code, PARAMS, backend="simulator", **given)
    path = registry.trial_path(begun.trial_id)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(f"trial {begun.trial_id} {metrics}".encode())
    registry.finish_trial(begun.trial_id, "complete", metrics,
                          checksum=file_checksum(path))
    return begun


def _earlier(minutes):
    """A start some minutes ago: another second than any trial begun now."""
    return datetime.datetime.now(datetime.UTC) - datetime.timedelta(minutes=10 - minutes)


def _renumberings(registry, code):
    return [(c.field, c.old_value, c.new_value, c.corrected_by, c.reason)
            for c in registry.corrections(code)]


def test_a_number_another_station_gave_meanwhile_is_renumbered_at_the_sync_and_kept(
        department, server_registries, caplog):
    """Issue 32: "syncs when the server returns, without duplicates or lost trials". The
    sync was refused for good when robot-2 numbered trials for the patient while robot-1
    was cut off: nothing let anyone resolve it. Now robot-1's trials arrive under the
    server's next free numbers, in their order, gap-free, each file found by its checksum,
    and each renumbering is a sealed record saying which trial, who, the number before and
    after, and whose trial took it."""
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Di", "Sample").code
    first = _filed_trial(station, code, {"rmse_x_mm": 1.0})
    station.record_proposal(first.trial_id, {"assistance_level": 0.3})  # as the window does
    network.cut()
    offline = [_filed_trial(station, code, {"rmse_x_mm": 2.0 + n}) for n in range(3)]
    assert station.proposal(first.trial_id).next_trial_id == offline[0].trial_id
    station.record_proposal(offline[-1].trial_id, {"assistance_level": 0.4})
    station.add_note(code, 1, "tired after the third", author="therapist A",
                     trial_id=offline[-1].trial_id)
    assert [station.trial(b.trial_id).number for b in offline] == [2, 3, 4]
    files = [station.trial(b.trial_id).file for b in offline]
    other = Registry(DataDir(data.root.parent / "robot-2"), server=url, station="robot-2")
    # robot-2 records trials 2 and 3 (begun at other seconds than ours: a file's name holds
    # its start to the second, and two files of one name are refused, below)
    theirs = [_filed_trial(other, code, {"rmse_x_mm": 9.0}, started_at=_earlier(n))
              for n in range(2)]
    assert station.offline_cause == UNREACHABLE
    network.restore()
    synced = station.try_sync()
    assert synced is not None, station.sync_problem
    assert not station.offline
    assert (station.sync_problem, station.offline_cause) == ("", "")
    assert synced.trials == 3

    direct = Registry(data, server=url, station="robot-1")
    on_server = direct.trials_for_patient(code)
    assert [(t.number, t.station) for t in on_server] == [
        (1, "robot-1"), (2, "robot-2"), (3, "robot-2"), (4, "robot-1"), (5, "robot-1"),
        (6, "robot-1")]  # gap-free, robot-1's in the order recorded, nothing twice
    ours = on_server[3:]
    assert [t.file for t in ours] == files  # never renamed: the registry points at them
    assert [t.metrics["rmse_x_mm"] for t in ours] == [2.0, 3.0, 4.0]  # nothing lost
    assert all(direct.verify_trial_file(t) is None and t.checksum for t in on_server[:1] + ours)
    assert direct.proposal(ours[2].id).proposal == {"assistance_level": 0.4}
    # the proposal after trial 1 was decided by both stations' next trials: the one that is
    # trial 2 now, robot-2's, decided it (it refused the sync, renumbered or not)
    assert direct.proposal(on_server[0].id).next_trial_id == on_server[1].id
    assert [n.trial_id for n in direct.notes(code)] == [ours[2].id]
    assert synced.trial_ids == {b.trial_id: t.id for b, t in zip(offline, ours, strict=True)}

    started = [t.started_at for t in other.trials_for_patient(code) if t.station == "robot-2"]
    took = (f"station robot-2 recorded trial 2 (begun {started[0]:%Y-%m-%d %H:%M} UTC) and "
            f"trial 3 (begun {started[1]:%Y-%m-%d %H:%M} UTC) meanwhile")
    assert [m.line for m in synced.renumbered] == [
        f"trial {before} of session 1 is now trial {after}: {took}"
        for before, after in ((2, 4), (3, 5), (4, 6))]
    assert [m.trial_ids for m in synced.renumbered] == [(t.id,) for t in ours]
    assert renumber.said(synced.renumbered) == \
        f"trials 2, 3, 4 of session 1 are now trials 4, 5, 6: {took}"
    kept = _renumberings(direct, code)
    assert [k[:4] for k in kept] == [
        ("trial_number", {"trial_id": t.id, "session": 1, "trial": before},
         {"trial_id": t.id, "session": 1, "trial": after}, "station robot-1")
        for t, before, after in zip(ours, (2, 3, 4), (4, 5, 6), strict=True)]
    assert kept[0][4] == (
        "recorded on station robot-1 while the shared registry was unreachable, as trial 2 "
        f"of session 1 (its file {files[0]} keeps that number in its name); {took}; sent at "
        "the sync as trial 4")
    with direct._read() as conn:  # sealed by the server, append-only, as every correction
        seals.verify(conn, "the shared registry")
    assert len({t.file for t in on_server}) == 6
    assert theirs[0].trial_number == 2
    # research reads the numbers before and after (ids), not the reason or who
    research = Registry(DataDir(data.root.parent / "research"),
                        server=server_registries.as_researcher(url))
    assert [(c.field, c.old_value, c.new_value) for c in research.corrections(code)] == \
        [k[:3] for k in kept]
    assert all(c.reason != k[4] for c, k in zip(research.corrections(code), kept,
                                                   strict=True))

    assert station.try_sync() is None  # online: nothing more to send, nothing twice
    assert len(direct.trials_for_patient(code)) == 6
    assert len(_renumberings(direct, code)) == 3
    assert any("trial 2 of session 1 is now trial 4" in r.message for r in caplog.records)
    # the standby is the server's again: the next trial offline is numbered after them all
    network.cut()
    assert _trial(station, code).trial_number == 7


def test_a_session_another_station_opened_meanwhile_is_renumbered_with_its_trials(
        department):
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Di", "Sample").code
    _trial(station, code)
    network.cut()
    station.record_scale(code, 2, "fugl_meyer", total=30, rater="K. Lee")
    mine = [_filed_trial(station, code, {"rmse_x_mm": 3.0}, session_number=2)
            for _ in range(2)]
    files = [station.trial(b.trial_id).file for b in mine]
    other = Registry(DataDir(data.root.parent / "robot-2"), server=url, station="robot-2")
    _trial(other, code)  # robot-2 records trial 2 of session 1 (after robot-1's drop)
    other.begin_trial(code, PARAMS, backend="simulator", session_number=2,
                      started_at=_earlier(0))  # and opens session 2
    network.restore()
    synced = station.try_sync()
    assert synced is not None, station.sync_problem
    direct = Registry(data, server=url, station="robot-1")
    assert [(s.number, s.n_trials) for s in direct.sessions(code)] == [(1, 2), (2, 1), (3, 2)]
    ours = [t for t in direct.trials_for_patient(code) if t.session_number == 3]
    assert [t.number for t in ours] == [1, 2]
    assert [t.file for t in ours] == files
    assert all(direct.verify_trial_file(t) is None and t.checksum for t in ours)
    assert [(e.session_number, e.total) for e in direct.scale_entries(code)] == [(3, 30)]
    (moved,) = synced.renumbered
    today = direct.sessions(code)[1].date
    assert moved.line == ("session 2 is now session 3: station robot-2 opened session 2 "
                          f"meanwhile (dated {today.isoformat()})")
    assert moved.trial_ids == tuple(t.id for t in ours)
    (kept,) = _renumberings(direct, code)
    session_id = kept[2]["session_id"]  # the server's id of robot-1's session
    assert kept[:4] == ("session_number", {"session_id": session_id, "session": 2},
                        {"session_id": session_id, "session": 3}, "station robot-1")
    with direct._read() as conn:
        assert conn.exec_driver_sql("SELECT number FROM sessions WHERE id = %s",
                                    (session_id,)).scalar_one() == 3


def test_a_row_another_station_changed_meanwhile_still_refuses_the_sync(department):
    """Not a number: a patient's field corrected on both stations. The station cannot tell
    which correction is right, so it keeps its records, says so in one line, and goes on."""
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Di", "Sample").code
    _trial(station, code)
    network.cut()
    offline = _trial(station, code, {"rmse_x_mm": 9.0})
    station.correct_patient(code, "upper_arm_m", 0.31, reason="measured again", by="A")
    other = Registry(DataDir(data.root.parent / "robot-2"), server=url, station="robot-2")
    other.correct_patient(code, "upper_arm_m", 0.29, reason="measured again", by="B")
    network.restore()
    assert station.try_sync() is None
    assert station.offline
    assert station.offline_cause == SYNC_REFUSED
    assert "\n" not in station.sync_problem
    assert "was changed on the server by another station while this one was offline" \
        in station.sync_problem
    assert station.trial(offline.trial_id).metrics["rmse_x_mm"] == 9.0  # nothing lost
    assert [t.station for t in other.trials_for_patient(code)] == ["robot-1"]  # none sent
    assert _trial(station, code).trial_id > offline.trial_id  # the station goes on
    network.cut()  # refused, then the network drops: unreachable again, not 'refused'
    assert station.try_sync() is None
    assert station.offline_cause == UNREACHABLE


@pytest.mark.parametrize("how", ["named again", "kept current"])
def test_what_another_station_recorded_before_the_drop_is_numbered_before_ours(
        department, how):
    """Another station records for our patient while we are online; then our network drops.
    Our standby must know that trial (the station brings the patient up to date when the
    window names them again, and now and then between trials: keep_current), or the trial
    we record offline takes its number and the sync is refused."""
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Di", "Sample").code
    other_patient = station.create_patient("Ed", "Sample").code
    _trial(station, code)
    other = Registry(DataDir(data.root.parent / "robot-2"), server=url, station="robot-2")
    _trial(other, code)  # robot-2 records trial 2 while robot-1 is still online
    if how == "named again":
        station.trial_summaries(other_patient)
        station.trial_summaries(code)  # the therapist opens the patient again
    else:
        station.keep_current()
    network.cut()
    offline = _trial(station, code, {"rmse_x_mm": 9.0})
    assert station.offline
    assert station.trial(offline.trial_id).number == 3
    network.restore()
    synced = station.try_sync()
    assert synced is not None, station.sync_problem
    assert [(t.number, t.station) for t in other.trials_for_patient(code)] == [
        (1, "robot-1"), (2, "robot-2"), (3, "robot-1")]


def test_a_trial_finished_after_the_next_patient_was_opened_is_finished_in_the_standby(
        department):
    """The window finishes a trial on its job thread; the therapist may have opened the next
    patient by then. The standby must hold that trial finished (the write was for the
    trial's patient, not the one named last), or offline it would be shown as recording
    and a change to it refused at the sync."""
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    first = station.create_patient("Di", "Sample").code
    second = station.create_patient("Ed", "Sample").code
    begun = _trial(station, first, finish=False)
    station.trial_summaries(second)  # the next patient opened
    station.finish_trial(begun.trial_id, "complete", {"rmse_x_mm": 2.5})
    network.cut()
    trial = station.trial(begun.trial_id)
    assert station.offline
    assert trial.status == "complete"
    assert trial.metrics == {"rmse_x_mm": 2.5}


def test_a_station_that_starts_while_cut_off_sends_its_records_when_it_starts_again(
        department):
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Ed", "Sample").code
    network.cut()
    _trial(station, code)
    station.close()  # the console closes (its hold on the standby ends)

    again = StationRegistry(data, network.url(url), station="robot-1")  # still cut off
    assert again.offline
    assert [t.number for t in again.trials_for_patient(code)] == [1]
    _trial(again, code)
    new = again.create_patient("Flo", "Newcomer").code  # registered while offline
    offered = _trial(again, new)
    again.record_proposal(offered.trial_id, {"assistance_level": 0.4})
    again.close()

    network.restore()
    last = StationRegistry(data, network.url(url), station="robot-1")
    assert not last.offline
    direct = Registry(data, server=url)
    assert [t.number for t in direct.trials_for_patient(code)] == [1, 2]
    assert direct.patient(new).first_name == "Flo"
    assert [t.number for t in direct.trials_for_patient(new)] == [1]
    # its proposal names the patient by the server's id (schema v13), found as theirs
    (trial,) = direct.trials_for_patient(new)
    assert direct.pending_proposal(new).trial_id == trial.id
    assert direct.pending_proposal(code) is None


def test_a_sync_whose_answer_was_lost_is_not_sent_twice(department):
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Gus", "Sample").code
    network.cut()
    _trial(station, code)
    other = Registry(DataDir(data.root.parent / "robot-2"), server=url, station="robot-2")
    other.begin_trial(code, PARAMS, backend="simulator", started_at=_earlier(0))  # its 1
    path = standby_path(data)
    sent = path.with_name("as-sent.sqlite3")
    shutil.copy(path, sent)
    network.restore()
    synced = station.try_sync()
    assert (synced.trials, len(synced.renumbered)) == (1, 1)  # its session sent as 2
    # the commit arrived but its answer did not: the station still holds the same records
    shutil.copy(sent, path)
    station.offline_reason = "the answer to the last sync was lost"
    again = station.try_sync()
    assert (again.added, again.changed, again.renumbered) == ({}, {}, ())  # not sent again
    assert not station.offline
    direct = Registry(data, server=url)
    assert [(t.session_number, t.number, t.station)
            for t in direct.trials_for_patient(code)] == [(1, 1, "robot-2"), (2, 1, "robot-1")]
    assert len(direct.corrections(code)) == 1  # its renumbering kept once


def test_a_second_console_on_the_folder_uses_the_server_only(department):
    url, network, data = department
    first = StationRegistry(data, network.url(url), station="robot-1")
    second = StationRegistry(data, network.url(url), station="robot-1")
    assert first.held
    assert not second.held
    code = second.create_patient("Hal", "Sample").code
    network.cut()
    with pytest.raises(RegistryUnreachable, match="cannot reach the registry's server"):
        second.begin_trial(code, PARAMS, backend="simulator")


def test_a_damaged_standby_is_set_aside_never_sent_and_the_station_starts_afresh(department):
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Ivy", "Sample").code
    network.cut()
    _trial(station, code)
    station.close()
    path = standby_path(data)
    content = path.read_bytes()
    at = content.index(b"Sample")
    path.write_bytes(content[:at] + b"Simple" + content[at + 6:])  # a name changed on disk
    network.restore()

    again = StationRegistry(data, network.url(url), station="robot-1")
    assert not again.offline
    assert "standby registry was damaged" in again.sync_problem
    assert "\n" not in again.sync_problem
    (kept,) = path.parent.glob("damaged-*.sqlite3")
    assert kept.read_bytes()[at:at + 6] == b"Simple"  # kept as it was found
    assert Registry(data, server=url).trials_for_patient(code) == []  # nothing sent from it
    assert again.patient(code).last_name == "Sample"  # the server's, mirrored afresh


def test_the_standby_kept_current_in_place_equals_one_built_whole(department, caplog,
                                                                  tmp_path):
    """After each write the standby's rows of the patient are brought to the server's in
    place (app.records.station.refresh): rows changed, added and taken out (a trial
    withdrawn at Start) leave it exactly as a standby built whole from the server."""
    import contextlib
    import sqlite3

    from app.records.station.mirror import build_standby, manifest, patient_rows, standby_rows

    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Jo", "Sample").code
    first = _trial(station, code)
    station.record_proposal(first.trial_id, {"assistance_level": 0.5})
    _trial(station, code)
    taken_back = station.begin_trial(code, PARAMS, backend="simulator")
    station.withdraw_trial(taken_back.trial_id, "its file was never written")
    station.add_note(code, 1, "steady", author="therapist A")
    station.mark_trial(first.trial_id, valid=False, reason="the cuff slipped", by="A")
    station.correct_patient(code, "last_name", "Sampler", reason="typo", by="A")
    assert "built whole again" not in caplog.text  # kept current in place each time

    whole = DataDir(tmp_path / "whole")
    with Registry(whole, server=url)._read() as conn:
        build_standby(whole, patient_rows(conn, [code]), "test", "now")

    def contents(folder):
        with contextlib.closing(sqlite3.connect(standby_path(folder))) as conn:
            return standby_rows(conn), manifest(conn)

    assert contents(data) == contents(whole)


def test_a_login_the_server_refuses_records_on_the_station_and_says_it_is_not_the_network(
        department):
    """A password changed on the server (or typed wrong in the URL file): the station
    records on its own as when the network is down, but says what to do. It said 'cannot
    be reached', which sent the therapist to the network."""
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Gil", "Refused").code
    station.close()
    wrong = network.url(url).set(password="not-the-password")
    refused = StationRegistry(data, wrong, station="robot-1")
    _trial(refused, code)
    assert refused.offline
    reason = refused.offline_reason
    assert reason.startswith(f"the shared registry 127.0.0.1:{network.port}/{url.database} "
                             "refused this station's login: this station records on its own")
    assert f"refused the login {url.username} with its password" in reason
    assert "correct the user or password in the registry URL" in reason
    assert "cannot be reached" not in reason
    assert "not-the-password" not in reason
    assert refused.offline_cause == LOGIN_REFUSED
    assert refused.try_sync() is None  # still refused: still the login, never 'unreachable'
    assert refused.offline_cause == LOGIN_REFUSED
    refused.close()
    again = StationRegistry(data, network.url(url), station="robot-1")  # the URL corrected
    assert not again.offline
    assert [t.number for t in Registry(data, server=url).trials_for_patient(code)] == [1]


def test_db_status_says_what_waits_on_the_station_whether_the_server_answers_or_not(
        department, tmp_path, monkeypatch, capsys):
    """It gave the server's counts alone ('trials 1 … every row matches its seal') while
    two trials were only in the station's standby, and nothing but the server's refusal
    while it was down."""
    from tests.app.cli.running import run

    url, network, data = department
    config = tmp_path / "config"
    config.mkdir(mode=0o700)
    (config / "registry.url").write_text(
        network.url(url).render_as_string(hide_password=False) + "\n")
    (config / "registry.url").chmod(0o600)
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(config))
    monkeypatch.setenv("REHAB_DATA_DIR", str(data.root))
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Hal", "Waiting").code
    _trial(station, code)
    code_now, out, _ = run(["db", "status"], capsys)
    assert code_now == 0
    assert "this station" not in out  # nothing waits

    network.cut()
    _trial(station, code)
    _trial(station, code)
    waiting = (f"this station: 2 trial(s) (2 record(s) in all) recorded or changed while the "
               f"shared registry was unreachable wait in {standby_path(data)}, not on the "
               "server yet: the console's window sends them once it runs and the server "
               "answers (the command line does not)\n")
    code_now, out, err = run(["db", "status"], capsys)
    assert (code_now, out) == (2, waiting)  # said, then the server's refusal
    assert "cannot reach the registry's server" in err

    network.restore()
    code_now, out, _ = run(["db", "status"], capsys)
    assert code_now == 0
    assert out.startswith(waiting)  # the server answers, but they are not on it yet
    assert "trials 1," in out
    station.try_sync()
    code_now, out, _ = run(["db", "status"], capsys)
    assert "this station" not in out
    assert "trials 3," in out

    # another station's number meanwhile: the sync goes through, renumbered, and nothing is
    # said waiting (it said 'the window's last attempt to send them … was refused' for good)
    network.cut()
    _trial(station, code, {"rmse_x_mm": 7.0})
    other = Registry(DataDir(data.root.parent / "robot-2"), server=url, station="robot-2")
    other.begin_trial(code, PARAMS, backend="simulator", started_at=_earlier(0))  # its 4
    network.restore()
    synced = station.try_sync()
    assert synced is not None, station.sync_problem
    assert [m.line.split(":")[0] for m in synced.renumbered] == [
        "trial 4 of session 1 is now trial 5"]
    code_now, out, _ = run(["db", "status"], capsys)
    assert code_now == 0
    assert "this station" not in out
    assert "trials 5," in out

    # a sync the server refuses (a row robot-2 changed meanwhile): the line says so, not
    # that the window will send them
    network.cut()
    _trial(station, code, {"rmse_x_mm": 8.0})
    station.correct_patient(code, "upper_arm_m", 0.31, reason="measured again", by="A")
    other.correct_patient(code, "upper_arm_m", 0.29, reason="measured again", by="B")
    network.restore()
    assert station.try_sync() is None
    code_now, out, _ = run(["db", "status"], capsys)
    assert code_now == 0
    first = out.splitlines()[0]
    assert first.startswith(f"this station: 1 trial(s) (3 record(s) in all) recorded or "
                            f"changed while the shared registry was unreachable wait in "
                            f"{standby_path(data)}, not on the server yet: the window's last "
                            "attempt to send them (")
    assert ") was refused: the records this station made offline were not sent: " in first
    assert "was changed on the server by another station while this one was offline" in first
    assert "sends them once it runs" not in first
    # a sync that goes through removes the refusal kept (here: one kept by hand beside a
    # standby that sends)
    station.close()
    shutil.rmtree(data.root / "offline")
    again = StationRegistry(data, network.url(url), station="robot-1")
    again.trial_summaries(code)  # the patient opened: in the standby
    network.cut()
    _trial(again, code)
    keep_refusal(data, "an earlier refusal")
    assert "an earlier refusal" in run(["db", "status"], capsys)[1]
    network.restore()
    assert again.try_sync().trials == 1
    code_now, out, _ = run(["db", "status"], capsys)
    assert "this station" not in out


def test_a_network_that_drops_everything_is_seen_in_seconds_and_the_session_goes_on(
        department, monkeypatch):
    """A pulled cable ends nothing: the statement is sent and its answer waited for until
    TCP gives up (about 15 minutes), the window frozen on it and the robot faulted for its
    lost heartbeat. Each wait for the server is bounded (postgres.deadline)."""
    import threading

    from app.records.registry import database
    from app.records.registry.postgres import deadline

    monkeypatch.setattr(database, "CONNECT_TIMEOUT_S", 2)  # libpq's least
    monkeypatch.setattr(deadline, "ANSWER_TIMEOUT_S", 0.5)
    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Joy", "Sample").code
    _trial(station, code)

    network.silence()  # the cable pulled: nothing ends, nothing answers
    done = threading.Event()
    threading.Thread(target=lambda: (_trial(station, code, {"rmse_x_mm": 2.5}), done.set()),
                     daemon=True).start()
    # a bound for a hang (the fix answers within seconds), not a measure of speed
    assert done.wait(120), "the station waited on a silent network"
    assert station.offline
    assert "cannot be reached" in station.offline_reason

    network.silent = False  # plugged in again: the old connections are gone
    network.cut()
    network.restore()
    station.try_sync()  # between trials, as the window does while offline
    assert not station.offline
    server = Registry(data, server=url)
    assert [t.number for t in server.trials_for_patient(code)] == [1, 2]


def test_a_sync_waiting_on_a_silent_server_holds_no_other_call(tmp_path):
    """Offline, every call is answered by the standby; a sync reaching for the server (on
    the window's job thread, up to the bounded wait on a silent network) held them all
    behind it, so the window's own (a trial's numbers read after it ends) froze it. The
    server here is one that never answers until the test lets it (no timing involved)."""
    import threading

    import sqlalchemy as sa

    reaching, answer = threading.Event(), threading.Event()
    tries = []

    def connect(*_args, **_kwargs):
        if tries:  # the console's start is refused at once; a sync then waits
            reaching.set()
            answer.wait(60)  # a bound for a test that failed meanwhile
        tries.append(1)
        raise RegistryUnreachable("the server did not answer (the test's silent network)")

    station = StationRegistry(DataDir(tmp_path / "robot-1"),
                              sa.make_url("postgresql://station@127.0.0.1:9/registry"),
                              station="robot-1", connect=connect)
    try:
        assert station.offline
        code = station.create_patient("Ada", "Offline").code
        # the standby answers the read in milliseconds
        _answered_while_waiting(station.try_sync, lambda: station.suggest_registration(code),
                                reaching, answer)
        assert station.offline
    finally:
        answer.set()
        station.close()


@pytest.mark.parametrize("standby", ["as left", "changed"])
def test_keeping_current_on_a_silent_server_holds_no_other_call(department, standby):
    """Online, between trials, the window's job thread keeps the standby current
    (keep_current); on a silent network the server's answer waits out the bounded wait,
    and a call of the window's meanwhile (a trial's numbers) waited behind it, the window
    frozen. The server's reading here is one that never answers until the test lets it
    (no timing involved); the window's own call reaches the server as usual. A standby
    changed since this station last left it (another program, a failed write) is built
    whole, from every recent patient's rows: that reading held the other calls still."""
    import contextlib
    import os
    import threading

    url, network, data = department
    station = StationRegistry(data, network.url(url), station="robot-1")
    code = station.create_patient("Kit", "Sample").code
    _trial(station, code)
    if standby == "changed":
        path = standby_path(data)
        seen = os.stat(path)
        os.utime(path, ns=(seen.st_atime_ns, seen.st_mtime_ns + 1_000_000_000))
    server = station._server
    reaching, answer = threading.Event(), threading.Event()
    ordinary = server._read

    @contextlib.contextmanager
    def silent_once(*args, **kwargs):
        if not reaching.is_set():  # keep_current's: waits for an answer that never comes
            reaching.set()
            answer.wait(60)  # a bound for a test that failed meanwhile
            raise RegistryUnreachable("the server did not answer (the test's silent network)")
        with ordinary(*args, **kwargs) as conn:
            yield conn

    server._read = silent_once
    try:
        # the server answers the window's call in milliseconds
        _answered_while_waiting(station.keep_current, lambda: station.trial_summaries(code),
                                reaching, answer)
        assert station.offline  # the silence seen: the next calls go to the standby
        assert [t.number for t in station.trials_for_patient(code)] == [1]
    finally:
        answer.set()
        station.close()


def _answered_while_waiting(waiting, call, reaching, answer):
    """`call` returns while `waiting` (on another thread) waits for a silent server (it sets
    `reaching`, then waits until the test sets `answer`); then `waiting` ends."""
    import threading

    waits = threading.Thread(target=waiting, daemon=True)
    waits.start()
    assert reaching.wait(60)
    read = threading.Event()
    threading.Thread(target=lambda: (call(), read.set()), daemon=True).start()
    # a bound for a hang, not a measure of speed
    assert read.wait(30), f"a call waited behind {waiting.__name__}'s wait for a silent server"
    answer.set()
    waits.join(60)
