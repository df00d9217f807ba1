"""A station's new connection to the server made ready for its first registration.

Why: a PostgreSQL server process compiles a PL/pgSQL function the first time its session
calls it, plans the statements inside it then, and loads each table's and index's
description the first time its session touches them. A station's first registration on a
connection is the first to fire the numbering and seal triggers (numbering.py, seals.py)
and the proposals' trigger, so it paid all of that: 13–18 ms against 4–5 ms for the ones
after it, measured with eight stations writing (bench/stations.py, docs/performance.md).

What: as the pool makes a connection, the station registers a throwaway patient, session,
trial and proposal, decides the proposal and finishes the trial, the statements a
registration sends, and then rolls all of it back. Nothing of it is ever committed, so
nothing is seen by anyone: not another station, not the research role, not a count. Its
rows take ids below zero, drawn at random, which the identity columns accept (tables.py)
and never hand out themselves, so no id is used up, and no other connection's warm-up
waits on the same unique key. Its patient is its own, so its numbering locks no real
patient's row.

A registry whose schema is not today's (before `rehab db upgrade`) is left alone: the
registry's own check says what to do. A login that may not register a trial (a
researcher's, which the registry knows only once connected) is not warmed.
A warm-up that fails for another reason than the connection itself says so in the log and
leaves the connection as it was; the station registers as it would without it. A lost
connection fails the connection, as it would have failed the first statement.
"""

from __future__ import annotations

import logging
import secrets

from app.records.registry import proposals
from app.records.registry.postgres.tables import SCHEMA_VERSION
from app.records.registry.sessions import Carried, carrying

log = logging.getLogger(__name__)

_WHEN = "2000-01-01T00:00:00+00:00"


def _driver(statement: str) -> str:
    """A registry statement (its `?` placeholders: statements.py) as psycopg reads it."""
    if "%" in statement:  # psycopg would read a literal % as a placeholder's
        raise ValueError(f"a registry statement with a %: {statement[:60]}")
    return statement.replace("?", "%s")


def _statements() -> tuple[tuple[str, tuple[str, ...]], ...]:
    """What a registration sends, each statement with the names of its values, on rows of
    the warm-up's own: the numbering triggers give the session and trial their numbers
    (none is given), the seal triggers seal every row, the proposals' trigger gives the
    proposal its patient (postgres.PROPOSALS_PATIENT). The proposal is recorded and found
    by the registry's own statements (app.records.registry.proposals), which read the
    proposals, trials and trial marks with their indexes."""
    return (
        ("INSERT INTO patients (id, code, created_at) VALUES (%s, %s, %s)",
         ("patient", "code", "when")),
        ("INSERT INTO sessions (id, patient_id, date) VALUES (%s, %s, '2000-01-01')",
         ("session", "patient")),
        ("INSERT INTO trials (id, session_id, parameters, file, status, started_at, backend) "
         "VALUES (%s, %s, '{}', %s, 'recording', %s, 'warm-up')",
         ("trial", "session", "code", "when")),
        (_driver(proposals.RECORD), ("nothing", "when", "trial")),
        # begin_trial's read after the lock: the sessions, and the pending proposal with them
        (_driver(carrying(Carried(proposals.PENDING, (), proposals.PENDING_COLUMNS))),
         ("patient", "none", "patient", "patient", "none", "patient", "none")),
        ("UPDATE proposals SET decision = 'kept', decided_at = %s WHERE trial_id = %s",
         ("when", "trial")),
        ("UPDATE trials SET status = 'complete', ended_at = %s WHERE id = %s "
         "RETURNING number, seal IS NOT NULL", ("when", "trial")),
    )


def _throwaway_values() -> dict[str, object]:
    """Ids below zero, drawn at random (the identity columns never give one), and a code
    that is no patient's."""
    def below_zero() -> int:
        return -1 - secrets.randbelow(2**62)
    return {"patient": below_zero(), "session": below_zero(), "trial": below_zero(),
            "code": f"warm-up {secrets.token_hex(8)}", "when": _WHEN, "nothing": "{}",
            "none": 0}


def warm_up(connection) -> bool:
    """Fire, on `connection` (a psycopg 3 connection, fresh from the pool), everything a
    trial's registration fires on the server, in a transaction that is always rolled
    back. True if it ran and the server numbered and sealed its trial; False if the
    registry is not at today's schema or the login registers no trial, or the warm-up
    failed without the connection failing, or the server's triggers did not do their part
    (the last two logged)."""
    import psycopg  # the server's driver, loaded only for a server

    try:
        with connection.transaction(force_rollback=True), connection.cursor() as cursor:
            cursor.execute("SELECT to_regclass('public.schema_version') IS NOT NULL "
                           "AND to_regclass('public.trials') IS NOT NULL")
            if not cursor.fetchone()[0]:
                return False
            cursor.execute("SELECT (SELECT version FROM schema_version), "
                           "has_table_privilege('public.trials', 'INSERT')")
            version, registers = cursor.fetchone()
            if version != SCHEMA_VERSION or not registers:
                return False
            values = _throwaway_values()
            for statement, names in _statements():
                cursor.execute(statement, tuple(values[name] for name in names))
            number, sealed = cursor.fetchone()
    except psycopg.Error as exc:
        if connection.closed or connection.broken:
            raise  # the connection itself failed: the station's registry says so
        return _not_warmed(f"{type(exc).__name__}: {str(exc).strip().splitlines()[0]}")
    if number != 1 or not sealed:  # a trigger of the server's was disabled or changed
        return _not_warmed(f"the server gave its trial number {number} and "
                           f"{'a' if sealed else 'no'} seal, where its triggers give 1 and one")
    return True


def _not_warmed(why: str) -> bool:
    log.warning("the new connection to the registry's server was not warmed up (%s); its "
                "first registration may take longer, nothing else changes", why)
    return False


def on_connect(dbapi_connection, _record) -> None:
    """SQLAlchemy's pool "connect" event: each new connection of a station is warmed up."""
    warm_up(dbapi_connection)
