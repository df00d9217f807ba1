"""A console's SQLite registry moved onto the department's PostgreSQL server, every record
kept and proven kept (issue 32: "migrations from today's SQLite schema keep every record";
`rehab db upgrade --from FILE`).

How, in one transaction of the server (all of it or nothing):

* The file is read as it is (read-only): it must be at this console's schema (an older one
  is upgraded first, with its own copy kept: `rehab db upgrade` on its data folder), sound
  (SQLite's integrity check) and every row must match its seal.
* The server's registry must be empty: copying into one that holds records would mix two
  registries' numbers and ids.
* Every table is copied in the order its foreign keys need, every column but the seal,
  ids kept (the server's ids accept a given one); the identity sequences are then moved
  past the highest id. The server's numbering triggers are off for the copy only: a
  registry from before schema v9 may hold gaps a therapist typed, which are kept as they
  were recorded (the rule applies to what comes after).
* The server seals each row itself; the seals are the same digest on both engines
  (postgres/seals.py), so each copied row's seal must equal the file's: that proves every
  value arrived unchanged. One mismatch undoes the whole copy.
"""

from __future__ import annotations

import sqlite3

import sqlalchemy as sa

from app.errors import RegistryError, SchemaError
from app.records.registry import seals
from app.records.registry.postgres.tables import REGISTRY_TABLES, metadata
from app.records.registry.schema import SCHEMA_VERSION

_NUMBERING_TRIGGERS = (("sessions", "a_sessions_numbered"), ("trials", "a_trials_numbered"))


def copy_registry(source: sqlite3.Connection, source_name: str, server: sa.Connection,
                  where: str) -> dict[str, int]:
    """Copy the SQLite registry `source` into the empty registry of `server` (in its
    transaction); the rows copied per table. RegistryError, one line, when it cannot be."""
    version = source.execute("PRAGMA user_version").fetchone()[0]
    if version != SCHEMA_VERSION:
        raise SchemaError(
            f"the registry {source_name} has schema v{version}, this console v{SCHEMA_VERSION}"
            ": " + ("upgrade it first (`rehab db upgrade --data-dir` its folder, which keeps "
                    "a copy of it)" if version < SCHEMA_VERSION else
                    "it was written by a newer console; update this one") + "; nothing was "
            "copied")
    seals.verify(source, source_name)  # its structure and every row's seal
    held = {table: server.execute(sa.text(f"SELECT count(*) FROM {table}")).scalar_one()
            for table in REGISTRY_TABLES}
    if any(held.values()):
        listed = ", ".join(f"{table} {n}" for table, n in held.items() if n)
        raise RegistryError(f"the registry at {where} already holds records ({listed}): a "
                            "registry file is copied only into an empty one; nothing was "
                            "copied")
    for table, trigger in _NUMBERING_TRIGGERS:
        server.execute(sa.text(f"ALTER TABLE {table} DISABLE TRIGGER {trigger}"))
    copied = {table: _copy_table(source, server, table) for table in REGISTRY_TABLES}
    for table, trigger in _NUMBERING_TRIGGERS:
        server.execute(sa.text(f"ALTER TABLE {table} ENABLE TRIGGER {trigger}"))
    for table in REGISTRY_TABLES:
        if "id" in metadata.tables[table].c:
            server.execute(sa.text(
                f"SELECT setval(pg_get_serial_sequence('public.{table}', 'id'), "
                f"coalesce(max(id), 1), max(id) IS NOT NULL) FROM {table}"))
        _same_seals(source, source_name, server, table)
    return copied


def _copy_table(source: sqlite3.Connection, server: sa.Connection, table: str) -> int:
    columns = [c.name for c in metadata.tables[table].columns if c.name != "seal"]
    key = _key(table)
    rows = source.execute(f"SELECT {', '.join(columns)} FROM {table} ORDER BY {key}"
                          ).fetchall()
    if rows:
        server.execute(sa.insert(metadata.tables[table]),
                       [dict(zip(columns, row, strict=True)) for row in rows])
    return len(rows)


def _same_seals(source: sqlite3.Connection, source_name: str, server: sa.Connection,
                table: str) -> None:
    """Each row's seal on the server equals the file's: the same values, to the bit."""
    key = _key(table)
    theirs = dict(_keyed(source.execute(f"SELECT {key}, seal FROM {table}").fetchall()))
    ours = dict(_keyed(server.execute(sa.text(f"SELECT {key}, seal FROM {table}")).all()))
    for row_key, seal in theirs.items():
        if ours.get(row_key) != seal:
            shown = "/".join(str(part) for part in row_key)
            raise RegistryError(
                f"{table} row {shown} of {source_name} did not arrive unchanged on the server "
                "(its seal there differs from the file's); nothing was copied")


def _key(table: str) -> str:
    return ", ".join(c.name for c in metadata.tables[table].primary_key.columns)


def _keyed(rows) -> list[tuple[tuple, str]]:
    return [(tuple(row[:-1]), row[-1]) for row in rows]
