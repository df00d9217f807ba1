"""A station's standby registry: the patients it works with, copied from the department's
server into a SQLite registry of its own, so it can go on recording for them when the server
cannot be reached (issue 32: "a station never stops a session because the network is down";
docs/stations.md, Offline stations).

The standby is a whole registry (this console's schema, seals and numbering triggers) in
`<data folder>/offline/registry.sqlite3`; its trial files are the data folder's own
(`StandbyDataDir`), so a trial recorded offline is where it will stay. It holds:

* the mirrored patients' rows, every table, with the server's ids and numbers: the standby
  numbers a patient's next session and trial exactly as the server would, and answers what
  the window asks (progress, the pending proposal, the plan) from the same records;
* the manifest (`station_mirror`): each mirrored row's key and seal as the server had it.
  The seals are the same digest on both engines (postgres/seals.py), so equal seals prove
  the copy exact, and after a spell offline a row whose seal differs from its manifest's is
  one the station changed, a row not in it one the station added (`changes`: the sync's
  work, app.records.station.sync).

The standby is built whole in a temporary file and moved into place (`build_standby`), and
only while it holds nothing unsynced: what a station recorded offline is never overwritten.
"""

from __future__ import annotations

import contextlib
import datetime
import json
import os
import sqlite3
import tempfile
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

import sqlalchemy as sa

from app.errors import RegistryError
from app.records.datadir import OFFLINE, REGISTRY_NAME, DataDir
from app.records.registry import numbering, seals
from app.records.registry.postgres.tables import REGISTRY_TABLES, metadata
from app.records.registry.schema import MIGRATIONS, SCHEMA_VERSION
from app.records.safewrite import atomic_path
from device.safewrite import make_private_folders

_TRIALS_OF = "SELECT t.id FROM trials t JOIN sessions s ON s.id = t.session_id " \
             "WHERE s.patient_id = :patient"
_SESSIONS_OF = "SELECT id FROM sessions WHERE patient_id = :patient"
PATIENT_ROWS: dict[str, str] = {
    "patients": "id = :patient",
    "sessions": "patient_id = :patient",
    "trials": f"session_id IN ({_SESSIONS_OF})",
    "proposals": f"trial_id IN ({_TRIALS_OF})",
    "plans": "patient_id = :patient",
    "plan_runs": "plan_id IN (SELECT id FROM plans WHERE patient_id = :patient)",
    "plan_steps": "run_id IN (SELECT r.id FROM plan_runs r JOIN plans p ON p.id = r.plan_id "
                  "WHERE p.patient_id = :patient)",
    "scales": f"session_id IN ({_SESSIONS_OF})",
    "notes": f"session_id IN ({_SESSIONS_OF})",
    "trial_marks": f"trial_id IN ({_TRIALS_OF})",
    "corrections": "patient_id = :patient",
}
"""Each table's rows of one patient (`:patient`, the patient's id): everything the registry
holds of them."""

_MIRROR_DDL = (
    "CREATE TABLE station_mirror (tbl TEXT NOT NULL, key TEXT NOT NULL, seal TEXT NOT NULL, "
    "patient TEXT NOT NULL, PRIMARY KEY (tbl, key))",
    "CREATE TABLE station_mirror_source (one INTEGER PRIMARY KEY CHECK (one = 1), "
    "server TEXT NOT NULL, built_at TEXT NOT NULL)",
    "CREATE INDEX station_mirror_by_patient ON station_mirror (patient)",
)

Rows = dict[str, list[tuple]]
"""Rows per table, each its values in seals.SEALED's order, then its seal."""
Patients = dict[str, Rows]
"""Rows per patient code."""


@dataclass(frozen=True, slots=True)
class StandbyDataDir(DataDir):
    """The data folder with the standby registry in its `offline` folder: a registry over it
    writes its trial files, reports and exports into the data folder itself."""

    @property
    def registry_path(self) -> Path:
        return self.root / OFFLINE / REGISTRY_NAME


def key_columns(table: str) -> tuple[str, ...]:
    return tuple(c.name for c in metadata.tables[table].primary_key.columns)


def key_text(values) -> str:
    """A row's key as the manifest stores it: its primary key's values as compact JSON (the
    server's refresh query writes it alike: refresh._keys_and_seals)."""
    return json.dumps(list(values), separators=(",", ":"))


def row_key(table: str, row: tuple) -> str:
    """The key text (`key_text`) of a row in seals.SEALED's order."""
    columns = seals.SEALED[table]
    return key_text(row[columns.index(name)] for name in key_columns(table))


def patient_id(conn: sa.Connection, code: str) -> int | None:
    found = conn.execute(sa.text("SELECT id FROM patients WHERE code = :code"),
                         {"code": code}).first()
    return None if found is None else found[0]


def patient_rows(conn: sa.Connection, codes: Iterable[str]) -> Patients:
    """The server's rows of the patients with these codes (those it has), every table."""
    found: Patients = {}
    for code in codes:
        patient = patient_id(conn, code)
        if patient is not None:
            found[code] = {table: rows_of(conn, table, patient) for table in REGISTRY_TABLES}
    return found


def rows_of(conn: sa.Connection, table: str, patient: int, where: str = "",
            params: Mapping | None = None) -> list[tuple]:
    """The server's rows of `table` of the patient with id `patient` (and `where`), by key."""
    columns = ", ".join((*seals.SEALED[table], "seal"))
    query = sa.text(f"SELECT {columns} FROM {table} WHERE {PATIENT_ROWS[table]} {where} "
                    f"ORDER BY {', '.join(key_columns(table))}")
    if params and "keys" in params:
        query = query.bindparams(sa.bindparam("keys", expanding=True))
    return [tuple(r) for r in conn.execute(query, {"patient": patient, **(params or {})})]


def standby_path(data_dir: DataDir) -> Path:
    return StandbyDataDir(data_dir.root).registry_path


def stamp() -> str:
    """Now, UTC, for the name of a standby kept aside."""
    return datetime.datetime.now(datetime.UTC).strftime("%Y%m%dT%H%M%S.%fZ")


def keep_sent(path: Path) -> Path:
    """The standby at `path` as it was sent, kept beside it (`synced-<UTC>.sqlite3`), then
    removed: the next mirror starts from the server."""
    kept = path.with_name(f"synced-{stamp()}.sqlite3")
    with contextlib.closing(sqlite3.connect(path)) as source, \
            atomic_path(kept, owned=True) as temporary, \
            contextlib.closing(sqlite3.connect(temporary)) as copy:
        source.backup(copy)
    for suffix in ("", "-wal", "-shm"):
        with contextlib.suppress(FileNotFoundError):
            os.unlink(f"{path}{suffix}")
    return kept


def build_standby(data_dir: DataDir, rows: Patients, server: str, built_at: str) -> None:
    """The standby registry holding `rows` (from `patient_rows`) and their manifest, built
    whole beside its place and moved there; RegistryError when a copied row's seal is not
    the server's (the copy would not be exact: nothing is moved into place)."""
    path = standby_path(data_dir)
    make_private_folders(path.parent)
    # Built aside and moved over the last build: the standby is the station's own copy of
    # the server's rows, replaced only when it holds nothing unsent (the caller checks;
    # app.records.safewrite refuses to write over a database, rightly, everywhere else).
    fd, name = tempfile.mkstemp(prefix=".standby-", suffix=".sqlite3", dir=path.parent)
    os.close(fd)
    temporary = Path(name)
    try:
        with contextlib.closing(seals.register(
                sqlite3.connect(temporary, isolation_level=None))) as conn:
            conn.execute("BEGIN IMMEDIATE")
            for _, statements in MIGRATIONS:
                for statement in statements:
                    conn.execute(statement)
            conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
            for statement in _MIRROR_DDL:
                conn.execute(statement)
            # The server's numbers as they are: a registry from before schema v9 may hold
            # gaps a therapist typed, which the insert triggers would refuse to copy.
            conn.execute("DROP TRIGGER sessions_numbered")
            conn.execute("DROP TRIGGER trials_numbered")
            for table in REGISTRY_TABLES:
                for code, theirs in rows.items():
                    _copy(conn, table, theirs[table], code)
            for statement in numbering.SQLITE_V9[:2]:
                conn.execute(statement)
            conn.execute("INSERT INTO station_mirror_source VALUES (1, ?, ?)",
                         (server, built_at))
            conn.execute("COMMIT")
            conn.execute("PRAGMA journal_mode = WAL")
        with open(temporary, "rb") as written:
            os.fsync(written.fileno())
        for suffix in ("-wal", "-shm"):  # the last build's, if its console stopped hard
            with contextlib.suppress(FileNotFoundError):
                os.unlink(f"{path}{suffix}")
        os.replace(temporary, path)
    except BaseException:
        for suffix in ("", "-wal", "-shm"):
            with contextlib.suppress(FileNotFoundError):
                os.unlink(f"{temporary}{suffix}")
        raise


def _copy(conn: sqlite3.Connection, table: str, rows: list[tuple], code: str) -> None:
    columns = seals.SEALED[table]
    marks = ", ".join("?" for _ in columns)
    conn.executemany(f"INSERT INTO {table} ({', '.join(columns)}) VALUES ({marks})",
                     [row[:-1] for row in rows])
    record_mirrored(conn, table, rows, code)


def record_mirrored(conn: sqlite3.Connection, table: str, rows: list[tuple],
                    code: str) -> None:
    """Each of `rows`, as written into the standby, has the server's seal (RegistryError
    otherwise: the copy would not be exact); the manifest keeps it."""
    if not rows:
        return
    keys = [row_key(table, row) for row in rows]
    names = key_columns(table)
    # by the key's first column (the primary key's index), the whole key compared below
    firsts = sorted({json.loads(key)[0] for key in keys})
    stored = {key_text(r[:-1]): r[-1] for r in conn.execute(
        f"SELECT {', '.join(names)}, seal FROM {table} WHERE {names[0]} IN "
        f"({', '.join('?' for _ in firsts)})", firsts)}
    for key, row in zip(keys, rows, strict=True):
        if stored.get(key) != row[-1]:
            raise RegistryError(f"{table} row {key} did not copy unchanged into the "
                                "station's standby registry (its seal differs from the "
                                "server's); the standby was left as it was")
    conn.executemany("INSERT OR REPLACE INTO station_mirror VALUES (?, ?, ?, ?)",
                     [(table, key, row[-1], code) for key, row in zip(keys, rows, strict=True)])


def standby_rows(conn: sqlite3.Connection) -> Rows:
    """Every row of the standby registry (as `patient_rows` gives the server's)."""
    return {table: [tuple(r) for r in conn.execute(
        f"SELECT {', '.join((*seals.SEALED[table], 'seal'))} FROM {table} "
        f"ORDER BY {', '.join(key_columns(table))}")] for table in REGISTRY_TABLES}


def manifest(conn: sqlite3.Connection) -> dict[str, dict[str, str]]:
    """Each mirrored row's seal as the server had it, per table and key."""
    found: dict[str, dict[str, str]] = {table: {} for table in REGISTRY_TABLES}
    for table, key, seal in conn.execute("SELECT tbl, key, seal FROM station_mirror"):
        found[table][key] = seal
    return found


@dataclass(frozen=True, slots=True)
class Change:
    """A row the station added (`mirrored` None) or changed while it was offline."""

    table: str
    row: tuple  # values in seals.SEALED's order, then the seal
    mirrored: str | None  # the seal the server had when the row was mirrored


def changes(rows: Rows, mirrored: Mapping[str, Mapping[str, str]]) -> list[Change]:
    """What the standby holds that the server did not when it was mirrored: rows added or
    changed, in the tables' order (what the sync replays), each table's by key."""
    found = []
    for table in REGISTRY_TABLES:
        known = mirrored.get(table, {})
        for row in rows[table]:
            before = known.get(row_key(table, row))
            if before != row[-1]:
                found.append(Change(table, row, before))
    return found
