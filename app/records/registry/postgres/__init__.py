"""The registry on a PostgreSQL server, for several robot stations of a department (issue 32):
today's schema with the seals, the gap-free numbering and the clinic and research roles
enforced by the server itself.

What the server holds that the registry's code (app.records.registry, the same on both
engines: docs/stations.md) relies on: the tables as SQLAlchemy 2 Core metadata (`tables`),
each row's seal computed by a trigger with the digest the SQLite registry computes
(`seals`), session and trial numbers that stay gap-free with several stations writing at
once (`numbering`), who may read names (`roles`), and the steps from each older schema
(`MIGRATIONS`).

`create_registry` builds all of it in one transaction in an empty database, as the
database's owner (the role that later migrates it): SQLAlchemy creates the tables, then
the server's functions, triggers, grants and views are added by their SQL.
"""

from __future__ import annotations

from sqlalchemy import Connection, insert, inspect, select, text, update
from sqlalchemy.dialects import postgresql
from sqlalchemy.schema import CreateIndex

from app.errors import SchemaError
from app.records.registry.postgres import numbering, seals, tables
from app.records.registry.postgres.roles import Roles, research_view
from app.records.registry.postgres.tables import (
    REGISTRY_TABLES,
    SCHEMA_VERSION,
    metadata,
    schema_version,
)
from app.records.registry.proposals import PENDING_INDEXES, patient_of_trial
from app.records.registry.seals import sealed_at

__all__ = [
    "TRIALS_UNCOMPRESSED",
    "Roles",
    "create_registry",
    "migrate_registry",
    "registry_version",
    "trials_uncompressed",
]


def create_registry(conn: Connection, roles: Roles | None = None) -> None:
    """Today's registry in the empty database `conn` is connected to, in `conn`'s
    transaction: tables, seals, numbering, roles; its schema version recorded. Refused
    (SchemaError) where a registry, or any table of one, is already there."""
    present = sorted(set(inspect(conn).get_table_names()) & set(metadata.tables))
    if present:
        raise SchemaError(f"the database {conn.engine.url.database!r} already holds registry "
                          f"tables ({', '.join(present)}): a registry is created only in an "
                          "empty database")
    metadata.create_all(conn)
    # server-side code holds '%' (PL/pgSQL's RAISE): sent as it is, never as a template
    raw = conn.execution_options(no_parameters=True)
    for statement in (*seals.statements(), *numbering.statements(), *PROPOSALS_PATIENT,
                      *(roles or Roles()).statements(), TRIALS_UNCOMPRESSED):
        raw.exec_driver_sql(statement)
    conn.execute(insert(schema_version).values(version=SCHEMA_VERSION))


TRIALS_UNCOMPRESSED = "ALTER TABLE trials SET (toast_tuple_target = 8160)"
"""A trial's row is kept whole and uncompressed up to 8,160 bytes (the most a page allows).

A trial's row is some 2,200 bytes, 1,400 of them its metrics' JSON: over the server's
default threshold (2,032 bytes), so the server compressed the metrics (pglz) in every row,
and the progress query decompressed a patient's 1,000 of them each time it read them,
6-9 ms of the server's CPU a query, which EXPLAIN ANALYZE does not show (it sends no row).
Uncompressed, the rows take 15 % more room (docs/performance.md). It is a storage setting,
not the schema: no column, constraint or seal changes, SQLite has nothing like it, and
it applies to rows written from then on (the rows already there keep their compression
until rewritten). create_registry sets it, and `rehab db upgrade` where it is missing
(admin._server_schema, migrate_registry)."""


def trials_uncompressed(conn: Connection) -> bool:
    """Whether the trials table of `conn`'s registry keeps its rows as TRIALS_UNCOMPRESSED
    says."""
    return conn.execute(text(
        "SELECT coalesce('toast_tuple_target=8160' = ANY(reloptions), false) FROM pg_class "
        "WHERE oid = 'public.trials'::regclass")).scalar_one()


PROPOSALS_PATIENT = (
    f"""CREATE FUNCTION proposals_patient() RETURNS trigger LANGUAGE plpgsql AS $$
        BEGIN
            NEW.patient_id := {patient_of_trial("NEW.trial_id", "public.")};
            RETURN NEW;
        END $$""",
    "CREATE TRIGGER proposals_patient BEFORE INSERT OR UPDATE OF trial_id, patient_id "
    "ON proposals FOR EACH ROW EXECUTE FUNCTION proposals_patient()",
)
"""Schema v13: a proposal's `patient_id` is always its trial's session's patient, set by the
server whatever a writer gave (before the seal's trigger, which fires last: by name), so the
pending proposal found by it (app.records.registry.proposals.PENDING) is the patient's.
On SQLite, proposals._sqlite_patient_trigger."""


MIGRATIONS: dict[int, tuple[str, ...]] = {
    9: ("""DO $$ DECLARE who text; BEGIN
            FOR who IN SELECT DISTINCT grantee FROM information_schema.role_table_grants
                       WHERE table_schema = 'public' AND table_name = 'trials'
                       AND privilege_type = 'DELETE' AND grantee <> current_user LOOP
                EXECUTE format('GRANT DELETE ON plan_steps, proposals TO %I', who);
            END LOOP;
        END $$""",),
}

def _quoted(sql: str) -> str:
    """`sql` as a PL/pgSQL string literal."""
    return "'" + sql.replace("'", "''") + "'"


def _rows_match_their_seals(table: str) -> str:
    """Every row of `table` checked against its seal before a step seals it again (as on
    SQLite: damage is refused, never laundered by the upgrade)."""
    return f"""DO $$ BEGIN
            IF EXISTS (SELECT 1 FROM public.{table} r
                       WHERE r.seal IS DISTINCT FROM public.registry_seal_of_{table}(r)) THEN
                RAISE EXCEPTION 'the registry is damaged: a row of {table} does not match '
                    'its seal; nothing was changed. Restore the registry from a backup'
                    USING ERRCODE = 'data_corrupted';
            END IF;
        END $$"""


def _research_grantee(table: str, then: str) -> str:
    """A PL/pgSQL block doing `then` (a statement with %I) for whoever research's view of
    `table` is granted to."""
    return f"""DO $$ DECLARE who text; BEGIN
        SELECT grantee INTO who FROM information_schema.role_table_grants
            WHERE table_schema = 'research' AND table_name = '{table}'
            AND privilege_type = 'SELECT' AND grantee <> current_user LIMIT 1;
        IF who IS NOT NULL THEN EXECUTE format({_quoted(then)}, who); END IF;
    END $$"""


MIGRATIONS[10] = (
    *(_rows_match_their_seals(table) for table in ("trials", "plan_runs")),
    "ALTER TABLE trials ADD COLUMN station text, ADD COLUMN checksum text "
    "CONSTRAINT trials_checksum CHECK (checksum IS NULL OR checksum ~ '^[0-9a-f]{64}$')",
    "ALTER TABLE plan_runs ADD COLUMN station text",
    *(seals.table_statements(tables.metadata.tables[table], sealed_at(table, 10))[0].replace(
        "CREATE FUNCTION", "CREATE OR REPLACE FUNCTION", 1) for table in ("trials", "plan_runs")),
    "UPDATE trials SET station = NULL",  # the seal trigger seals each row again
    "UPDATE plan_runs SET station = NULL",
    # research's views: every column of the table but its seal, the hidden ones empty
    # (roles.research_columns), made again with their grant to whoever had them
    f"""DO $$ DECLARE who text; BEGIN
        SELECT grantee INTO who FROM information_schema.role_table_grants
            WHERE table_schema = 'research' AND table_name = 'trials'
            AND privilege_type = 'SELECT' AND grantee <> current_user LIMIT 1;
        {" ".join(f"DROP VIEW research.{t};" for t in REGISTRY_TABLES)}
        {" ".join(f"EXECUTE {_quoted(research_view(t, at=10))};" for t in REGISTRY_TABLES)}
        IF who IS NOT NULL THEN
            {" ".join(f"EXECUTE format('GRANT SELECT ON research.{t} TO %I', who);"
                      for t in REGISTRY_TABLES)}
            EXECUTE format('GRANT SELECT (station, checksum) ON trials TO %I', who);
            EXECUTE format('GRANT SELECT (station) ON plan_runs TO %I', who);
        END IF;
    END $$""",
)
"""The server's steps to each schema version from the one before (the first the server had
is v8). v9 brought SQLite the numbering rule the server held from its first version
(app.records.registry.numbering); on the server, the clinic role (whoever may withdraw a
trial) may now delete what a withdrawn trial takes with it (roles.WITHDRAWN_WITH_A_TRIAL).
v10: the station of each trial and plan run, and each trial file's checksum
(app.records.registry.provenance), sealed; research reads them (they name no person); and
research's views take every column of their table, the hidden ones empty (roles.
research_columns), so the registry's code reads through them on a researcher's login.
v11: the shared trial store each trial's file was copied to (app.records.registry.stores),
sealed; research reads it (a folder, named by station).
v12: a trial's registration does less work in the server: the indexes that find a patient's
pending proposal (app.records.registry.proposals.PENDING_INDEXES), and the seal's parts
declared STABLE, which lets the server inline them in every seal trigger (seals.FUNCTIONS).
Nothing a trigger or a role enforces changes; every seal stays the digest it was."""

MIGRATIONS[11] = (
    _rows_match_their_seals("trials"),
    "ALTER TABLE trials ADD COLUMN stored_in text",
    seals.table_statements(tables.metadata.tables["trials"])[0].replace(
        "CREATE FUNCTION", "CREATE OR REPLACE FUNCTION", 1),
    "UPDATE trials SET stored_in = NULL",  # the seal trigger seals each row again
    # a view may gain columns at its end in place, keeping its grants
    research_view("trials").replace("CREATE VIEW", "CREATE OR REPLACE VIEW", 1),
    _research_grantee("trials", "GRANT SELECT (stored_in) ON trials TO %I"),
)

MIGRATIONS[12] = (*reversed(PENDING_INDEXES), *seals.PARTS_STABLE)

MIGRATIONS[13] = (
    _rows_match_their_seals("proposals"),
    "ALTER TABLE proposals ADD COLUMN patient_id bigint REFERENCES patients (id) "
    "ON DELETE RESTRICT",
    seals.table_statements(tables.metadata.tables["proposals"])[0].replace(
        "CREATE FUNCTION", "CREATE OR REPLACE FUNCTION", 1),
    *PROPOSALS_PATIENT,
    "UPDATE proposals SET patient_id = NULL",  # each row's set by its trigger, sealed again
    "DROP INDEX proposals_pending",
    *(str(CreateIndex(index).compile(dialect=postgresql.dialect()))
      for index in tables.proposals.indexes if index.name == "proposals_pending_by_patient"),
    research_view("proposals").replace("CREATE VIEW", "CREATE OR REPLACE VIEW", 1),
    _research_grantee("proposals", "GRANT SELECT (patient_id) ON proposals TO %I"),
)
"""v13: each proposal's patient (PROPOSALS_PATIENT), sealed (each row checked against its v12
seal first), research reads it (an id, as a session's patient_id), and the pending
proposals indexed by it instead of by trial (app.records.registry.proposals.PENDING)."""


def migrate_registry(conn: Connection) -> tuple[int, int]:
    """Bring the registry in `conn`'s database up to today's schema, in `conn`'s transaction
    (PostgreSQL's DDL is transactional: all of it or nothing). Returns (from, to). Refused
    (SchemaError) for a database without a registry, or of a version with no step here."""
    version = registry_version(conn)
    if version is None or (version < SCHEMA_VERSION and version + 1 not in MIGRATIONS):
        raise SchemaError(f"the database {conn.engine.url.database!r} holds "
                          f"{'no registry' if version is None else f'schema v{version}'}: "
                          "this console has no migration from it on PostgreSQL")
    raw = conn.execution_options(no_parameters=True)
    for target in range(version + 1, SCHEMA_VERSION + 1):
        for statement in MIGRATIONS[target]:
            raw.exec_driver_sql(statement)
    raw.exec_driver_sql(TRIALS_UNCOMPRESSED)  # whatever the version: a setting, not schema
    conn.execute(update(schema_version).values(version=max(version, SCHEMA_VERSION)))
    return version, max(version, SCHEMA_VERSION)


def registry_version(conn: Connection) -> int | None:
    """The schema version of the registry in `conn`'s database, None when it has none."""
    if not inspect(conn).has_table("schema_version"):
        return None
    return conn.execute(select(schema_version.c.version)).scalar_one()
