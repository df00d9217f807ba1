"""Several stations on one registry (issue 32; app.records.registry.provenance): each trial
and plan run says which station recorded it, each finished trial its file's SHA-256; a
station that starts again finishes only its own interrupted trials and runs. On both
engines (tests/app/records/conftest.py)."""

from __future__ import annotations

import time

import pytest

from app.errors import InvalidRecordError, RegistryError
from app.plans.templates import load_template
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.provenance import file_checksum, station_id
from app.trials.finalize import finalize_trial, finish_interrupted
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT
from tests.app.records.history import registry_at

PARAMS = THESIS_SUBJECT.replace(duration_s=2.0)


def test_a_station_id_is_the_environments_or_the_host_name_and_refused_when_unfit():
    assert station_id({"REHAB_STATION": "robot-2"}) == "robot-2"
    assert 1 <= len(station_id({})) <= 64
    assert station_id({"REHAB_STATION": ""}) == station_id({})  # empty: not set
    for bad in ("-robot", "robot 2", "r" * 65, "robot/2"):
        with pytest.raises(InvalidRecordError, match=r"REHAB_STATION .* is not a station"):
            station_id({"REHAB_STATION": bad})
    with pytest.raises(InvalidRecordError, match="station 'a b' is not a station id"):
        Registry(DataDir("/nonexistent-never-made"), station="a b")


def test_each_trial_and_run_names_its_station_and_a_finished_file_its_checksum(
        open_registry, tmp_path):
    robot_1 = open_registry(station="robot-1")
    code = robot_1.create_patient("Ada", "Example").code
    begun = robot_1.begin_trial(code, PARAMS, backend="simulator")
    save(simulate(PARAMS, patient="healthy"), begun.path, subject_code=code)
    done = finalize_trial(robot_1, begun.trial_id)
    trial = robot_1.trial(done.trial_id)
    assert (trial.station, trial.checksum) == ("robot-1", file_checksum(begun.path))
    assert robot_1.verify_trial_file(trial) is None
    run = robot_1.begin_plan_run(robot_1.save_plan(code, load_template("reaching").plan).id)
    assert robot_1.plan_run(run).station == "robot-1"

    with open(begun.path, "r+b") as file:  # a byte changed after the end
        file.seek(-1, 2)
        last = file.read(1)
        file.seek(-1, 2)
        file.write(bytes([last[0] ^ 1]))
    assert "is not the one recorded: its SHA-256 is" in robot_1.verify_trial_file(trial)
    begun.path.unlink()
    assert "cannot be read" in robot_1.verify_trial_file(trial.id)
    with pytest.raises(InvalidRecordError, match="checksum 'abc'"):
        robot_1.finish_trial(robot_1.begin_trial(code, PARAMS, backend="simulator").trial_id,
                             "complete", {}, checksum="abc")


def test_a_station_starting_again_finishes_only_its_own_trials_and_runs(open_registry,
                                                                        tmp_path):
    """Another station's trial is recording into a file this one cannot see, and its plan
    is going: neither is touched."""
    robot_1 = open_registry(station="robot-1")
    robot_2 = open_registry(station="robot-2")
    code = robot_1.create_patient("Ada", "Example").code
    other = robot_1.create_patient("Bob", "Example").code
    mine = robot_1.begin_trial(code, PARAMS, backend="simulator")
    theirs = robot_2.begin_trial(other, PARAMS, backend="simulator")
    plan = robot_1.save_plan(code, load_template("reaching").plan)
    my_run, their_run = robot_1.begin_plan_run(plan.id), robot_2.begin_plan_run(plan.id)

    lines = finish_interrupted(robot_1, now=time.time() + 3600)

    assert robot_1.trial(mine.trial_id).status == "recording_lost"  # its file is missing
    assert robot_1.trial(theirs.trial_id).status == "recording"
    assert robot_1.plan_run(my_run).status == "interrupted"
    assert robot_1.plan_run(their_run).status == "running"
    assert len(lines) == 2
    assert f"plan run {my_run} was interrupted" in lines[1]
    assert [t.id for t in robot_2.unfinished_trials()] == [theirs.trial_id]
    assert robot_2.interrupt_runs() == [their_run]


def test_a_v9_registry_is_migrated_sealing_the_new_columns_and_a_damaged_row_is_refused(
        tmp_path):
    def v9(folder, damage: bool) -> DataDir:
        with registry_at(folder, 9) as conn:
            conn.execute("INSERT INTO patients (code, created_at) VALUES ('PABC234', 'c')")
            conn.execute("INSERT INTO sessions (patient_id, number, date) "
                         "VALUES (1, 1, '2024-01-01')")
            conn.execute("INSERT INTO trials (session_id, number, parameters, file, metrics, "
                         "status, started_at) VALUES (1, 1, '{}', 'f', '{}', 'complete', "
                         "'2024-01-01T10:00:00+00:00')")
            if damage:  # written past the seal's trigger, as a bit flipped on the disk
                conn.execute("DROP TRIGGER trials_sealed_on_update")
                conn.execute("UPDATE trials SET status = 'faulted'")
        return DataDir(folder)

    registry = Registry(v9(tmp_path / "sound", damage=False))
    (trial,) = registry.trials_for_patient("PABC234")
    assert (trial.status, trial.station, trial.checksum) == ("complete", None, None)
    assert registry.integrity_check() == []
    assert list((tmp_path / "sound").glob("registry.sqlite3.v9-*.bak"))
    with pytest.raises(RegistryError, match="trials_rows_match_their_seals"):
        Registry(v9(tmp_path / "damaged", damage=True))
