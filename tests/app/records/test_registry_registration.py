"""What a trial's registration asks of the registry, on both engines (issue 32: registration
p99 < 10 ms with 8 stations writing; bench/registration.py, docs/performance.md): the
statements each call sends (each a round trip to a server), the indexes that find a
patient's pending proposal (schema v12, by patient since v13), and older registries brought
to today's keeping every record."""

from __future__ import annotations

import contextlib
import datetime
import json
import re
import sqlite3

import pytest
import sqlalchemy as sa

from app.errors import RegistryError
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.patients import patient_id
from app.records.registry.proposals import PENDING
from app.records.registry.sessions import carrying
from app.records.registry.statements import execute
from core.trial import TrialParameters
from tests.app.records.history import registry_at

PARAMS = TrialParameters()


class Sent:
    """The statements a registry sends and the transactions it opens (a connection taken
    from its engine's pool: on the server, BEGIN ... COMMIT around them; their round trips
    are tests/app/records/postgres/test_postgres_round_trips.py's), counted by SQLAlchemy's
    events during `with sent.counting():`."""

    def __init__(self, registry: Registry) -> None:
        self.statements: list[str] = []
        self.transactions = 0
        for engine in {registry._writer, registry._reader_engine}:
            sa.event.listen(engine, "before_cursor_execute", self._statement)
            sa.event.listen(engine.pool, "checkout", self._transaction)

    def _statement(self, conn, cursor, statement, *_) -> None:
        if statement.startswith("BEGIN"):  # the server's transaction, begun by the registry
            return
        self.statements.append(" ".join(statement.split())[:60])

    def _transaction(self, *_) -> None:
        self.transactions += 1

    @contextlib.contextmanager
    def counting(self):
        self.statements, self.transactions = [], 0
        yield self


def test_each_call_of_a_trials_registration_sends_the_fewest_statements(open_registry):
    """begin_trial: the patient's row lock, what their sessions say (the latest, the one
    asked for, the next trial number) and their pending proposal in one read, the
    insert(s), the proposal's decision; finish_trial and record_proposal: one statement
    each, in one transaction, the row they return as written (RETURNING), never read again.
    Before: 7, 4 and 4 in two transactions; then begin_trial 5, the pending proposal read
    apart after the insert."""
    registry = open_registry()
    code = registry.create_patient("Ada", "Example").code
    sent = Sent(registry)
    today = datetime.datetime.now(datetime.UTC)
    first = registry.begin_trial(code, PARAMS, backend="simulator", started_at=today)
    registry.finish_trial(first.trial_id, "complete", {"rmse_x_m": 0.01})
    registry.record_proposal(first.trial_id, {"assistance_level": 0.5})
    with sent.counting():  # today's session goes on; the proposal is decided
        begun = registry.begin_trial(code, PARAMS, backend="simulator", started_at=today)
    assert (len(sent.statements), sent.transactions) == (4, 1), sent.statements
    with sent.counting():
        done = registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.02})
    assert (len(sent.statements), sent.transactions) == (1, 1), sent.statements
    assert done == registry.trial(begun.trial_id)
    with sent.counting():
        stored = registry.record_proposal(begun.trial_id, {"assistance_level": 0.4})
    assert (len(sent.statements), sent.transactions) == (1, 1), sent.statements
    assert stored == registry.proposal(begun.trial_id)
    replaced = registry.record_proposal(begun.trial_id, {"assistance_level": 0.3})
    assert (replaced.proposal, replaced.decision) == ({"assistance_level": 0.3}, "pending")
    assert registry.integrity_check() == []  # every row written so sealed as it is
    with sent.counting():  # the numbers as the window gives them: a new session
        registry.begin_trial(code, PARAMS, backend="simulator", session_number=2,
                             trial_number=1, started_at=today)
    assert (len(sent.statements), sent.transactions) == (5, 1), sent.statements
    with sent.counting():  # and the next trial of it (no proposal waits: none decided)
        registry.begin_trial(code, PARAMS, backend="simulator", session_number=2,
                             trial_number=2, started_at=today)
    assert (len(sent.statements), sent.transactions) == (3, 1), sent.statements


def _plan(registry: Registry, engine: str, statement: str, values: tuple) -> str:
    """How the engine would run `statement`: on the server as it would in a registry of a
    department's size, where reading a whole table is never the cheaper way (a test's
    tables are a few rows, which the server reads whole whatever the indexes)."""
    with registry._read() as conn:
        if engine == "postgresql":
            conn.exec_driver_sql("SET LOCAL enable_seqscan = off")
            rows = execute(conn, "EXPLAIN " + statement, values).fetchall()
        else:
            rows = execute(conn, "EXPLAIN QUERY PLAN " + statement, values).fetchall()
    return "\n".join(str(row[-1]) for row in rows)


def test_the_pending_proposal_and_a_decided_ones_trial_are_found_by_their_indexes(
        open_registry, registry_engine):
    """Before v12 the server read every proposal of the patient's trials to find the pending
    one, and a withdrawn trial's decision was looked for in every proposal of the registry
    (`Proposals._trial_withdrawn`), on both engines. Since v13 the pending ones are indexed
    by their patient, on both engines."""
    registry = open_registry()
    code = registry.create_patient("Ada", "Example").code
    for _ in range(3):
        begun = registry.begin_trial(code, PARAMS, backend="simulator")
        registry.finish_trial(begun.trial_id, "complete", {})
        registry.record_proposal(begun.trial_id, {"assistance_level": 0.5})
    with registry._read() as conn:
        patient = patient_id(conn, registry.where, code)
    plan = _plan(registry, registry_engine, PENDING, (patient, -1) * 2)
    assert "proposals_pending_by_patient" in plan
    assert "proposals_by_next_trial" in plan
    # as begin_trial reads it, in the round trip that reads the patient's sessions
    carried = registry._read_at_start(patient, json.dumps(PARAMS.to_dict()))
    plan = _plan(registry, registry_engine, carrying(carried),
                 (patient, None, patient, *carried.values))
    assert "proposals_pending_by_patient" in plan
    assert "proposals_by_next_trial" in plan
    withdrawn = _plan(registry, registry_engine, "UPDATE proposals SET decision = 'pending', "
                      "next_trial_id = NULL, decided_at = NULL WHERE next_trial_id = ?", (1,))
    assert "proposals_by_next_trial" in withdrawn
    assert registry.pending_proposal(code).trial_id == begun.trial_id


def test_a_patients_pending_proposal_is_found_from_their_trials_not_everyones(
        open_registry, registry_engine):
    """Every patient of a department has a pending proposal (their last trial's): the
    search starts from the patient's trials, whatever the registry holds besides. On the
    server, with the pending ones found by a join, it started from every patient's pending
    proposal, reading each one's trial and session (5-13 ms at 1,000 patients, more than
    before the index): counted here in the server's pages read for it."""
    registry = open_registry()
    code = registry.create_patient("Ada", "Example").code
    begun = registry.begin_trial(code, PARAMS, backend="simulator")
    registry.record_proposal(begun.trial_id, {"assistance_level": 0.5})
    others = 300
    with registry._write() as conn:  # the others' rows as a department's registry has them
        for i in range(others):
            patient = execute(conn, "INSERT INTO patients (code, created_at) VALUES (?, 'c') "
                                    "RETURNING id", (f"PX{i:05d}",)).scalar_one()
            session = execute(conn, "INSERT INTO sessions (patient_id, number, date) VALUES "
                                    "(?, 1, '2026-12-01') RETURNING id", (patient,)).scalar_one()
            trial = execute(conn, "INSERT INTO trials (session_id, number, parameters, file, "
                                  "status, started_at) VALUES (?, 1, '{}', ?, 'complete', "
                                  "'2026-12-01T10:00:00+00:00') RETURNING id",
                            (session, f"trials/PX{i:05d}/1.h5")).scalar_one()
            execute(conn, "INSERT INTO proposals (trial_id, proposal, proposed_at) VALUES "
                          "(?, '{}', 'c')", (trial,))
    with registry._read() as conn:
        patient = patient_id(conn, registry.where, code)
        if registry_engine == "postgresql":
            conn.exec_driver_sql("ANALYZE")  # the server knows the tables' sizes
            plan = "\n".join(row[0] for row in execute(
                conn, "EXPLAIN (ANALYZE, BUFFERS, FORMAT TEXT) " + PENDING,
                (patient, -1) * 2))
            pages = sum(int(n) for n in re.findall(r"^  Buffers: shared hit=(\d+)", plan,
                                                   re.MULTILINE))
            assert 0 < pages < others, plan
        else:
            plan = _plan(registry, registry_engine, PENDING, (patient, -1) * 2)
            assert "SEARCH p USING INDEX proposals_pending_by_patient (patient_id=?)" in plan
    assert registry.pending_proposal(code).trial_id == begun.trial_id
    with registry._read() as conn:  # the rows inserted without it name their patient
        assert execute(conn, "SELECT count(*) FROM proposals p WHERE coalesce(p.patient_id, "
                             "0) != (SELECT s.patient_id FROM trials t JOIN sessions s ON "
                             "s.id = t.session_id WHERE t.id = p.trial_id)").scalar_one() == 0
    assert registry.integrity_check() == []


def _history(registry: Registry, code: str, trials: int) -> int:
    """`trials` trials of the patient `code` in one session, each with its proposal, each
    decided by the next trial but the last one's, pending (as a patient's history stands
    between two trials), every tenth marked valid; the patient's id."""
    with registry._write() as conn:
        patient = patient_id(conn, registry.where, code)
        session = execute(conn, "INSERT INTO sessions (patient_id, number, date) VALUES "
                                "(?, 1, '2026-12-01') RETURNING id", (patient,)).scalar_one()
        ids = [execute(conn, "INSERT INTO trials (session_id, number, parameters, file, "
                             "status, started_at) VALUES (?, ?, ?, ?, 'complete', "
                             "'2026-12-01T10:00:00+00:00') RETURNING id",
                       (session, n, json.dumps(PARAMS.to_dict()), f"trials/{code}/{n}.h5")
                       ).scalar_one() for n in range(1, trials + 1)]
        for trial, after in zip(ids, [*ids[1:], None], strict=True):
            execute(conn, "INSERT INTO proposals (trial_id, proposal, decision, "
                          "next_trial_id, proposed_at, decided_at) VALUES (?, '{}', ?, ?, "
                          "'c', ?)", (trial, "pending" if after is None else "kept",
                                      after, None if after is None else "d"))
        for trial in ids[::10]:  # checked and found valid, as a department marks some
            execute(conn, "INSERT INTO trial_marks (trial_id, valid, reason, marked_by, "
                          "marked_at) VALUES (?, 1, 'checked', 'Dr B', 'm')", (trial,))
    return patient


def _analyzed(request, registry: Registry, engine: str) -> None:
    """The server's statistics of the test's tables, as a department's server keeps them
    (autovacuum; only a table's owner may ANALYZE it, not the station's login)."""
    if engine == "postgresql":
        request.getfixturevalue("postgres_server").admin_sql(
            "ANALYZE", database=registry._writer.url.database)


def _work(registry: Registry, engine: str, patient: int) -> tuple[int, str]:
    """What finding the patient's pending proposal costs the engine, in its own units: on
    the server the pages it reads (EXPLAIN's buffers), on SQLite the virtual machine's
    instructions; and the plan."""
    with registry._read() as conn:
        if engine == "postgresql":
            plan = "\n".join(row[0] for row in execute(
                conn, "EXPLAIN (ANALYZE, BUFFERS, FORMAT TEXT) " + PENDING,
                (patient, -1) * 2))
            pages = sum(int(n) for n in re.findall(r"^  Buffers: shared hit=(\d+)", plan,
                                                   re.MULTILINE))
            return pages, _plan(registry, engine, PENDING, (patient, -1) * 2)
        steps = [0]

        def count() -> int:
            steps[0] += 1
            return 0

        plan = _plan(registry, engine, PENDING, (patient, -1) * 2)
        raw = conn.connection.driver_connection
        raw.set_progress_handler(count, 1)
        try:
            execute(conn, PENDING, (patient, -1) * 2).fetchall()
        finally:
            raw.set_progress_handler(None, 1)
        return steps[0], plan


def test_a_patients_pending_proposal_costs_the_same_whatever_their_number_of_trials(
        request, open_registry, registry_engine):
    """Schema v13: the pending proposals are indexed by their patient, so finding a patient's
    is one probe of that index. Before, the lookup started from the patient's trials and
    probed the index of pending proposals once for each (1,000 probes at 1,000 trials: 1.8-2.2
    ms a begin_trial on the server, docs/performance.md); a patient with 300 trials then cost
    the server 300 more pages than one with 3, and SQLite thousands more instructions."""
    registry = open_registry()
    few, many = (registry.create_patient("Ada", "Example").code,
                 registry.create_patient("Bea", "Example").code)
    patients = {code: _history(registry, code, trials) for code, trials in ((few, 3),
                                                                            (many, 300))}
    _analyzed(request, registry, registry_engine)
    work = {code: _work(registry, registry_engine, patient)
            for code, patient in patients.items()}
    (few_work, _), (many_work, plan) = work[few], work[many]
    if registry_engine == "postgresql":
        assert many_work <= few_work + 2, (few_work, many_work)
    else:
        assert many_work <= few_work * 1.2, (few_work, many_work)
    assert "proposals_pending_by_patient" in plan, plan
    assert registry.pending_proposal(few).trial_id == registry.trials_for_patient(few)[-1].id
    assert registry.pending_proposal(many).trial_id == \
        registry.trials_for_patient(many)[-1].id


def test_a_v11_registry_gains_the_indexes_keeping_every_record(tmp_path):
    folder = tmp_path / "data"
    with registry_at(folder, 11) as conn:
        conn.execute("INSERT INTO patients (code, created_at) VALUES ('PABC001', 'c')")
        conn.execute("INSERT INTO sessions (patient_id, number, date) VALUES (1, 1, "
                     "'2026-12-01')")
        for number in (1, 2):
            conn.execute("INSERT INTO trials (session_id, number, parameters, file, status, "
                         "started_at) VALUES (1, ?, ?, ?, 'complete', ?)",
                         (number, json.dumps(PARAMS.to_dict()), f"trials/PABC001/{number}.h5",
                          f"2026-12-01T10:0{number}:00+00:00"))
        conn.execute("INSERT INTO proposals (trial_id, proposal, decision, next_trial_id, "
                     "proposed_at, decided_at) VALUES (1, '{\"assistance_level\": 0.5}', "
                     "'kept', 2, 'a', 'b')")
        conn.execute("INSERT INTO proposals (trial_id, proposal, proposed_at) VALUES "
                     "(2, '{\"assistance_level\": 0.4}', 'c')")
    registry = Registry(DataDir(folder))
    assert list(tmp_path.glob("data/registry.sqlite3.v11-*.bak"))
    assert [(p.trial_id, p.decision, p.next_trial_id) for p in
            registry.proposals_for_patient("PABC001")] == [(1, "kept", 2), (2, "pending", None)]
    assert registry.pending_proposal("PABC001").proposal == {"assistance_level": 0.4}
    assert [t.number for t in registry.trials_for_patient("PABC001")] == [1, 2]
    assert registry.integrity_check() == []
    with registry._read() as conn:
        indexes = {name for (name,) in conn.exec_driver_sql(
            "SELECT name FROM sqlite_master WHERE type = 'index' AND tbl_name = 'proposals'")}
    assert {"proposals_pending_by_patient", "proposals_by_next_trial"} <= indexes


def _v12(folder, *, damage: bool = False) -> DataDir:
    """A v12 registry of two patients, each with two trials and their proposals (the first
    decided, the second pending), and a validity mark; `damage`: a proposal changed past
    its seal's trigger, as a bit flipped on the disk."""
    with registry_at(folder, 12) as conn:
        for patient, code in ((1, "PABC001"), (2, "PABC002")):
            conn.execute("INSERT INTO patients (code, created_at) VALUES (?, 'c')", (code,))
            conn.execute("INSERT INTO sessions (patient_id, number, date) VALUES (?, 1, "
                         "'2026-12-01')", (patient,))
            first = 2 * patient - 1
            for number in (1, 2):
                conn.execute("INSERT INTO trials (session_id, number, parameters, file, "
                             "status, started_at) VALUES (?, ?, ?, ?, 'complete', ?)",
                             (patient, number, json.dumps(PARAMS.to_dict()),
                              f"trials/{code}/{number}.h5",
                              f"2026-12-01T10:0{number}:00+00:00"))
            conn.execute("INSERT INTO proposals (trial_id, proposal, decision, next_trial_id, "
                         "proposed_at, decided_at) VALUES (?, '{\"assistance_level\": 0.5}', "
                         "'kept', ?, 'a', 'b')", (first, first + 1))
            conn.execute("INSERT INTO proposals (trial_id, proposal, proposed_at) VALUES "
                         "(?, '{\"assistance_level\": 0.4}', 'c')", (first + 1,))
        conn.execute("INSERT INTO trial_marks (trial_id, valid, reason, marked_by, marked_at) "
                     "VALUES (4, 0, 'the arm slipped', 'Dr B', 'm')")
        if damage:
            conn.execute("DROP TRIGGER proposals_sealed_on_update")
            conn.execute("UPDATE proposals SET decision = 'accepted' WHERE trial_id = 1")
    return DataDir(folder)


def test_a_v12_registry_gains_each_proposals_patient_keeping_every_record(tmp_path):
    """v13: each proposal names its trial's patient, sealed with the rest (each row checked
    against its v12 seal first), and the pending ones are indexed by it. Every row is kept,
    a copy of the file first; the reads give what v12's rules give (the second patient's
    latest trial is marked invalid: its proposal is never offered, and the one it decided
    is pending again)."""
    folder = tmp_path / "data"
    _v12(folder)
    with contextlib.closing(sqlite3.connect(folder / "registry.sqlite3")) as conn:
        before = {table: conn.execute(f"SELECT * FROM {table} ORDER BY 1").fetchall()
                  for table in ("patients", "sessions", "trials", "trial_marks")}
        proposals = conn.execute("SELECT trial_id, proposal, decision, next_trial_id, "
                                 "proposed_at, decided_at FROM proposals ORDER BY 1").fetchall()
    registry = Registry(DataDir(folder))
    assert registry.schema_version() == 13
    assert list(tmp_path.glob("data/registry.sqlite3.v12-*.bak"))
    assert registry.integrity_check() == []
    with contextlib.closing(sqlite3.connect(folder / "registry.sqlite3")) as conn:
        assert {table: conn.execute(f"SELECT * FROM {table} ORDER BY 1").fetchall()
                for table in before} == before
        assert conn.execute("SELECT trial_id, proposal, decision, next_trial_id, proposed_at, "
                            "decided_at FROM proposals ORDER BY 1").fetchall() == proposals
        assert conn.execute("SELECT trial_id, patient_id FROM proposals ORDER BY 1"
                            ).fetchall() == [(1, 1), (2, 1), (3, 2), (4, 2)]
    assert registry.pending_proposal("PABC001").trial_id == 2
    assert registry.pending_proposal("PABC002").trial_id == 3  # trial 4 is invalid
    begun = registry.begin_trial("PABC002", PARAMS, backend="simulator")
    assert registry.proposal(3).next_trial_id == begun.trial_id
    registry.record_proposal(begun.trial_id, {"assistance_level": 0.3})
    assert registry.pending_proposal("PABC002").trial_id == begun.trial_id
    assert registry.integrity_check() == []


def test_a_proposal_damaged_before_the_upgrade_to_v13_is_refused_not_sealed_again(tmp_path):
    with pytest.raises(RegistryError, match=r"proposals_rows_match_their_seals.*still v12"):
        Registry(_v12(tmp_path / "data", damage=True))
