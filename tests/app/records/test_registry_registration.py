"""What a trial's registration asks of the registry, on both engines (issue 32: registration
p99 < 10 ms with 8 stations writing; bench/registration.py, docs/performance.md): the
statements each call sends (each a round trip to a server), the indexes that find a
patient's pending proposal (schema v12), and a v11 registry brought to v12 keeping every
record."""

from __future__ import annotations

import contextlib
import datetime
import json
import re

import sqlalchemy as sa

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.patients import patient_id
from app.records.registry.proposals import _PENDING
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
    asked for, the next trial number) in one read, the insert(s), the pending proposal and
    its decision; finish_trial and record_proposal: one statement each, in one transaction,
    the row they return as written (RETURNING), never read again. Before: 7, 4 and 4 in two
    transactions."""
    registry = open_registry()
    code = registry.create_patient("Ada", "Example").code
    sent = Sent(registry)
    today = datetime.datetime.now(datetime.UTC)
    first = registry.begin_trial(code, PARAMS, backend="simulator", started_at=today)
    registry.finish_trial(first.trial_id, "complete", {"rmse_x_m": 0.01})
    registry.record_proposal(first.trial_id, {"assistance_level": 0.5})
    with sent.counting():  # today's session goes on; the proposal is decided
        begun = registry.begin_trial(code, PARAMS, backend="simulator", started_at=today)
    assert (len(sent.statements), sent.transactions) == (5, 1), sent.statements
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
    assert (len(sent.statements), sent.transactions) == (6, 1), sent.statements
    with sent.counting():  # and the next trial of it
        registry.begin_trial(code, PARAMS, backend="simulator", session_number=2,
                             trial_number=2, started_at=today)
    assert (len(sent.statements), sent.transactions) == (4, 1), sent.statements


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
    (`Proposals._trial_withdrawn`), on both engines."""
    registry = open_registry()
    code = registry.create_patient("Ada", "Example").code
    for _ in range(3):
        begun = registry.begin_trial(code, PARAMS, backend="simulator")
        registry.finish_trial(begun.trial_id, "complete", {})
        registry.record_proposal(begun.trial_id, {"assistance_level": 0.5})
    with registry._read() as conn:
        patient = patient_id(conn, registry.where, code)
    if registry_engine == "postgresql":  # SQLite reaches a proposal by its trial's rowid
        plan = _plan(registry, registry_engine, _PENDING, (patient, -1) * 2)
        assert "proposals_pending" in plan
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
                conn, "EXPLAIN (ANALYZE, BUFFERS, FORMAT TEXT) " + _PENDING,
                (patient, -1) * 2))
            pages = sum(int(n) for n in re.findall(r"^  Buffers: shared hit=(\d+)", plan,
                                                   re.MULTILINE))
            assert 0 < pages < others, plan
        else:
            plan = _plan(registry, registry_engine, _PENDING, (patient, -1) * 2)
            assert plan.splitlines()[2].startswith("SEARCH s "), plan  # the patient's sessions
    assert registry.pending_proposal(code).trial_id == begun.trial_id


def test_a_v11_registry_gains_the_indexes_keeping_every_record(tmp_path):
    folder = tmp_path / "data"
    with registry_at(folder, 11) as conn:
        conn.execute("INSERT INTO patients (code, created_at) VALUES ('P0000001', 'c')")
        conn.execute("INSERT INTO sessions (patient_id, number, date) VALUES (1, 1, "
                     "'2026-12-01')")
        for number in (1, 2):
            conn.execute("INSERT INTO trials (session_id, number, parameters, file, status, "
                         "started_at) VALUES (1, ?, ?, ?, 'complete', ?)",
                         (number, json.dumps(PARAMS.to_dict()), f"trials/P0000001/{number}.h5",
                          f"2026-12-01T10:0{number}:00+00:00"))
        conn.execute("INSERT INTO proposals (trial_id, proposal, decision, next_trial_id, "
                     "proposed_at, decided_at) VALUES (1, '{\"assistance_level\": 0.5}', "
                     "'kept', 2, 'a', 'b')")
        conn.execute("INSERT INTO proposals (trial_id, proposal, proposed_at) VALUES "
                     "(2, '{\"assistance_level\": 0.4}', 'c')")
    registry = Registry(DataDir(folder))
    assert list(tmp_path.glob("data/registry.sqlite3.v11-*.bak"))
    assert [(p.trial_id, p.decision, p.next_trial_id) for p in
            registry.proposals_for_patient("P0000001")] == [(1, "kept", 2), (2, "pending", None)]
    assert registry.pending_proposal("P0000001").proposal == {"assistance_level": 0.4}
    assert [t.number for t in registry.trials_for_patient("P0000001")] == [1, 2]
    assert registry.integrity_check() == []
    with registry._read() as conn:
        indexes = {name for (name,) in conn.exec_driver_sql(
            "SELECT name FROM sqlite_master WHERE type = 'index' AND tbl_name = 'proposals'")}
    assert {"proposals_pending", "proposals_by_next_trial"} <= indexes
