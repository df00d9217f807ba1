"""The registry: records, numbering as the registration tab does it, migration, two consoles.

Tests taking `registry` (or `open_registry`) run on both engines, SQLite and PostgreSQL
(tests/app/records/conftest.py); those of the SQLite file itself (its migration, a damaged
or foreign file) on SQLite."""

from __future__ import annotations

import contextlib
import datetime
import itertools
import json
import logging
import math
import multiprocessing as mp
import os
import sqlite3
from pathlib import Path

import pytest
import sqlalchemy as sa

from app.errors import (
    DuplicateNumberError,
    InvalidRecordError,
    PatientNotFound,
    RegistryError,
    SchemaError,
    SessionNotFound,
    TrialNotFound,
)
from app.records.datadir import CODE_PATTERN, DataDir
from app.records.registry import (
    KEY_PARAMETERS,
    MIGRATE_V1_TO_V2,
    SCHEMA_V1,
    SCHEMA_VERSION,
    Registry,
)
from core.trial import TrialParameters

ROOT = Path(__file__).resolve().parents[3]
UTC = datetime.UTC
T0 = datetime.datetime(2024, 5, 2, 9, 30, tzinfo=UTC)
CHILD_TIMEOUT_S = 60.0


@pytest.fixture
def registry(open_registry) -> Registry:
    return open_registry()


@pytest.fixture
def patient(registry):
    return registry.create_patient("Ada", "Lovelace", side="left", body_mass_kg=62.0)


def begin(registry, code, **kwargs):
    kwargs.setdefault("backend", "simulator")
    return registry.begin_trial(code, kwargs.pop("parameters", TrialParameters()), **kwargs)


def query(path: Path, sql: str, args: tuple = ()) -> list[tuple]:
    with contextlib.closing(sqlite3.connect(path)) as conn:
        return conn.execute(sql, args).fetchall()


# -- patients ------------------------------------------------------------------------------

def test_patient_round_trip_with_a_generated_pseudonymous_code(registry):
    created = registry.create_patient(
        "Émile", "Durand", birth_year=1951, side="right", body_mass_kg=78.5, upper_arm_m=0.31,
        forearm_m=0.27, shoulder_m=(-0.12, 0.71), notes="left MCA stroke, 2023",
    )
    assert CODE_PATTERN.fullmatch(created.code)
    assert registry.patient(created.code) == created
    assert created.shoulder_m == (-0.12, 0.71)
    assert created.created_at.tzinfo is not None
    assert created.display_name == "Durand, Émile"
    params = TrialParameters().replace(**created.trial_overrides())
    assert (params.body_mass_kg, params.upper_arm_m, params.side) == (78.5, 0.31, "right")


def test_codes_are_unique_and_use_only_unambiguous_characters(registry):
    codes = {registry.create_patient().code for _ in range(40)}
    assert len(codes) == 40
    assert not any(set(code[1:]) & set("ILOU") for code in codes)


def test_update_patient_keeps_code_and_refuses_bad_values(registry, patient):
    updated = registry.update_patient(patient.code, forearm_m=0.26, notes="  shoulder pain ")
    assert (updated.code, updated.created_at) == (patient.code, patient.created_at)
    assert (updated.forearm_m, updated.notes, updated.body_mass_kg) == (0.26, "shoulder pain",
                                                                          62.0)
    with pytest.raises(InvalidRecordError, match=r"body_mass_kg = 400 .*\[20, 250\] kg"):
        registry.update_patient(patient.code, body_mass_kg=400)
    with pytest.raises(InvalidRecordError, match="code cannot be changed"):
        registry.update_patient(patient.code, code="PAAAAAA")
    with pytest.raises(InvalidRecordError, match="side = 'up'"):
        registry.create_patient("A", "B", side="up")
    assert registry.patient(patient.code) == updated


def test_search_by_name_fragment_ignores_case_and_accents_and_finds_codes(registry):
    a = registry.create_patient("Jürgen", "Müller")
    b = registry.create_patient("Anna", "Muller-Smith")
    c = registry.create_patient("Anna", "Berg")
    d = registry.create_patient()  # a study that keeps no names
    assert registry.search_patients("mull") == [a, b]
    assert registry.search_patients("anna MULL") == [b]
    assert c in registry.search_patients(c.code.lower()[:5])
    assert registry.search_patients(c.code) == [c]
    assert registry.search_patients(d.code) == [d]
    assert registry.find_patients("jurgen", "MÜLLER") == [a]
    assert registry.find_patients("Anna", "Muller") == []
    assert len(registry.search_patients("")) == 4


def test_unknown_patient_session_and_trial_are_named_in_the_error(registry, patient):
    with pytest.raises(PatientNotFound, match="no patient has the code 'PZZZZZZ'"):
        registry.patient("PZZZZZZ")
    with pytest.raises(SessionNotFound, match=f"patient {patient.code} has no session 4"):
        registry.trials(patient.code, 4)
    with pytest.raises(TrialNotFound, match="no trial has the id 99"):
        registry.finish_trial(99, "complete", {})


# -- registration numbering ------------------------------------------------------------------

def test_numbering_continues_today_and_opens_a_new_session_on_a_new_day(registry, patient):
    code = patient.code
    day1 = T0.astimezone().date()
    suggestion = registry.suggest_registration(code, today=day1)
    assert (suggestion.session_number, suggestion.trial_number, suggestion.new_session) == (
        1, 1, True)
    first = begin(registry, code, started_at=T0)
    second = begin(registry, code, started_at=T0 + datetime.timedelta(minutes=5))
    assert [(t.session_number, t.trial_number) for t in (first, second)] == [(1, 1), (1, 2)]
    assert registry.suggest_registration(code, today=day1).trial_number == 3

    next_day = T0 + datetime.timedelta(days=1)
    suggestion = registry.suggest_registration(code, today=next_day.astimezone().date())
    assert (suggestion.session_number, suggestion.trial_number) == (2, 1)
    third = begin(registry, code, started_at=next_day)
    assert (third.session_number, third.trial_number) == (2, 1)
    assert [s.number for s in registry.sessions(code)] == [1, 2]
    assert registry.sessions(code)[0].n_trials == 2


def test_confirmed_numbers_are_used_and_a_repeat_or_a_gap_is_refused_naming_the_next(
        registry, patient):
    """Numbers have no gaps and no repeats (schema v9, app.records.registry.numbering): a
    typed number must be the next one; the refusal names it, on both engines alike."""
    code = patient.code
    with pytest.raises(DuplicateNumberError,
                       match=rf"patient {code} has no session yet: session 3 would leave a "
                             "gap; use 1, the next free number"):
        begin(registry, code, session_number=3, trial_number=1, started_at=T0)
    begin(registry, code, session_number=1, trial_number=1, started_at=T0)
    begin(registry, code, session_number=1, trial_number=2, started_at=T0)
    assert registry.next_trial_number(code, 1) == 3
    with pytest.raises(DuplicateNumberError,
                       match=rf"patient {code} session 1 already has a trial 2 .*use 3"):
        begin(registry, code, session_number=1, trial_number=2)
    with pytest.raises(DuplicateNumberError,
                       match=rf"patient {code} session 1 has trials up to 2 only: trial 5 "
                             "would leave a gap; use 3"):
        begin(registry, code, session_number=1, trial_number=5)
    begun = begin(registry, code, session_number=1, trial_number=3)
    assert (begun.session_number, begun.trial_number) == (1, 3)
    assert registry.next_session_number(code) == 2

    with pytest.raises(DuplicateNumberError, match=r"already has a session 1 .*use 2.*continue"):
        registry.open_session(code, number=1)
    with pytest.raises(DuplicateNumberError, match=r"has sessions up to 1 only: session 4 would "
                                                   "leave a gap; use 2"):
        registry.open_session(code, number=4)
    session = registry.open_session(code, therapist="R. Ortiz", location="room 2")
    assert (session.number, session.therapist, session.location) == (2, "R. Ortiz", "room 2")
    with pytest.raises(InvalidRecordError, match="trial number 0"):
        begin(registry, code, trial_number=0)
    assert [t.number for t in registry.trials(code, 1)] == [1, 2, 3]
    assert registry.sessions(code)[1].n_trials == 0


def test_refused_registration_leaves_nothing_behind(registry, patient):
    begin(registry, patient.code, session_number=1, trial_number=1)
    with pytest.raises(DuplicateNumberError):
        begin(registry, patient.code, session_number=1, trial_number=1)
    with pytest.raises(InvalidRecordError, match="patient_kind 'zombie'"):
        begin(registry, patient.code, patient_kind="zombie")
    with pytest.raises(InvalidRecordError, match="radius_m"):
        begin(registry, patient.code, parameters={"radius_m": 5.0})
    assert len(registry.trials_for_patient(patient.code)) == 1
    assert registry.integrity_check() == []


# -- trials --------------------------------------------------------------------------------

def test_trial_round_trip_with_relative_file_and_json_metrics(registry, patient):
    params = TrialParameters(radius_m=0.12, duration_s=5.0, controller="ctpid")
    begun = begin(registry, patient.code, parameters=params, patient_kind="spastic",
                  started_at=T0)
    assert begun.file == (f"trials/{patient.code}/{patient.code}_S001_T001_"
                          "20240502T093000Z.h5")
    assert begun.path == registry.data_dir.root / begun.file
    assert begun.path.parent.is_dir()
    running = registry.trial(begun.trial_id)
    assert (running.status, running.ended_at, running.metrics) == ("recording", None, {})

    metrics = {"rmse_x_m": 0.0123, "directional_performance_pct": 81.5, "sparc": math.nan,
               "a_metric_added_next_year": 3}
    done = registry.finish_trial(begun.trial_id, "stopped_early", metrics,
                                 ended_at=T0 + datetime.timedelta(seconds=42))
    assert done.status == "stopped_early"
    assert done.metrics["rmse_x_m"] == 0.0123
    assert math.isnan(done.metrics["sparc"])
    assert done.metrics["a_metric_added_next_year"] == 3.0
    assert done.parameters == params.to_dict()
    assert done.trial_parameters() == params
    assert (done.backend, done.patient_kind) == ("simulator", "spastic")
    assert done.ended_at - done.started_at == datetime.timedelta(seconds=42)
    assert registry.trial_path(done) == begun.path
    with registry._read() as conn:  # the row as stored, on either engine
        stored = tuple(conn.exec_driver_sql("SELECT file, metrics FROM trials").one())
    assert stored[0] == begun.file
    assert not os.path.isabs(stored[0])
    assert json.loads(stored[1])["sparc"] is None  # JSON has no NaN

    with pytest.raises(RegistryError, match=r"already finished .*update_metrics"):
        registry.finish_trial(begun.trial_id, "complete", {})
    again = registry.update_metrics(begun.trial_id, {"ldlj": -7.5})
    assert again.metrics["ldlj"] == -7.5
    assert again.metrics["rmse_x_m"] == 0.0123


def test_finish_refuses_unknown_status_bad_metrics_and_time_travel(registry, patient):
    begun = begin(registry, patient.code, started_at=T0)
    with pytest.raises(InvalidRecordError, match="status 'done'"):
        registry.finish_trial(begun.trial_id, "done", {})
    with pytest.raises(InvalidRecordError, match="metric name 'rmse x'"):
        registry.finish_trial(begun.trial_id, "complete", {"rmse x": 1.0})
    with pytest.raises(InvalidRecordError, match="metric rmse_x_m = 'low'"):
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": "low"})
    with pytest.raises(InvalidRecordError, match="before it started"):
        registry.finish_trial(begun.trial_id, "complete", {},
                              ended_at=T0 - datetime.timedelta(seconds=1))
    assert registry.trial(begun.trial_id).status == "recording"


def test_previous_trial_for_change_since_last_trial_and_last_session(registry, patient):
    code = patient.code
    small, large = TrialParameters(radius_m=0.10), TrialParameters(radius_m=0.14)
    ids = {}
    plan = [(1, small, "complete"), (1, large, "complete"), (2, small, "complete"),
            (2, small, "faulted"), (2, large, "complete")]
    for i, (session, params, status) in enumerate(plan):
        begun = begin(registry, code, parameters=params, session_number=session,
                      started_at=T0 + datetime.timedelta(days=session, minutes=i))
        registry.finish_trial(begun.trial_id, status, {"rmse_x_m": 0.01 * (i + 1)})
        ids[(session, begun.trial_number)] = begun.trial_id

    last = ids[(2, 3)]
    assert registry.previous_trial(last).id == ids[(2, 1)]  # the faulted one is skipped
    assert registry.previous_trial(last, statuses=("complete", "faulted")).id == ids[(2, 2)]
    assert registry.previous_trial(last, same_parameters=True).id == ids[(1, 2)]
    assert registry.previous_trial(last, earlier_session=True).id == ids[(1, 2)]
    assert registry.previous_trial(ids[(2, 1)], earlier_session=True,
                                   same_parameters=True).id == ids[(1, 1)]
    assert registry.previous_trial(ids[(1, 1)]) is None
    assert len(KEY_PARAMETERS) == 8


def test_previous_trial_of_the_same_shape_skips_a_circle_done_in_between(registry, patient):
    """A report compares like with like: D, circle, D → the last D's previous is the
    first D, not the circle."""
    ids = []
    for i, shape in enumerate(("d", "circle", "d")):
        begun = begin(registry, patient.code, parameters=TrialParameters(shape=shape),
                      started_at=T0 + datetime.timedelta(minutes=i))
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.01})
        ids.append(begun.trial_id)
    assert registry.previous_trial(ids[2]).id == ids[1]
    assert registry.previous_trial(ids[2], same_shape=True).id == ids[0]
    assert registry.previous_trial(ids[1], same_shape=True) is None


def test_trials_for_patient_are_in_session_then_trial_order(registry, patient):
    for session, trial in [(1, 1), (1, 2), (2, 1), (1, 3), (2, 2)]:
        begin(registry, patient.code, session_number=session, trial_number=trial)
    other = registry.create_patient("Other", "Patient")
    begin(registry, other.code)
    got = [(t.session_number, t.number) for t in registry.trials_for_patient(patient.code)]
    assert got == [(1, 1), (1, 2), (1, 3), (2, 1), (2, 2)]


# -- names never on disk -----------------------------------------------------------------------

def test_no_name_appears_in_any_file_or_folder_the_registry_produces(tmp_path, caplog):
    names = ["Zebulon", "Quintavius", "O'Hara", "Nguyễn", "Smith"]
    registry = Registry(DataDir(tmp_path / "data"))
    caplog.set_level(logging.DEBUG)
    for first, last in itertools.pairwise(names):
        patient = registry.create_patient(first, last, notes=f"{first} {last}")
        registry.update_patient(patient.code, first_name=first + "a")
        for _ in range(2):
            begun = begin(registry, patient.code)
            begun.path.write_bytes(b"trial")
            registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.01})
        report = registry.data_dir.report_path(patient.code, begun.session_number,
                                               begun.trial_number, begun.started_at)
        assert patient.code in report.name
    registry.backup(registry.data_dir.ensure("exports") / "registry-copy.sqlite3")

    produced = [p.relative_to(tmp_path) for p in tmp_path.rglob("*")]
    assert any(p.suffix == ".h5" for p in produced)
    for path in produced:
        for name in names:
            assert name.casefold() not in str(path).casefold(), path
    for record in caplog.records:
        for name in names:
            assert name.casefold() not in record.getMessage().casefold(), record.getMessage()


# -- schema and migration ---------------------------------------------------------------------

def make_v1_registry(folder: Path) -> Path:
    """A registry as console v1 left it: its DDL, user_version 1, one finished trial."""
    folder.mkdir(parents=True)
    path = folder / "registry.sqlite3"
    with contextlib.closing(sqlite3.connect(path, isolation_level=None)) as conn:
        for statement in SCHEMA_V1:
            conn.execute(statement)
        conn.execute("PRAGMA user_version = 1")
        conn.execute("INSERT INTO patients (code, first_name, last_name, side, created_at) "
                     "VALUES ('PABC234', 'Old', 'Record', 'left', '2023-01-05T10:00:00+00:00')")
        conn.execute("INSERT INTO sessions (patient_id, number, date, therapist) "
                     "VALUES (1, 1, '2023-01-05', 'K. Lee')")
        conn.execute(
            "INSERT INTO trials (session_id, number, parameters, file, metrics, status, "
            "started_at, ended_at) VALUES (1, 1, ?, "
            "'trials/PABC234/PABC234_S001_T001_20230105T100500Z.h5', ?, 'complete', "
            "'2023-01-05T10:05:00+00:00', '2023-01-05T10:05:40+00:00')",
            (json.dumps(TrialParameters().to_dict()), json.dumps({"rmse_x_m": 0.02})),
        )
    return path


def test_a_v1_registry_is_backed_up_and_migrated_keeping_its_records(tmp_path):
    path = make_v1_registry(tmp_path / "data")
    registry = Registry(DataDir(tmp_path / "data"))

    assert registry.schema_version() == SCHEMA_VERSION == 13
    assert query(path, "SELECT count(*) FROM proposals") == [(0,)]
    assert query(path, "PRAGMA journal_mode") == [("wal",)]
    trial_columns = {row[1] for row in query(path, "PRAGMA table_info(trials)")}
    session_columns = {row[1] for row in query(path, "PRAGMA table_info(sessions)")}
    assert {"backend", "end_reason", "assistance"} <= trial_columns
    assert "location" in session_columns
    old = registry.trials_for_patient("PABC234")
    assert len(old) == 1
    assert (old[0].backend, old[0].metrics, old[0].status) == (None, {"rmse_x_m": 0.02},
                                                                "complete")
    assert old[0].end_reason == ""
    assert old[0].assistance is None  # only the built level is known
    assert registry.session("PABC234", 1).location == ""
    assert registry.patient("PABC234").last_name == "Record"

    begun = begin(registry, "PABC234", session_number=1, backend="quanser")
    assert begun.trial_number == 2
    assert registry.trial(begun.trial_id).backend == "quanser"

    backups = list(path.parent.glob("registry.sqlite3.v1-*.bak"))
    assert len(backups) == 1
    assert query(backups[0], "PRAGMA user_version") == [(1,)]
    assert registry.integrity_check() == []
    Registry(DataDir(tmp_path / "data"))  # opening again migrates nothing more
    assert len(list(path.parent.glob("*.bak"))) == 1


def test_a_failing_migration_changes_nothing(tmp_path):
    path = make_v1_registry(tmp_path / "data")
    # A hand-made column of the same name makes v2's first step fail.
    query(path, "ALTER TABLE trials ADD COLUMN backend TEXT")
    with pytest.raises(SchemaError, match=r"schema v2 \(duplicate column name: backend\); "
                                           r"nothing was changed, it is still v1"):
        Registry(DataDir(tmp_path / "data"))
    assert query(path, "PRAGMA user_version") == [(1,)]
    assert "location" not in {row[1] for row in query(path, "PRAGMA table_info(sessions)")}
    assert MIGRATE_V1_TO_V2[0].startswith("ALTER TABLE trials ADD COLUMN backend")


def test_a_newer_schema_or_a_foreign_file_is_refused_with_advice(tmp_path):
    data = DataDir(tmp_path / "newer")
    Registry(data)
    query(data.registry_path, f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    with pytest.raises(SchemaError, match=rf"schema v{SCHEMA_VERSION + 1}, written by a newer "
                                          r"console.*Update"):
        Registry(data)

    other = DataDir(tmp_path / "foreign")
    other.ensure()
    other.registry_path.write_bytes(b"these are not the droids " * 100)
    with pytest.raises(SchemaError, match="not a registry database"):
        Registry(other)


# -- two consoles on one data folder ----------------------------------------------------------

def _begin_many(folder: str, server: str | None, code: str, ready, go, results) -> None:
    registry = Registry(DataDir(Path(folder)), server=server and sa.make_url(server))
    ready.put(os.getpid())
    go.wait(CHILD_TIMEOUT_S)
    numbers = []
    try:
        for _ in range(50):
            begun = registry.begin_trial(code, TrialParameters(), backend="simulator",
                                         session_number=1)
            numbers.append((begun.trial_number, begun.file))
    except Exception as exc:  # reported to the test rather than lost in the child
        results.put(f"{type(exc).__name__}: {exc}")
        raise
    results.put(numbers)


@pytest.fixture
def spawn(monkeypatch):
    """A spawn context whose children can import this module (and so its targets)."""
    monkeypatch.syspath_prepend(str(ROOT))
    return mp.get_context("spawn")


def _at_once(spawn, target, argses: list[tuple]) -> list:
    """`target(*args, ready, go, results)` in a process of its own for each of `argses`,
    let go together once all are ready; what each put in `results` (no errors: a child's
    error is a string there, and fails the test)."""
    ready, results, go = spawn.Queue(), spawn.Queue(), spawn.Event()
    workers = [spawn.Process(target=target, args=(*args, ready, go, results),
                             name=f"console-{i}") for i, args in enumerate(argses)]
    for worker in workers:
        worker.start()
    try:
        for _ in workers:
            ready.get(timeout=CHILD_TIMEOUT_S)
        go.set()
        batches = [results.get(timeout=CHILD_TIMEOUT_S) for _ in workers]
    finally:
        for worker in workers:
            worker.join(CHILD_TIMEOUT_S)
            if worker.is_alive():
                worker.kill()
                worker.join()
        for q in (ready, results):
            q.close()
            q.join_thread()
    assert [batch for batch in batches if isinstance(batch, str)] == []
    assert [w.exitcode for w in workers] == [0] * len(workers)
    return batches


def test_two_processes_numbering_at_once_take_distinct_numbers(tmp_path, spawn,
                                                               open_registry):
    """Two consoles on one data folder (SQLite), two stations on one server (PostgreSQL)."""
    data = DataDir(tmp_path / "data")
    registry = open_registry(data)
    code = registry.create_patient("Two", "Consoles").code
    server = (registry.server.render_as_string(hide_password=False)
              if registry.server is not None else None)
    batches = _at_once(spawn, _begin_many, [(str(data.root), server, code)] * 2)

    numbers = sorted(n for batch in batches for n, _ in batch)
    assert numbers == list(range(1, 101))
    assert len({f for batch in batches for _, f in batch}) == 100
    registry = open_registry(data)
    assert registry.integrity_check() == []
    assert [t.number for t in registry.trials(code, 1)] == list(range(1, 101))


def _open_sessions(folder: str, server: str | None, code: str, record: str, ready, go,
                   results) -> None:
    """25 times: the patient's next session number read, then a scale (`record` "scale")
    or a trial recorded in it, as a therapist types the number shown a moment before."""
    registry = Registry(DataDir(Path(folder)), server=server and sa.make_url(server))
    ready.put(os.getpid())
    go.wait(CHILD_TIMEOUT_S)
    numbers = []
    try:
        for i in range(25):
            number = registry.next_session_number(code)
            if record == "scale":
                numbers.append(registry.record_scale(code, number, "pain", total=i % 11,
                                                     rater="K. Lee").session_number)
            else:
                numbers.append(registry.begin_trial(code, TrialParameters(),
                                                    backend="simulator",
                                                    session_number=number).session_number)
    except Exception as exc:  # reported to the test rather than lost in the child
        results.put(f"{type(exc).__name__}: {exc}")
        raise
    results.put((record, numbers))


def test_a_scale_and_a_trial_opening_sessions_at_once_share_them_without_gaps(
        tmp_path, spawn, open_registry):
    """A station recording the Fugl-Meyer that opens a session while another starts the
    session's first trial: one session, numbered once (the scale's number is allocated
    where the trial's is, the patient's row locked), on both engines."""
    data = DataDir(tmp_path / "data")
    registry = open_registry(data)
    code = registry.create_patient("Two", "Stations").code
    server = (registry.server.render_as_string(hide_password=False)
              if registry.server is not None else None)
    batches = _at_once(spawn, _open_sessions, [(str(data.root), server, code, record)
                                               for record in ("scale", "trial")])

    registry = open_registry(data)
    sessions = registry.sessions(code)
    assert [s.number for s in sessions] == list(range(1, len(sessions) + 1))  # no gap
    assert sum(s.n_trials for s in sessions) == 25
    entries = registry.scale_entries(code)
    assert len(entries) == 25
    said = dict(batches)
    assert sorted(said["scale"]) == [e.session_number for e in entries]
    trials = registry.trials_for_patient(code)
    assert sorted(said["trial"]) == [t.session_number for t in trials]
    assert registry.integrity_check() == []


@pytest.mark.parametrize("content", [b"", b"\x00" * 4096, b"PK\x03\x04 a zip, not a registry"])
def test_an_empty_or_foreign_registry_file_is_refused_and_kept_as_it_was(tmp_path, content):
    """A 0-byte registry used to be taken for a new one: every patient gone, every trial
    file orphaned."""
    data = DataDir(tmp_path / "data")
    data.ensure()
    data.registry_path.write_bytes(content)
    with pytest.raises(RegistryError,
                       match=r"not a registry database \((empty|not a SQLite).*backup"):
        Registry(data)
    assert data.registry_path.read_bytes() == content  # nothing was changed
    kept = list(data.root.glob("registry.sqlite3.damaged-*"))
    assert len(kept) == 1
    assert kept[0].read_bytes() == content


def test_a_missing_registry_beside_trial_files_is_refused(tmp_path):
    data = DataDir(tmp_path / "data")
    registry = Registry(data)
    code = registry.create_patient("Ada", "Example", body_mass_kg=70.0).code
    begun = registry.begin_trial(code, TrialParameters(), backend="simulator")
    begun.path.parent.mkdir(parents=True, exist_ok=True)
    begun.path.write_bytes(b"a trial")
    data.registry_path.unlink()
    for suffix in ("-wal", "-shm"):
        data.registry_path.with_name("registry.sqlite3" + suffix).unlink(missing_ok=True)
    with pytest.raises(RegistryError, match=r"missing, but .* holds 1 trial file"):
        Registry(data)
    assert not data.registry_path.exists()


def test_a_used_number_is_refused_in_words_for_people(tmp_path):
    """The refusal used to show a raw timestamp with microseconds and advise leaving a
    spin box 'empty'."""
    import re

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Example").code
    registry.begin_trial(code, TrialParameters(), backend="simulator", session_number=1,
                         trial_number=1)
    with pytest.raises(DuplicateNumberError) as refused:
        registry.begin_trial(code, TrialParameters(), backend="simulator", session_number=1,
                             trial_number=1)
    text = str(refused.value)
    assert re.search(r"started \d{2} \w{3} \d{4} \d{2}:\d{2}\)", text)
    assert not re.search(r"\d{2}:\d{2}:\d{2}\.\d+", text)
    assert "empty" not in text
    assert "use 2, the next free number" in text
