"""A therapist at one station sees the trials another station recorded (issue 32): the
progress names each trial's station and where its file is — here, in the shared trial store,
or still on the station that recorded it — and Replay opens the store's copy, checked
(app.records.trialplace, app.reports.progress). On both engines
(tests/app/records/conftest.py): on the server each station keeps its files in its own data
folder; on the data folder's SQLite registry every station shares that one folder, so a
file not there is missing whoever recorded it.

Before, the progress query did not carry a trial's station nor its store, and the progress
checked only this station's data folder: robot-2's trials showed "complete (file missing)"
at robot-1, and Replay could not open them."""

from __future__ import annotations

import shutil

import pytest

from app.errors import AppError
from app.records.datadir import DataDir
from app.records.trialplace import file_to_read
from app.records.trialstore import store_pending
from app.reports.progress import (
    FILE_AT_STATION,
    FILE_IN_STORE,
    FILE_MISSING,
    FILE_OK,
    FILE_STORE_UNREACHABLE,
    progress,
)
from app.trials.finalize import finalize_trial
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT
from tests.trialfiles import flip_last_byte
from ui.views.progress_table import progress_table

PARAMS = THESIS_SUBJECT.replace(duration_s=2.0)


def _finished(registry, code):
    begun = registry.begin_trial(code, PARAMS, backend="simulator")
    save(simulate(PARAMS, patient="healthy"), begun.path, subject_code=code)
    return registry.trial(finalize_trial(registry, begun.trial_id).trial_id)


@pytest.fixture
def department(open_registry, registry_engine, tmp_path):
    """robot-1 and robot-2 on one registry, robot-2 copying into its trial store: one
    patient's trials, robot-1's first, then robot-2's: three copied into the store, the last
    not yet. Robot-1 has none of robot-2's files in its data folder (on SQLite, which the
    stations share, they are taken out of it after the copy)."""
    robot_1 = open_registry(station="robot-1")
    on_server = registry_engine == "postgresql"
    robot_2 = open_registry(DataDir(tmp_path / "robot-2") if on_server else None,
                            station="robot-2")
    code = robot_1.create_patient("Ada", "Example").code
    mine = [_finished(robot_1, code), _finished(robot_1, code)]
    store = tmp_path / "department" / "robot-2"
    store.mkdir(parents=True)
    copied = [_finished(robot_2, code) for _ in range(3)]
    assert store_pending(robot_2, store).problems == []
    waiting = _finished(robot_2, code)  # its store not reached since
    theirs = [robot_2.trial(t.id) for t in copied] + [waiting]
    for trial in theirs:  # not in robot-1's data folder
        robot_1.trial_path(trial).unlink(missing_ok=True)
    return robot_1, code, mine, theirs, store, on_server


def test_each_trial_says_its_station_and_where_its_file_is(department):
    robot_1, code, (_, lost), (_, gone, damaged, _), store, on_server = department
    robot_1.trial_path(lost).unlink()  # robot-1's own, never copied: really missing
    (store / gone.file).unlink()  # copied, then lost from the store
    flip_last_byte(store / damaged.file)  # its copy damaged in the store

    summaries = robot_1.trial_summaries(code)
    assert [(s.station, s.stored_in) for s in summaries] == [
        ("robot-1", None), ("robot-1", None), *[("robot-2", str(store))] * 3,
        ("robot-2", None)]

    result = progress(robot_1, code)
    assert list(result.file_states) == [
        FILE_OK, FILE_MISSING, FILE_IN_STORE, FILE_MISSING,
        FILE_IN_STORE,  # its signature whole: only Replay hashes a copy
        # on a server, on robot-2's own data folder; on SQLite's shared folder: lost
        FILE_AT_STATION if on_server else FILE_MISSING]
    assert result.file_ok.tolist() == [True, False, True, False, True, False]
    header, rows = result.table()
    assert [row[header.index("station")] for row in rows] == ["robot-1"] * 2 + ["robot-2"] * 4

    table = progress_table(result)
    station, status = table.headings.index("Station"), table.headings.index("Status")
    assert [row[station] for row in table.rows] == ["robot-1"] * 2 + ["robot-2"] * 4
    assert [row[status] for row in table.rows] == [
        "complete", "complete (file missing)", "complete (file in the trial store)",
        "complete (file missing)", "complete (file in the trial store)",
        "complete (on station robot-2, not yet in the trial store)" if on_server
        else "complete (file missing)"]

    shutil.move(store, store.with_name("unmounted"))  # the share not mounted here
    assert progress(robot_1, code).file_states[2] == FILE_STORE_UNREACHABLE
    assert progress_table(progress(robot_1, code)).rows[2][status] == \
        "complete (file in a trial store not reachable here)"


def test_replay_reads_the_store_s_copy_only_when_it_is_the_file_recorded(department):
    robot_1, _, (here, _), (stored, gone, damaged, waiting), store, on_server = department
    assert file_to_read(robot_1, here) == (robot_1.trial_path(here), "")
    copy = store / stored.file
    assert file_to_read(robot_1, stored) == (
        copy, f"read from the trial store's copy {copy}")

    flip_last_byte(store / damaged.file)
    with pytest.raises(AppError, match=rf"^the copy of session 1, trial {damaged.number} "
                                       rf"\(id {damaged.id}\) in the trial store .* is not "
                                       r"the file recorded: its SHA-256 is"):
        file_to_read(robot_1, damaged)
    (store / gone.file).unlink()
    with pytest.raises(AppError, match=r"cannot be read \(No such file or directory\): "
                                       "restore it from a backup"):
        file_to_read(robot_1, gone)
    if on_server:
        with pytest.raises(AppError, match=rf"^the file of session 1, trial {waiting.number} "
                                           rf"\(id {waiting.id}\) is on station robot-2, not "
                                           "yet in the trial store: open it at robot-2, or "
                                           "here once that station has copied"):
            file_to_read(robot_1, waiting)
    else:  # the stations' one data folder: the reader says the file is missing
        assert file_to_read(robot_1, waiting) == (robot_1.trial_path(waiting), "")


def test_rehab_progress_and_its_pdf_name_each_trial_s_station(department, monkeypatch,
                                                              capsys, tmp_path):
    """`rehab progress` at robot-1: a station column, and a line for each trial whose file
    cannot be read here saying why; its PDF's table names the station too."""
    import argparse

    from app.cli import reports
    from app.reports.progress_pdf import write_progress_pdf
    from tests.app.reports.made import page_texts

    robot_1, code, (_, lost), (_, _, _, waiting), _, on_server = department
    robot_1.trial_path(lost).unlink()
    monkeypatch.setattr(reports, "registry_for", lambda args: robot_1)
    assert reports.cmd_progress(argparse.Namespace(
        code=code, metrics=None, csv=False, include_invalid=False, pdf=None)) == 0
    out = capsys.readouterr().out.splitlines()
    heading = next(line for line in out if line.lstrip().startswith("session"))
    assert heading.split()[:4] == ["session", "trial", "station", "status"]
    listed = [line.split() for line in out if line.lstrip()[:1].isdigit()]
    assert [cells[2] for cells in listed] == ["robot-1"] * 2 + ["robot-2"] * 4
    assert [line for line in out if line.startswith("  session ")] == [
        f"  session 1 trial 2 (id {lost.id}): file missing",
        f"  session 1 trial {waiting.number} (id {waiting.id}): "
        + ("on station robot-2, not yet in the trial store" if on_server else "file missing")]

    pages = page_texts(write_progress_pdf(progress(robot_1, code), tmp_path / "p.pdf"))
    assert "Station" in pages[0]
    assert pages[0].count("robot-2") == 4


def test_rehab_report_reads_another_station_s_trial_from_the_store(department):
    """`rehab report ID` (and the Report of a registered trial) at robot-1 for a trial of
    robot-2: its store's copy, checked; one not yet copied says where it is."""
    from app.reports.build import content_for_registry_trial

    robot_1, _, _, (stored, *_, waiting), _, on_server = department
    content = content_for_registry_trial(robot_1, stored.id)
    assert (content.session_number, content.trial_number) == (1, stored.number)
    if on_server:
        with pytest.raises(AppError, match="is on station robot-2, not yet in the trial "
                                           "store"):
            content_for_registry_trial(robot_1, waiting.id)


def test_the_plans_dose_counts_another_station_s_run_from_the_store(department):
    """A session plan run at robot-2: robot-1's Progress (and its PDF) counts its movements
    from the store's copies; it counted nothing ('does not exist')."""
    from app.plans.dose import run_dose
    from app.plans.templates import load_template
    from app.records.registry import Registry

    robot_1, code, _, (stored, *_), _, _ = department
    # robot-2 on the same registry (its data folder does not matter to a plan run)
    robot_2 = Registry(robot_1.data_dir, server=robot_1.server, station="robot-2")
    run = robot_2.begin_plan_run(
        robot_2.save_plan(code, load_template("first-session").plan).id)
    robot_2.record_plan_trial(run, 1, 1, stored.id, 3.0)
    robot_2.end_plan_run(run, "stopped", "the therapist pressed Stop")
    dose = run_dose(robot_1, run)
    assert dose.notes == []
    assert dose.movements > 0
