"""The registry's proposals: after each finished trial, what the console proposed for the
next one (app.trials.progression) and what the therapist did with it.

A trial marked invalid (app.records.registry.clinical) does not count: its proposal is
never offered, and the proposal it decided is offered again. A proposal is `pending`
until the patient's next trial starts; `begin_trial` then marks
it `accepted` (the next trial is the proposal applied to the trial before: every
parameter equal, the proposed assistance, speed and tolerance and the rest as before),
`kept` (every parameter as the trial before, against a proposed change) or `changed`
(anything else: another shape, mode or size is never "accepted"), and links the trial
that followed. An assessment trial neither makes a proposal (app.trials.finalize) nor
decides one: the exercise's proposal waits for the next exercise trial (and one an
assessment trial made in a registry from before then is never offered).
`pending_proposal` gives the one waiting, after a restart too. The history
of a patient's progression is their proposals beside their trials' parameters, which the
trials table keeps.
"""

from __future__ import annotations

import dataclasses
import datetime
import functools
import json
import math
from dataclasses import dataclass

import sqlalchemy as sa

from app.errors import InvalidRecordError
from app.records.registry import seals
from app.records.registry.database import Database
from app.records.registry.patients import patient_id
from app.records.registry.sessions import Carried
from app.records.registry.statements import execute
from app.records.registry.trials import trial_by_id
from core.errors import CoreError
from core.trial import TrialParameters

DECISIONS = ("pending", "accepted", "changed", "kept")
_TOLERANCE = 1e-9


@dataclass(frozen=True, slots=True)
class StoredProposal:
    """A proposal as the registry keeps it (its values in Proposal.to_dict's form)."""

    trial_id: int
    proposal: dict
    decision: str
    next_trial_id: int | None
    proposed_at: str
    decided_at: str | None


class Proposals(Database):
    """Keeping the proposal after a trial, deciding it when the next trial starts. Comes
    before Trials in the registry's bases, so that its `_trial_begun` is the one called."""

    def record_proposal(self, trial_id: int, proposal: dict) -> StoredProposal:
        """Keep the proposal made after trial `trial_id` (replacing a pending one)."""
        text = json.dumps(proposal, allow_nan=False, sort_keys=True)
        with self._write() as conn:
            # One statement (a round trip to a server; bench/registration.py): inserted, or
            # a pending one replaced whole, and returned as written; no row when the trial
            # is unknown or its proposal was decided, said below.
            row = execute(conn, RECORD, (text, _now(), trial_id)).fetchone()
            if row is None:
                trial_by_id(conn, self.where, trial_id)  # refuses an unknown trial
                decided = execute(conn, "SELECT decision FROM proposals WHERE trial_id = ?",
                                  (trial_id,)).scalar_one()
                raise InvalidRecordError(
                    f"trial {trial_id}'s proposal was already {decided}; it is kept as it was")
        return _stored(row)

    def proposal(self, trial_id: int) -> StoredProposal | None:
        with self._read() as conn:
            row = execute(conn, _SELECT + " WHERE trial_id = ?", (trial_id,)).fetchone()
        return None if row is None else _stored(row)

    def proposals_for_patient(self, code: str) -> list[StoredProposal]:
        with self._read() as conn:
            pid = patient_id(conn, self.where, code)
            rows = execute(conn,
                _SELECT + " WHERE trial_id IN (SELECT t.id FROM trials t JOIN sessions s "
                "ON s.id = t.session_id WHERE s.patient_id = ?) ORDER BY trial_id",
                (pid,)).fetchall()
        return [_stored(r) for r in rows]

    def pending_proposal(self, code: str) -> StoredProposal | None:
        """The proposal waiting for the patient's next trial (the one the next Start
        decides), None when none waits: what the window offers again after a restart."""
        with self._read() as conn:
            row = _pending(conn, patient_id(conn, self.where, code), NO_TRIAL)
        return None if row is None else _stored(row)

    def _trial_withdrawn(self, conn: sa.Connection, trial_id: int) -> None:
        """A trial withdrawn (Trials.withdraw_trial) never ran: the proposal it decided is
        pending again, and one made after it goes with it."""
        execute(conn, "UPDATE proposals SET decision = 'pending', next_trial_id = NULL, "
                      "decided_at = NULL WHERE next_trial_id = ?", (trial_id,))
        execute(conn, "DELETE FROM proposals WHERE trial_id = ?", (trial_id,))

    def _read_at_start(self, patient: int, parameters: str) -> Carried | None:
        """At Start, after the patient's lock (Trials._read_at_start): their pending
        proposal, read in the round trip that numbers the trial; none for an assessment
        trial (TrialParameters.assessment), which decides none: it runs its task's fixed
        protocol between exercise trials, and the proposal waits for the next exercise. Read
        before the trial's insert, which changes no proposal, so it reads what it read after
        (the new trial has no proposal yet: none to leave out)."""
        if _parameters(parameters).assessment:
            return None
        return Carried(PENDING, (patient, NO_TRIAL) * 2, PENDING_COLUMNS)

    def _trial_begun(self, conn: sa.Connection, trial_id: int, parameters: str,
                     read: list[tuple]) -> None:
        """At Start, in begin_trial's transaction (Trials._trial_begun): the patient's
        pending proposal (`read`: PENDING's rows, from `_read_at_start`) decided by the
        parameters the new trial started with (their JSON as stored)."""
        row = _first_exercise(sorted(read, key=lambda r: r[0], reverse=True))
        if row is None:  # none waits, or an assessment trial read none
            return
        stored = _stored(row)
        before = _parameters(row[-1])  # its trial's, as read
        decision = _decision(stored.proposal, before, _parameters(parameters))
        execute(conn, "UPDATE proposals SET decision = ?, next_trial_id = ?, decided_at = ? "
                      "WHERE trial_id = ?", (decision, trial_id, _now(), stored.trial_id))


_SELECT = ("SELECT trial_id, proposal, decision, next_trial_id, proposed_at, decided_at "
           "FROM proposals")
RECORD = ("INSERT INTO proposals (trial_id, proposal, proposed_at, patient_id) "
          "SELECT t.id, ?, ?, s.patient_id FROM trials t JOIN sessions s "
          "ON s.id = t.session_id WHERE t.id = ? "
          "ON CONFLICT (trial_id) DO UPDATE SET proposal = excluded.proposal, "
          "proposed_at = excluded.proposed_at, decision = 'pending', next_trial_id = NULL, "
          "decided_at = NULL WHERE proposals.decision = 'pending' "
          "RETURNING trial_id, proposal, decision, next_trial_id, proposed_at, decided_at")
"""A proposal recorded after its trial (text, time, trial id): inserted when the trial has
none (with its trial's patient, schema v13), replacing a pending one whole, nothing when the
trial is unknown (no row to insert) or its proposal was decided (the update's WHERE). The
same statement on both engines (an upsert: PostgreSQL 9.5, SQLite 3.24; SQLite reads
`SELECT … JOIN … WHERE` before `ON CONFLICT` unambiguously: a WHERE ends the join). On
the server the conflicting row is locked and its decision read as the station before left
it, as the SELECT … FOR UPDATE before it did."""
_INVALID = ("SELECT m.trial_id FROM trial_marks m WHERE m.valid = 0 AND m.id = "
            "(SELECT max(id) FROM trial_marks WHERE trial_id = m.trial_id)")
_CANDIDATE = ("SELECT p.trial_id, p.proposal, p.decision, p.next_trial_id, p.proposed_at, "
              "p.decided_at, t.parameters FROM proposals p JOIN trials t ON t.id = p.trial_id "
              "WHERE p.patient_id = ? AND p.trial_id != ? ")
PENDING = (_CANDIDATE + f"AND p.decision = 'pending' AND p.trial_id NOT IN ({_INVALID}) "
           "UNION ALL "
           + _CANDIDATE + f"AND p.decision != 'pending' AND p.next_trial_id IN ({_INVALID}) "
           f"AND p.trial_id NOT IN ({_INVALID}) ORDER BY 1 DESC")
"""The patient's pending proposal (patient id, a trial id to leave out, the same two again),
with its trial's parameters, latest first; `_pending` takes the first of an exercise trial.
The one: the latest of an exercise trial not marked invalid (schema v8) that no trial
decided, or that a trial since marked invalid decided (that trial does not count: its
proposal is offered again, as after a withdrawn trial). An assessment trial's proposal is
never the one: a registry written before assessments stopped proposing (app.trials.finalize)
may hold one, which would offer the task's fixed protocol ("transparent mode: the same
again") to the next exercise.

How it is found, measured on PostgreSQL with 1,000 patients of 1,000 trials, each with its
proposal (bench/registration.py, docs/performance.md):

* Before v12, one condition ("pending, or decided by a trial since marked invalid") that no
  index fitted: the server read the proposal of each of the patient's trials, 1.6-3.1 ms.
* v12: a partial index of every patient's pending proposals by trial, probed once for each
  of the patient's trials (a join started from the index instead read every patient's
  pending one, 5-13 ms): 0.8-2 ms, still one probe per trial of the patient, growing with
  their history, because proposals did not name their patient.
* v13 (`SQLITE_V13`, postgres.MIGRATIONS[13]): each proposal names its trial's patient, and
  the partial index of pending proposals is by patient (`PENDING_BY_PATIENT`): the
  patient's pending ones (about one) are one index probe, whatever their number of trials:
  5 pages read by the server, the statement 2.70 → 0.38 ms as a station sees it after a
  pause (its median over 100 trials, 1 s apart).
* Those an invalid trial decided, from the few invalid marks through the index on
  `next_trial_id`, kept to the patient's by the same column.

Why the assessment is told apart in Python: the candidates are few, while a condition on the
parameters in the SQL was evaluated by PostgreSQL on every trial of the patient, parsing
each one's parameters (`::jsonb`): 56 ms of server time in every begin_trial of a patient
with 1,000 trials (bench/stations.py, docs/performance.md)."""

PENDING_COLUMNS = ("trial_id", "proposal", "decision", "next_trial_id", "proposed_at",
                   "decided_at", "parameters")
"""PENDING's columns: _SELECT's six, then its trial's parameters."""
NO_TRIAL = -1
"""A trial id PENDING leaves out that no trial has (ids start at 1; the connection's warm-up,
postgres/warm.py, takes ids below zero but rolls them back)."""

PENDING_INDEXES = (
    "CREATE INDEX proposals_pending ON proposals (trial_id) WHERE decision = 'pending'",
    "CREATE INDEX proposals_by_next_trial ON proposals (next_trial_id)",
)
"""Schema v12 as it shipped (both engines): the pending proposals, and the proposals by the
trial that decided them, which `PENDING` reads and a withdrawn trial's
(Proposals._trial_withdrawn: its decision undone, and the foreign key's check when its row
is deleted) would otherwise find by reading every proposal of the registry. v13 replaced
the first by `PENDING_BY_PATIENT`."""

SQLITE_V12 = PENDING_INDEXES
"""Schema v12 on SQLite (the server's, postgres.MIGRATIONS[12], adds what makes its seal
triggers cheaper)."""

PENDING_BY_PATIENT = ("CREATE INDEX proposals_pending_by_patient ON proposals "
                      "(patient_id, trial_id) WHERE decision = 'pending'")
"""Schema v13 (both engines; on the server postgres/tables.py): the pending proposals by
their patient, latest last."""


def patient_of_trial(trial: str, schema: str = "") -> str:
    """The SQL of the patient whose trial is `trial` (an SQL expression of its id), its
    tables in `schema` ("public." in the server's trigger function)."""
    return (f"(SELECT s.patient_id FROM {schema}trials t JOIN {schema}sessions s "
            f"ON s.id = t.session_id WHERE t.id = {trial})")


def _sqlite_patient_trigger(name: str, event: str) -> str:
    """After `event`, a proposal's `patient_id` made its trial's where it is not (a writer
    that did not give it: a tool, a row inserted by hand). The console's own writers give
    it (`RECORD`; the standby's and the sync's copies carry it), and the update the
    trigger makes then never runs."""
    patient = patient_of_trial("NEW.trial_id")
    return (f"CREATE TRIGGER proposals_patient_on_{name} AFTER {event} ON proposals "
            f"WHEN NEW.patient_id IS NOT {patient} BEGIN UPDATE proposals SET patient_id = "
            f"{patient} WHERE trial_id = NEW.trial_id; END")


SQLITE_V13 = (
    *seals.checked_before_resealing("proposals", seals.SEALED_AT_V12["proposals"]),
    "ALTER TABLE proposals ADD COLUMN patient_id INTEGER REFERENCES patients (id) "
    "ON DELETE RESTRICT",
    "DROP TRIGGER proposals_sealed_on_insert",
    "DROP TRIGGER proposals_sealed_on_update",
    f"UPDATE proposals SET patient_id = {patient_of_trial('proposals.trial_id')}",
    f"UPDATE proposals SET seal = {seals.call('proposals', seals.sealed_at('proposals', 13))}",
    *seals.triggers("proposals", seals.sealed_at("proposals", 13)),
    _sqlite_patient_trigger("insert", "INSERT"),
    _sqlite_patient_trigger("update", "UPDATE OF trial_id, patient_id"),
    "DROP INDEX proposals_pending",
    PENDING_BY_PATIENT,
)
"""Schema v13 on SQLite: each proposal's patient (its trial's session's, kept so by the
database: `_sqlite_patient_trigger`), sealed with the rest (each row checked against its v12
seal first), and the pending proposals indexed by it (`PENDING`). A proposal's meaning is
unchanged: the column only says again which patient its trial is of."""


def _pending(conn: sa.Connection, patient: int, trial_id: int) -> tuple | None:
    """The row of the patient's pending proposal (as _SELECT reads it, then its trial's
    parameters), None when none waits (`PENDING`)."""
    return _first_exercise(execute(conn, PENDING, (patient, trial_id) * 2).fetchall())


def _first_exercise(rows: list[tuple]) -> tuple | None:
    """The first of PENDING's rows whose trial was an exercise, not an assessment."""
    for row in rows:
        assessment = json.loads(row[-1]).get("assessment")
        if assessment is None or assessment == "":
            return row
    return None


@functools.lru_cache(maxsize=64)
def _parameters(text: str) -> TrialParameters:
    """A trial's parameters from their JSON as stored, validated (CoreError when they no
    longer are). Parsed once for each text: a patient's trials share a few, and the trial
    before the one starting is usually the one started last (a TrialParameters is
    immutable: sharing it is safe). Validating a text costs 50 µs, a begin_trial two."""
    return TrialParameters.from_dict(json.loads(text))


_KEYS = ("assistance_level", "duration_s", "tolerance_rad")
"""What a proposal sets (app.trials.progression.Proposal.applied_to)."""


def _decision(proposal: dict, before: TrialParameters, after: TrialParameters) -> str:
    """accepted: `after` is the proposal applied to `before`, every parameter equal;
    kept: `after` is `before`; changed: anything else."""
    try:
        proposed = before.replace(**{key: float(proposal[key]) for key in _KEYS})
    except (CoreError, KeyError, TypeError, ValueError):
        proposed = None  # a proposal no longer valid (a range narrowed since) is not taken
    if proposed is not None and _same(proposed, after):
        return "accepted"
    if _same(before, after):
        return "kept"
    return "changed"


def _same(a: TrialParameters, b: TrialParameters) -> bool:
    """Every parameter equal, numbers to 1e-9 (one value through two unit conversions)."""
    def equal(x, y) -> bool:
        if isinstance(x, list | tuple) and isinstance(y, list | tuple):
            return len(x) == len(y) and all(map(equal, x, y))
        if isinstance(x, float | int) and isinstance(y, float | int) and not (
                isinstance(x, bool) or isinstance(y, bool)):
            return math.isclose(x, y, rel_tol=0.0, abs_tol=_TOLERANCE)
        return x == y

    # field by field, as to_dict would give them (its lists are these tuples' values)
    return all(equal(getattr(a, name), getattr(b, name)) for name in _FIELDS)


_FIELDS = tuple(f.name for f in dataclasses.fields(TrialParameters))


def _stored(row: tuple) -> StoredProposal:
    return StoredProposal(int(row[0]), json.loads(row[1]), row[2], row[3], row[4], row[5])


def _now() -> str:
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
