"""Today's registry schema as SQLAlchemy Core metadata (app.records.registry.postgres.tables)
is the SQLite registry's: the same tables and columns in the same order, types that keep
the same values, the same NULLs and defaults; and it builds on PostgreSQL."""

from __future__ import annotations

import contextlib
import sqlite3

import pytest
import sqlalchemy as sa

from app.errors import SchemaError
from app.records.registry import seals as sqlite_seals
from app.records.registry.postgres import create_registry, registry_version
from app.records.registry.postgres.tables import (
    REGISTRY_TABLES,
    SCHEMA_VERSION,
    metadata,
)
from app.records.registry.schema import MIGRATIONS, SCHEMA_VERSION as SQLITE_SCHEMA_VERSION

SQLITE_TYPES = {sa.BigInteger: "INTEGER", sa.Double: "REAL", sa.Text: "TEXT"}


def sqlite_registry() -> sqlite3.Connection:
    """Today's SQLite registry, in memory, built as create_registry_file builds it."""
    conn = sqlite_seals.register(sqlite3.connect(":memory:", isolation_level=None))
    for _, statements in MIGRATIONS:
        for statement in statements:
            conn.execute(statement)
    return conn


def sqlite_type(column: sa.Column) -> str:
    return next(name for kind, name in SQLITE_TYPES.items() if isinstance(column.type, kind))


def _default(column: sa.Column) -> str | None:
    """A column's default as SQLite's table_info gives it (an identity has none)."""
    default = column.server_default
    return str(default.arg) if isinstance(default, sa.DefaultClause) else None


def test_the_tables_are_the_sqlite_registrys_at_its_latest_schema():
    assert SCHEMA_VERSION == SQLITE_SCHEMA_VERSION
    with contextlib.closing(sqlite_registry()) as conn:
        tables = [name for (name,) in conn.execute(
            "SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY rowid")]
        assert tables == list(REGISTRY_TABLES)
        for name in tables:
            table = metadata.tables[name]
            sqlite = [(c[1], c[2], bool(c[3]) or bool(c[5]), c[4])
                      for c in conn.execute(f"PRAGMA table_info({name})")]
            ours = [(c.name, sqlite_type(c), not c.nullable, _default(c))
                    for c in table.columns]
            assert ours == sqlite, name
            pk = sorted(c[1] for c in conn.execute(f"PRAGMA table_info({name})") if c[5])
            assert sorted(c.name for c in table.primary_key.columns) == pk, name
            assert tuple(c.name for c in table.columns if c.name != "seal") == \
                sqlite_seals.SEALED[name], name


def test_the_foreign_keys_and_unique_keys_are_the_sqlite_registrys():
    with contextlib.closing(sqlite_registry()) as conn:
        for name in REGISTRY_TABLES:
            sqlite_fks = sorted((r[3], r[2], r[4], r[6]) for r in
                                conn.execute(f"PRAGMA foreign_key_list({name})"))
            ours = sorted((fk.parent.name, fk.column.table.name, fk.column.name,
                           fk.ondelete) for fk in metadata.tables[name].foreign_keys)
            assert ours == sqlite_fks, name
            sqlite_unique = sorted(
                tuple(c[2] for c in conn.execute(f"PRAGMA index_info('{index[1]}')"))
                for index in conn.execute(f"PRAGMA index_list({name})")
                if index[2] and index[3] == "u")
            table = metadata.tables[name]
            ours_unique = sorted({tuple(c.name for c in u.columns) for u in table.constraints
                                  if isinstance(u, sa.UniqueConstraint)}
                                 | {(c.name,) for c in table.columns if c.unique})
            assert ours_unique == sqlite_unique, name


def test_the_other_indexes_are_the_sqlite_registrys():
    """Each index the registry's queries rely on (the keys' own aside), with its columns and,
    for a partial one, its condition (schema v13's pending proposals by patient)."""
    with contextlib.closing(sqlite_registry()) as conn:
        sqlite = sorted(
            (table, name, tuple(c[2] for c in conn.execute(f"PRAGMA index_info('{name}')")),
            sql.split(" WHERE ", 1)[1] if " WHERE " in sql else None)
            for name, table, sql in conn.execute(
                "SELECT name, tbl_name, sql FROM sqlite_master WHERE type = 'index' "
                "AND sql IS NOT NULL"))
    ours = sorted(
        (table.name, index.name, tuple(c.name for c in index.columns),
         None if index.dialect_options["postgresql"]["where"] is None else
         str(index.dialect_options["postgresql"]["where"]))
        for table in metadata.tables.values() for index in table.indexes)
    assert ours == sqlite
    assert ("proposals", "proposals_pending_by_patient", ("patient_id", "trial_id"),
            "decision = 'pending'") in ours


def test_the_registry_builds_on_postgresql_with_its_version(registry):
    with registry.engine() as engine, engine.connect() as conn:
        assert registry_version(conn) == SCHEMA_VERSION
        inspector = sa.inspect(conn)
        for name in REGISTRY_TABLES:
            columns = [c["name"] for c in inspector.get_columns(name)]
            assert columns == [c.name for c in metadata.tables[name].columns]
        real = {c["name"]: c["type"] for c in inspector.get_columns("plan_steps")}
        assert isinstance(real["planned_s"], sa.Double)  # 8 bytes, as SQLite's REAL


def test_a_registry_is_created_only_in_an_empty_database(registry):
    with registry.engine() as engine, engine.connect() as conn, \
            pytest.raises(SchemaError, match="already holds registry tables"):
        create_registry(conn)


def test_a_database_without_a_registry_has_no_version(postgres_server):
    database = postgres_server.create_database()
    with contextlib.closing(sa.create_engine(postgres_server.url(database=database),
                                             poolclass=sa.NullPool).connect()) as conn:
        assert registry_version(conn) is None
