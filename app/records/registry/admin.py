"""The registry as a whole, on either engine: what `rehab db status` says of it and what
`rehab db upgrade` does to it (issue 32).

Why apart from `Registry`: opening a SQLite registry migrates it (schema.Schema._migrate),
and a status must change nothing; the PostgreSQL registry has no `Registry` yet (the
console records in SQLite; docs/stations.md). So the status reads a SQLite file read-only
and a server through one connection, and the upgrade calls each engine's own path:
SQLite's migration with its copy kept aside, PostgreSQL's `create_registry` in an empty
database, in one transaction.

Every failure is a RegistryError (or SchemaError) in one line: a server that cannot be
reached names its host and port, never the URL's password.
"""

from __future__ import annotations

import contextlib
import re
import sqlite3
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import sqlalchemy as sa

from app.errors import RegistryError, SchemaError
from app.records.datadir import REGISTRY_NAME, private_files
from app.records.registry import seals
from app.records.registry.database import CONNECT_TIMEOUT_S, SEALED_FROM, first_line
from app.records.registry.postgres import (
    MIGRATIONS,
    TRIALS_UNCOMPRESSED,
    Roles,
    create_registry,
    migrate_registry,
    registry_version,
    seals as pg_seals,
    trials_uncompressed,
)
from app.records.registry.postgres.tables import REGISTRY_TABLES
from app.records.registry.schema import SCHEMA_VERSION, Schema, check_registry_file
from app.records.registry.transfer import copy_registry
from app.records.registry.url import POSTGRESQL, RegistryURL, login_refusal
from device.safewrite import folded

ROLE_NAME = re.compile(r"[a-z_][a-z0-9_]{0,62}")
"""A role name put into SQL as it is: lower-case letters, digits and '_' only."""


@dataclass(frozen=True)
class Status:
    """What `rehab db status` prints, one line each; `damaged` the seal check's refusal
    (None when every row matches its seal, or the seals could not be checked)."""

    lines: tuple[str, ...]
    damaged: str | None = None


NOTHING_TO_DO = ": nothing to do"
"""The end of an upgrade's line when the registry is already this console's."""


def schema_line(version: int | None) -> str:
    """The registry's schema against this console's, and whether an upgrade is due."""
    mine = f"this console v{SCHEMA_VERSION}"
    if version is None:
        return f"schema: none here ({mine}): `rehab db upgrade` creates the registry"
    if version > SCHEMA_VERSION:
        return (f"schema: v{version} here, {mine}: the registry is newer, update this "
                "console (an upgrade is refused)")
    if version < SCHEMA_VERSION:
        return f"schema: v{version} here, {mine}: an upgrade is due (`rehab db upgrade`)"
    return f"schema: v{version} here, {mine}: up to date"


def status(location: RegistryURL) -> Status:
    if location.engine == POSTGRESQL:
        return _server_status(location)
    return _file_status(location)


def upgrade(location: RegistryURL, roles: Roles | None = None,
            source: Path | None = None) -> str:
    """Bring the registry to this console's schema; the one line saying what was done.
    SchemaError for a registry newer than this console. `source`: a SQLite registry file
    (or its data folder) copied into the server's registry, which must be empty
    (registry.transfer), in the same transaction."""
    if location.engine == POSTGRESQL:
        return _server_upgrade(location, roles or Roles(), source)
    if source is not None:
        raise RegistryError(f"--from copies a SQLite registry onto a PostgreSQL server, but "
                            f"this console's registry is the SQLite file {location.path} "
                            f"(from {location.source}): point the registry URL file at the "
                            "server first")
    return _file_upgrade(location)


def check_roles(clinic: str, research: str) -> Roles:
    """The group roles' names, refused unless they are plain SQL names, and different."""
    for which, name in (("clinic", clinic), ("research", research)):
        if not ROLE_NAME.fullmatch(name):
            raise RegistryError(f"the {which} role's name {name!r} is not one the console "
                                "uses: give lower-case letters, digits and '_' (at most 63, "
                                "not starting with a digit)")
    if clinic == research:
        raise RegistryError(f"the clinic and research roles are both {clinic!r}: give each "
                            "its own name (research must not read what clinic reads)")
    return Roles(clinic=clinic, research=research)


# -- SQLite -------------------------------------------------------------------------------
class _File(Schema):
    """The migration of `Schema` on a registry file named by a URL (not only a data
    folder's)."""

    def __init__(self, path: Path) -> None:
        self.path = path


def _existing_file(location: RegistryURL) -> Path:
    path = location.path
    if check_registry_file(path, path.parent / "trials") is None:
        raise RegistryError(f"no registry at {path} (from {location.source}): register a "
                            "first patient (`rehab patients add`) to start one, or check "
                            "the URL")
    return path


@contextlib.contextmanager
def _read_only(path: Path) -> Iterator[sqlite3.Connection]:
    try:
        conn = seals.register(sqlite3.connect(f"{path.as_uri()}?mode=ro", uri=True))
    except sqlite3.Error as exc:
        raise RegistryError(f"the registry {path} cannot be opened ({folded(exc)}): check "
                            "its permissions") from None
    try:
        yield conn
    except sqlite3.Error as exc:
        raise RegistryError(f"the registry {path} cannot be read ({folded(exc)}): check the "
                            "disk; restore it from a backup if it is damaged") from None
    finally:
        conn.close()


def _file_status(location: RegistryURL) -> Status:
    path = _existing_file(location)
    with _read_only(path) as conn:
        version = conn.execute("PRAGMA user_version").fetchone()[0]
        present = {name for (name,) in conn.execute(
            "SELECT name FROM sqlite_master WHERE type = 'table'")}
        counts = {table: conn.execute(f"SELECT count(*) FROM {table}").fetchone()[0]
                  for table in REGISTRY_TABLES if table in present}
        damaged = None
        if version > SCHEMA_VERSION:
            seal = "seals: not checked (the registry is newer than this console)"
        elif version < SEALED_FROM:
            seal = f"seals: none before schema v{SEALED_FROM} (the upgrade seals every row)"
        else:
            try:
                seals.verify(conn, path)
                seal = "seals: every row matches its seal (and SQLite's integrity check passes)"
            except SchemaError as exc:
                damaged = str(exc)
                seal = "seals: DAMAGED (below)"
    return Status((f"registry: SQLite file {path} (from {location.source})",
                   schema_line(version), _rows_line(counts), seal), damaged)


def _file_upgrade(location: RegistryURL) -> str:
    path = _existing_file(location)
    with _read_only(path) as conn:
        before = conn.execute("PRAGMA user_version").fetchone()[0]
    registry = _File(path)
    if before > SCHEMA_VERSION:
        raise registry._too_new(before)
    if before == SCHEMA_VERSION:
        return f"the registry {path} is at schema v{before}, this console's: nothing to do"
    registry._migrate()  # the copy kept aside first, then one transaction (schema.py)
    private_files(path)
    kept = sorted(path.parent.glob(f"{path.name}.v{before}-*.bak"))
    copy = f"; its copy at v{before} is kept as {kept[-1].name}" if kept else ""
    return (f"the registry {path} upgraded from schema v{before} to "
            f"v{registry.schema_version()}{copy}")


# -- PostgreSQL ---------------------------------------------------------------------------
@contextlib.contextmanager
def _server(location: RegistryURL, *, autocommit: bool) -> Iterator[sa.Connection]:
    """One connection to the server; what psycopg says when it cannot be reached or used
    becomes one line naming the server, never the password."""
    engine = sa.create_engine(location.url, poolclass=sa.NullPool,
                              connect_args={"connect_timeout": CONNECT_TIMEOUT_S})
    try:
        try:
            conn = engine.connect()
        except sa.exc.DBAPIError as exc:  # no answer, no such database, a login refused
            refused = login_refusal(_reason(exc), location.url, location.source)
            if refused:
                raise RegistryError(refused) from None
            raise RegistryError(f"cannot reach the registry's server {location.server} "
                                f"({_reason(exc)}): check that the server runs and that this "
                                "station's network reaches it, and the URL in "
                                f"{location.source}") from None
        with conn:
            if autocommit:
                conn = conn.execution_options(isolation_level="AUTOCOMMIT")
            yield conn
    except sa.exc.DBAPIError as exc:
        raise RegistryError(f"the registry's server {location.server} refused "
                            f"({_reason(exc)}); nothing was changed") from None
    finally:
        engine.dispose()


def _reason(exc: sa.exc.DBAPIError) -> str:
    return folded(first_line(exc))


def _denied(exc: sa.exc.DBAPIError) -> bool:
    return getattr(exc.orig, "sqlstate", None) == "42501"  # insufficient_privilege


def _server_status(location: RegistryURL) -> Status:
    with _server(location, autocommit=True) as conn:
        login, server = conn.execute(sa.text("SELECT current_user, current_setting("
                                             "'server_version')")).one()
        version = registry_version(conn)
        present = set(sa.inspect(conn).get_table_names())
        counts: dict[str, int | str] = {}
        for table in REGISTRY_TABLES:
            if table in present:
                try:
                    counts[table] = conn.execute(sa.text(
                        f"SELECT count(*) FROM {table}")).scalar_one()
                except sa.exc.ProgrammingError as exc:
                    if not _denied(exc):
                        raise
                    counts[table] = "not readable by this login"
        damaged = None
        if version is None or version > SCHEMA_VERSION:
            seal = "seals: not checked (" + ("no registry here)" if version is None else
                                             "the registry is newer than this console)")
        else:
            try:
                pg_seals.verify(conn, location.shown)
                seal = "seals: every row matches its seal"
            except sa.exc.ProgrammingError as exc:
                if not _denied(exc):
                    raise
                seal = f"seals: not checked (the login {login} may not read them)"
            except SchemaError as exc:
                damaged = str(exc)
                seal = "seals: DAMAGED (below)"
    return Status((f"registry: PostgreSQL {server} at {location.shown} (from "
                   f"{location.source}), login {login}",
                   schema_line(version), _rows_line(counts), seal), damaged)


def _server_upgrade(location: RegistryURL, roles: Roles, source: Path | None = None) -> str:
    if source is None:
        return _server_schema(location, roles)
    path = source / REGISTRY_NAME if source.is_dir() else source
    if check_registry_file(path, path.parent / "trials") is None:
        raise RegistryError(f"no registry file at {path} to copy: give a registry.sqlite3 "
                            "or the data folder holding it")
    where = location.shown
    with _read_only(path) as file, _server(location, autocommit=False) as conn, conn.begin():
        # the schema's line without its "nothing to do": the copy is something to do
        # (it read "…, this console's: nothing to do; the registry … copied into it")
        done = _server_schema(location, roles, conn).removesuffix(NOTHING_TO_DO)
        copied = copy_registry(file, str(path), conn, where)
    rows = ", ".join(f"{table} {n}" for table, n in copied.items())
    return (f"{done}; the registry {path} copied into it ({rows}): every row's seal on the "
            "server is the file's")


def _server_schema(location: RegistryURL, roles: Roles, conn: sa.Connection | None = None
                   ) -> str:
    """The server's registry created or brought to this console's schema, in `conn`'s
    transaction (a new one when None); the line saying what was done."""
    if conn is None:
        with _server(location, autocommit=False) as conn, conn.begin():
            return _server_schema(location, roles, conn)
    where = location.shown
    # two upgrades at once: the second waits, then finds the registry made
    conn.execute(sa.text("SELECT pg_advisory_xact_lock(hashtext('rehab registry'))"))
    version = registry_version(conn)
    if version is None:
        create_registry(conn, roles)
        return (f"the registry created at {where}: schema v{SCHEMA_VERSION}, seals, "
                f"numbering, roles {roles.clinic} (names) and {roles.research} (codes "
                "and data)")
    if version > SCHEMA_VERSION:
        raise SchemaError(f"the registry at {where} has schema v{version}, written by a "
                          f"newer console; this one reads up to v{SCHEMA_VERSION}. "
                          "Update the console; nothing was changed")
    if version == SCHEMA_VERSION:
        if trials_uncompressed(conn):
            return (f"the registry at {where} is at schema v{version}, this console's"
                    f"{NOTHING_TO_DO}")
        conn.exec_driver_sql(TRIALS_UNCOMPRESSED)
        return (f"the registry at {where} is at schema v{version}, this console's; its "
                "trials written from now on are stored uncompressed (a faster progress "
                "query)")
    if version + 1 not in MIGRATIONS:
        raise SchemaError(f"the registry at {where} has schema v{version}: this console "
                          "has no migration from it on PostgreSQL; nothing was changed")
    before, after = migrate_registry(conn)
    return f"the registry at {where} updated from schema v{before} to v{after}"


def _rows_line(counts: dict[str, int | str]) -> str:
    if not counts:
        return "rows: no registry tables"
    return "rows: " + ", ".join(f"{table} {count}" for table, count in counts.items())
