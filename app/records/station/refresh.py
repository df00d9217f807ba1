"""The standby's rows of one patient brought to the server's, writing only what differs
(app.records.station.mirror builds the standby whole; this keeps it current between
builds).

Why: after each write the station mirrors the patient again, and a write changes a row or
two of a patient's hundreds. Building the standby anew wrote them all (64 ms for a patient
with 300 trials, bench/station_offline.py); this reads each table's keys and seals from the
server, compares them with the manifest, and fetches and writes only the rows whose seal
differs, adds the new ones and takes out those the server no longer has (a trial withdrawn
at Start, its proposal and plan step). Every row written must then have the server's seal,
as in a build; on any doubt the caller builds the standby whole.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import sqlite3

import sqlalchemy as sa

from app.records.registry import seals
from app.records.registry.postgres.tables import REGISTRY_TABLES
from app.records.registry.schema import SCHEMA_VERSION
from app.records.station.mirror import (
    PATIENT_ROWS,
    key_columns,
    record_mirrored,
    row_key,
    rows_of,
)


@dataclasses.dataclass(frozen=True)
class Changes:
    """What the standby lacks of one patient's rows on the server: `ours`, the standby's
    keys and seals per table as read (a row in it is updated, not inserted); `gone`, the
    keys the server no longer has; `rows`, the server's rows whose seal differs."""

    code: str
    ours: dict[str, dict[str, str]]
    gone: dict[str, set[str]]
    rows: dict[str, list[tuple]]

    def __bool__(self) -> bool:
        return any(self.gone.values()) or any(self.rows.values())


def refresh_patient(path, server: sa.Connection, code: str) -> int:
    """The standby at `path` holding the server's rows of patient `code` exactly; the rows
    written or taken out. RegistryError when a row written has not the server's seal."""
    changes = server_changes(server, code, mirrored_seals(path, code))
    return write_changes(path, changes) if changes is not None else 0


def mirrored_seals(path, code: str) -> dict[str, dict[str, str]]:
    """The standby's keys and seals of patient `code`'s rows, per table (as the manifest
    holds them); sqlite3.DatabaseError when the standby is of another schema."""
    with contextlib.closing(sqlite3.connect(f"{path.as_uri()}?mode=ro", uri=True)) as conn:
        if conn.execute("PRAGMA user_version").fetchone()[0] != SCHEMA_VERSION:
            raise sqlite3.DatabaseError("the standby is of another schema")
        ours: dict[str, dict[str, str]] = {table: {} for table in REGISTRY_TABLES}
        for table, key, seal in conn.execute(
                "SELECT tbl, key, seal FROM station_mirror WHERE patient = ?", (code,)):
            ours[table][key] = seal
    return ours


def server_changes(server: sa.Connection, code: str,
                   ours: dict[str, dict[str, str]]) -> Changes | None:
    """The server's side of a refresh (every round trip it takes): what differs from
    `ours` for patient `code`; None when the server has no such patient. One round trip
    when nothing differs."""
    theirs = _keys_and_seals(server, code)
    if not theirs["patients"]:
        return None
    patient = json.loads(next(iter(theirs["patients"])))[0]
    gone = {table: ours[table].keys() - theirs[table].keys() for table in REGISTRY_TABLES}
    rows: dict[str, list[tuple]] = {}
    for table in REGISTRY_TABLES:
        wanted = {k for k, seal in theirs[table].items() if ours[table].get(k) != seal}
        rows[table] = _fetch(server, table, patient, wanted) if wanted else []
    return Changes(code, ours, gone, rows)


def write_changes(path, changes: Changes) -> int:
    """`changes` written into the standby at `path` in one transaction (no server
    involved); the rows written or taken out. The caller makes sure the standby is still
    as `changes.ours` was read."""
    if not changes:
        return 0
    with contextlib.closing(seals.register(sqlite3.connect(path, isolation_level=None))) \
            as conn:
        conn.execute("PRAGMA foreign_keys = ON")
        # No flush to the disk at each commit: online the standby holds only what the server
        # has, and a standby a power cut damaged is set aside and built again from it.
        conn.execute("PRAGMA synchronous = NORMAL")
        conn.execute("BEGIN IMMEDIATE")
        try:
            written = 0
            for table in reversed(REGISTRY_TABLES):  # the rows naming a row go first
                for key in changes.gone[table]:
                    _take_out(conn, table, key)
                    written += 1
            for table in REGISTRY_TABLES:
                rows = changes.rows[table]
                if rows:
                    for row in rows:
                        _write(conn, table, row, row_key(table, row) in changes.ours[table])
                    record_mirrored(conn, table, rows, changes.code)
                    written += len(rows)
            conn.execute("COMMIT")
        except BaseException:
            with contextlib.suppress(sqlite3.Error):
                conn.execute("ROLLBACK")
            raise
    return written


def _keys_and_seals(server: sa.Connection, code: str) -> dict[str, dict[str, str]]:
    """Every row's key (as mirror.row_key writes it) and seal of the patient `code`, per
    table, in one round trip (a station's network may be slow; eleven queries were
    eleven trips)."""
    patient = "(SELECT id FROM patients WHERE code = :code)"
    parts = [f"SELECT '{table}', '[' || concat_ws(',', {', '.join(key_columns(table))}) "
             f"|| ']', seal FROM {table} WHERE "
             f"{PATIENT_ROWS[table].replace(':patient', patient)}" for table in REGISTRY_TABLES]
    found: dict[str, dict[str, str]] = {table: {} for table in REGISTRY_TABLES}
    for table, key, seal in server.execute(sa.text(" UNION ALL ".join(parts)), {"code": code}):
        found[table][key] = seal
    return found


def _fetch(server: sa.Connection, table: str, patient: int, wanted: set[str]) -> list[tuple]:
    keys = key_columns(table)
    if len(keys) == 1:
        chosen = [json.loads(k)[0] for k in wanted]
        return rows_of(server, table, patient, f"AND {keys[0]} IN :keys", {"keys": chosen})
    return [row for row in rows_of(server, table, patient) if row_key(table, row) in wanted]


def _where_key(table: str) -> str:
    return " AND ".join(f"{name} = ?" for name in key_columns(table))


def _take_out(conn: sqlite3.Connection, table: str, key: str) -> None:
    conn.execute(f"DELETE FROM {table} WHERE {_where_key(table)}", json.loads(key))
    conn.execute("DELETE FROM station_mirror WHERE tbl = ? AND key = ?", (table, key))


def _write(conn: sqlite3.Connection, table: str, row: tuple, known: bool) -> None:
    columns = seals.SEALED[table]
    values = dict(zip(columns, row[:-1], strict=True))
    keys = key_columns(table)
    if known:
        others = [c for c in columns if c not in keys]
        conn.execute(f"UPDATE {table} SET {', '.join(f'{c} = ?' for c in others)} "
                     f"WHERE {_where_key(table)}",
                     [values[c] for c in others] + [values[k] for k in keys])
    else:
        conn.execute(f"INSERT INTO {table} ({', '.join(columns)}) VALUES "
                     f"({', '.join('?' for _ in columns)})", row[:-1])
