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
        # where the names are: the tab said "this computer's registry" on a station (hB)
        assert win.registration_tab.names_note.text().startswith(
            "Names stay in the department's shared registry")
        register_patient(qtbot, win)
        short_trial(win, duration_s=1.5)
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


def test_the_network_drops_mid_session_and_the_station_records_on_then_sends_it_all(
        qtbot, tmp_path, monkeypatch, server_registries):
    """Issue 32: the server becomes unreachable during a session (the network to it is cut:
    tests/netcut.py); the therapist runs two more trials as if nothing happened, the window
    says where they go, and when the server answers again they arrive on it whole, once."""
    from app.records.station import StationRegistry
    from device.loop.states import State
    from tests.netcut import NetworkCut
    from tests.ui.session import click, enabled

    url = server_registries.new()
    network = NetworkCut(url.port)
    data = DataDir(tmp_path / "data", "test")
    station = StationRegistry(data, network.url(url), station="robot-7")
    win = open_window(qtbot, tmp_path, monkeypatch, registry=station)

    def one_trial():
        click(qtbot, win.robot.buttons["start"])
        qtbot.waitUntil(lambda: win.unsaved_trial is not None
                        and win.registry.trial(win.unsaved_trial).finished)
        qtbot.waitUntil(lambda: "start" in enabled(win))
        return win.unsaved_trial

    try:
        register_patient(qtbot, win)
        code = win.patient.code
        short_trial(win, duration_s=1.5)
        build_connect_start(qtbot, win)
        qtbot.waitUntil(lambda: win.unsaved_trial is not None
                        and win.registry.trial(win.unsaved_trial).finished)
        qtbot.waitUntil(lambda: "start" in enabled(win))
        assert win.registry_label.text() == ""

        network.cut()
        one_trial()
        one_trial()
        win.check_station()  # the timer's tick, at once
        assert "Shared registry unreachable" in win.registry_label.text()
        said = win.messages.history()
        assert any("cannot be reached: this station records on its own" in t for t in said)
        # each finished with its metrics and checksum (the job thread writes them after the end)
        qtbot.waitUntil(lambda: all(t.metrics and t.checksum
                                    for t in win.registry.trials_for_patient(code)))
        offline = win.registry.trials_for_patient(code)
        assert [t.number for t in offline] == [1, 2, 3]

        network.restore()
        win.check_station()
        qtbot.waitUntil(lambda: not win.registry.offline)
        qtbot.waitUntil(lambda: any("The shared registry is back: 2 trials" in line
                                    for line in win.messages.history()))
        assert win.registry_label.text() == ""
        assert win.state == State.CONNECTED
        assert win.registry.trial(win.unsaved_trial).number == 3  # the server's id now
    finally:
        win.close()
        network.cut()
    other = Registry(DataDir(tmp_path / "elsewhere"), server=url, station="robot-8")
    trials = other.trials_for_patient(code)
    assert [(t.number, t.status, t.station) for t in trials] == \
        [(n, "complete", "robot-7") for n in (1, 2, 3)]
    for trial, before in zip(trials, offline, strict=True):
        assert trial.metrics == before.metrics
        assert trial.checksum == before.checksum == file_checksum(station.trial_path(trial))
    assert other.pending_proposal(code).trial_id == trials[2].id


@pytest.mark.parametrize("meanwhile", [False, True])
def test_what_an_earlier_session_recorded_offline_sent_as_the_window_opens_is_said(
        qtbot, tmp_path, monkeypatch, server_registries, meanwhile):
    """The console closed while the server was away; opened again once it answers, the
    station sends the trials as it opens. The window said nothing of them (the sync while
    it runs says 'The shared registry is back: 2 trials …'). `meanwhile`: robot-8 opened
    session 1 for the patient meanwhile, so this station's is sent as session 2, said."""
    import datetime

    from app.records.station import StationRegistry
    from core.trial import THESIS_SUBJECT
    from tests.netcut import NetworkCut

    url = server_registries.new()
    network = NetworkCut(url.port)
    data = DataDir(tmp_path / "data", "test")
    try:
        earlier = StationRegistry(data, network.url(url), station="robot-7")
        code = earlier.create_patient("Ida", "Earlier").code
        network.cut()
        for _ in range(2):
            begun = earlier.begin_trial(code, THESIS_SUBJECT, backend="simulator")
            earlier.finish_trial(begun.trial_id, "complete", {"rmse_x_mm": 1.0})
        earlier.close()
        if meanwhile:
            other = Registry(DataDir(tmp_path / "robot-8"), server=url, station="robot-8")
            other.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                              started_at=datetime.datetime.now(datetime.UTC)
                              - datetime.timedelta(minutes=5))
        network.restore()
        station = StationRegistry(data, network.url(url), station="robot-7")
        win = open_window(qtbot, tmp_path, monkeypatch, registry=station, start_device=False)
        try:
            assert not station.offline
            said = "The shared registry took 2 trials this station recorded while it was " \
                "unreachable"
            if meanwhile:
                (theirs, _) = Registry(DataDir(tmp_path / "robot-8"), server=url).sessions(code)
                said += (f"; session 1 is now session 2: station robot-8 opened session 1 "
                         f"meanwhile (dated {theirs.date.isoformat()})")
            assert any(line.endswith(said) for line in win.messages.history()), \
                win.messages.history()
        finally:
            win.close()
    finally:
        network.cut()


@pytest.mark.parametrize("theirs_begun", ["minutes before", "in the same second"])
def test_a_number_another_station_gave_meanwhile_is_renumbered_and_said_once(
        qtbot, tmp_path, monkeypatch, server_registries, theirs_begun):
    """Issue 32: robot-7 is cut off, records trial 2 and saves its report; robot-8 records
    trial 2 for the same patient meanwhile. The sync was refused for good ("… until the
    registry's owner resolves it", which nothing let anyone do). Now robot-7's trial
    arrives as trial 3, the event line says so once, the Report tab and the saved PDF
    show the registry's number, and the trial's file keeps its name and is found.
    robot-8's trial begun in the same second (its clock behind) has the file's name: the
    trial arrives under the name trial 3 gives, a second name of the file, and the status
    bar's last trial, named by the file recorded, says trial 3 too (it said trial 2)."""
    import datetime

    from app.records.station import StationRegistry
    from core.trial import THESIS_SUBJECT
    from tests.netcut import NetworkCut
    from tests.ui.session import click, enabled
    from ui.views.replay_strip import replay_line

    url = server_registries.new()
    network = NetworkCut(url.port)
    data = DataDir(tmp_path / "data", "test")
    station = StationRegistry(data, network.url(url), station="robot-7")
    win = open_window(qtbot, tmp_path, monkeypatch, registry=station)
    try:
        register_patient(qtbot, win)
        code = win.patient.code
        short_trial(win, duration_s=1.5)
        build_connect_start(qtbot, win)
        qtbot.waitUntil(lambda: win.unsaved_trial is not None
                        and win.registry.trial(win.unsaved_trial).finished)
        qtbot.waitUntil(lambda: "start" in enabled(win))

        first = win.unsaved_trial
        network.cut()
        click(qtbot, win.robot.buttons["start"])
        qtbot.waitUntil(lambda: win.unsaved_trial not in (None, first)
                        and win.registry.trial(win.unsaved_trial).checksum is not None)
        qtbot.waitUntil(lambda: "save" in enabled(win))
        offline = win.registry.trial(win.unsaved_trial)
        assert offline.number == 2
        click(qtbot, win.robot.buttons["save"])  # its report saved while cut off
        old_pdf = data.report_path(code, 1, 2, offline.started_at)
        qtbot.waitUntil(old_pdf.exists)
        qtbot.waitUntil(lambda: win.report.content is not None)
        assert win.report.content.trial_number == 2
        qtbot.waitUntil(lambda: "start" in enabled(win))

        other = Registry(DataDir(tmp_path / "robot-8"), server=url, station="robot-8")
        their_start = offline.started_at - datetime.timedelta(minutes=5) \
            if theirs_begun == "minutes before" else offline.started_at.replace(
                microsecond=(offline.started_at.microsecond + 1) % 1_000_000)
        begun = other.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                                  started_at=their_start)
        other.finish_trial(begun.trial_id, "complete", {"rmse_x_mm": 1.0})
        theirs = other.trial(begun.trial_id)

        network.restore()
        win.check_station()  # the timer's tick, at once
        qtbot.waitUntil(lambda: not win.registry.offline)
        said = ("The shared registry is back: 1 trial recorded on this station meanwhile "
                "sent to it; trial 2 of session 1 is now trial 3: station robot-8 recorded "
                f"trial 2 (begun {theirs.started_at:%Y-%m-%d %H:%M} UTC) meanwhile")
        qtbot.waitUntil(lambda: any(said in line for line in win.messages.history()))
        (moved,) = win.registry.synced[-1].trial_ids.values()
        assert win.registry_label.text() == ""
        new_pdf = data.report_path(code, 1, 3, offline.started_at)
        qtbot.waitUntil(lambda: new_pdf.exists() and not old_pdf.exists())
        qtbot.waitUntil(lambda: win.report.content is not None
                        and win.report.content.trial_number == 3)
        rewritten = f"written again with the registry's number: {new_pdf.name} (the one"
        qtbot.waitUntil(lambda: any(rewritten in line for line in win.messages.history()))
        # the status bar's last trial, and Replay: its list and the line on a replayed trial
        # (its file's name keeps the old number, which they gave)
        assert win.trial_label.text() == "session 1, trial 3: complete"
        qtbot.waitUntil(lambda: win.replay.trials.count() == 3)
        assert win.replay.trials.item(0).text().startswith("Session 1, trial 3 — ")
        win.tabs.setCurrentWidget(win.replay)
        win.replay.trials.setCurrentRow(0)
        click(qtbot, win.replay.open_selected)
        qtbot.waitUntil(lambda: win.replay.view is not None
                        and win.shown_view is win.replay.view)
        assert win.shown_view.source == station.trial_path(station.trial(moved))
        assert f"{code}, session 1, trial 3, " in replay_line(win.shown_view)
        win.check_station()  # online now: nothing more is sent or said
        assert len([line for line in win.messages.history() if "is now trial" in line]) == 1
    finally:
        win.close()
        network.cut()
    direct = Registry(DataDir(tmp_path / "elsewhere"), server=url, station="robot-9")
    trials = direct.trials_for_patient(code)
    assert [(t.number, t.station) for t in trials] == [
        (1, "robot-7"), (2, "robot-8"), (3, "robot-7")]
    if theirs_begun == "minutes before":
        assert trials[2].file == offline.file  # never renamed
    else:  # robot-8's has that name: a second name of the same file
        assert trials[1].file == offline.file
        assert trials[2].file == data.trial_file(code, 1, 3, offline.started_at)
        assert station.trial_path(trials[2]).samefile(data.resolve(offline.file))
    assert trials[2].checksum == offline.checksum == file_checksum(station.trial_path(trials[2]))
    kept = direct.corrections(code)[0]
    assert (kept.field, kept.old_value["trial"], kept.new_value["trial"], kept.corrected_by) \
        == ("trial_number", 2, 3, "station robot-7")
    assert [c.field for c in direct.corrections(code)[1:]] == \
        ([] if theirs_begun == "minutes before" else ["trial_file"])
