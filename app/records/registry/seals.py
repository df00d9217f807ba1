"""Every row of the registry sealed with a digest of its values, checked before anything is
read from it (issue 28, "Integrity of meaning"; schema v6).

Why: SQLite keeps no checksum of its pages. A bit flipped on the disk, in a backup or a
copy changes a patient's name, a trial's status or its parameters and every query reads
the changed value as if it had been written (a byte flipped in a name's page gave
"UnicodeDecodeError" at best, a different letter at worst). The trial files carry their
own seals; the registry's rows now do too.

How:

* Each sealed table (`SEALED`) has a `seal` column: the SHA-256 of the table's name and
  the row's other values in the order of `SEALED` (`seal_of`: each value tagged with
  its type and length, floats exactly as stored).
* The seal is computed by SQLite itself, in triggers after every INSERT and every UPDATE of
  a sealed column, through the function `registry_seal` that every connection of the
  console registers (`register`). So no write path of the console can forget it, and a
  tool that edits the registry without the console (a database browser, the sqlite3
  shell) is refused at once ("no such function: registry_seal") instead of leaving a row
  that no longer matches.
* Before a read or a write the console checks the file's structure (SQLite's integrity
  check: a damaged index would find the wrong patient, or none) and every row against
  its seal (`verify`), once for each state of the file (`Database` keeps the size and
  modification time of the file and its WAL it last checked); damage refuses the
  registry in one line naming what is damaged (bench/registry.py gives the check's cost).

What a seal is not: it is not keyed. It catches damage, not a person who recomputes it
with this module; the registry, unlike a model's approval, grants nothing by itself.
"""

from __future__ import annotations

import hashlib
import sqlite3

from app.errors import SchemaError

FUNCTION = "registry_seal"

SEALED_AT_V7: dict[str, tuple[str, ...]] = {
    "patients": ("id", "code", "first_name", "last_name", "birth_year", "side",
                 "body_mass_kg", "upper_arm_m", "forearm_m", "shoulder_x_m", "shoulder_y_m",
                 "notes", "created_at"),
}
"""The columns a sealed table's seal covered at v7 where v8 changed them (its migration
checks each row against them before sealing it again)."""

SEALED_AT_V9: dict[str, tuple[str, ...]] = {
    "trials": ("id", "session_id", "number", "parameters", "file", "metrics", "status",
               "started_at", "ended_at", "patient_kind", "backend", "end_reason",
               "assistance"),
    "plan_runs": ("id", "plan_id", "started_at", "ended_at", "status", "end_reason"),
}
"""The same for v9, where v10 changed them (a trial's station and its file's checksum, a
plan run's station: issue 32)."""

SEALED_AT_V10: dict[str, tuple[str, ...]] = {
    "trials": (*SEALED_AT_V9["trials"], "station", "checksum"),
}
"""The same for v10, where v11 changed them (the shared trial store a trial's file was
copied to: app.records.registry.stores)."""

SEALED_AT_V12: dict[str, tuple[str, ...]] = {
    "proposals": ("trial_id", "proposal", "decision", "next_trial_id", "proposed_at",
                  "decided_at"),
}
"""The same for v12, where v13 changed them (the patient each proposal is for:
app.records.registry.proposals.SQLITE_V13)."""

SEALED: dict[str, tuple[str, ...]] = {
    "patients": (*SEALED_AT_V7["patients"], "sex", "handedness"),
    "sessions": ("id", "patient_id", "number", "date", "therapist", "notes", "location"),
    "trials": (*SEALED_AT_V10["trials"], "stored_in"),
    "proposals": (*SEALED_AT_V12["proposals"], "patient_id"),
    "plans": ("id", "patient_id", "name", "plan", "template", "based_on", "created_at"),
    "plan_runs": (*SEALED_AT_V9["plan_runs"], "station"),
    "plan_steps": ("run_id", "step", "block", "round", "kind", "trial_id", "planned_s",
                   "taken_s"),
    "scales": ("id", "session_id", "scale", "total", "detail", "rater", "recorded_at"),
    "notes": ("id", "session_id", "trial_id", "text", "author", "written_at"),
    "trial_marks": ("id", "trial_id", "valid", "reason", "marked_by", "marked_at"),
    "corrections": ("id", "patient_id", "field", "old_value", "new_value", "reason",
                    "corrected_by", "corrected_at"),
}
"""The sealed tables and the columns their seal covers (every column but `seal`, in the
table's order). A migration that adds a column must add it here, check the rows against
their old seal (`checked_before_resealing`), seal them again and recreate the table's
triggers; one that adds a table creates it with its `seal` column and its `triggers`
(tests/app/records/test_registry_seals.py holds this to the schema)."""

APPEND_ONLY = ("scales", "notes", "trial_marks", "corrections")
"""The tables whose rows are never changed nor deleted once written (schema v8): a
therapist's scales, notes, validity marks and corrections are a history; a later row
supersedes an earlier one, which stays (`append_only`)."""

SEALED_AT_V6 = ("patients", "sessions", "trials", "proposals")
"""The tables schema v6 sealed (its migration, as it shipped: later tables are made
sealed by the migration that creates them)."""


def seal_of(table: str, *values) -> str:
    """The seal of a row of `table` with these values (in SEALED's order): SHA-256 over
    the table's name and each value tagged with its type and length (floats by their
    exact hexadecimal form), so that no two rows' values give the same bytes."""
    digest = hashlib.sha256(table.encode())
    update = digest.update
    for value in values:
        if value is None:
            update(b"|n")
        elif isinstance(value, str):
            data = value.encode("utf-8", "surrogatepass")
            update(b"|s%d:" % len(data))
            update(data)
        elif isinstance(value, float):
            update(b"|f" + value.hex().encode())
        elif isinstance(value, int):
            update(b"|i%d" % value)
        else:  # a BLOB
            data = bytes(value)
            update(b"|b%d:" % len(data))
            update(data)
    return digest.hexdigest()


def register(conn: sqlite3.Connection) -> sqlite3.Connection:
    """Give `conn` the seal function its triggers and `verify` call."""
    conn.create_function(FUNCTION, -1, seal_of, deterministic=True)
    return conn


def sealed_at(table: str, version: int) -> tuple[str, ...]:
    """The columns `table`'s seal covered at schema `version` (a historic migration seals
    and triggers over these, not over today's)."""
    for changed_at, before in ((8, SEALED_AT_V7), (10, SEALED_AT_V9), (11, SEALED_AT_V10),
                               (13, SEALED_AT_V12)):
        if version < changed_at and table in before:
            return before[table]
    return SEALED[table]


def call(table: str, columns: tuple[str, ...] | None = None) -> str:
    """The SQL expression of a row's seal (over `columns`, by default SEALED's)."""
    return f"{FUNCTION}('{table}', {', '.join(columns or SEALED[table])})"



def migration() -> tuple[str, ...]:
    """Schema v6: the seal column, every existing row sealed as it is (it is trusted at
    the upgrade, after the copy the migration keeps), and the triggers; over each table's
    columns at v6 (sealed_at: a later schema added some)."""
    statements: list[str] = []
    for table in SEALED_AT_V6:
        columns = sealed_at(table, 6)
        statements.append(f"ALTER TABLE {table} ADD COLUMN seal TEXT")
        statements.append(f"UPDATE {table} SET seal = {call(table, columns)}")
        statements.extend(triggers(table, columns))
    return tuple(statements)


def triggers(table: str, columns: tuple[str, ...] | None = None) -> tuple[str, str]:
    """The two triggers that seal `table`'s rows: after an insert, and after an update of
    any sealed column (the seal's own update is not one, so it does not fire again)."""
    columns = columns or SEALED[table]
    body = (f"BEGIN UPDATE {table} SET seal = {call(table, columns)} WHERE rowid = NEW.rowid;"
            " END")
    return (f"CREATE TRIGGER {table}_sealed_on_insert AFTER INSERT ON {table} {body}",
            f"CREATE TRIGGER {table}_sealed_on_update AFTER UPDATE OF {', '.join(columns)} "
            f"ON {table} {body}")


def append_only(table: str) -> tuple[str, str]:
    """Two triggers that refuse to change or delete a row of `table` once it is written
    (its seal, which the insert trigger writes, aside): what a therapist recorded stays
    as it was recorded, a later row corrects it."""
    columns = ", ".join(SEALED[table])
    return (f"CREATE TRIGGER {table}_append_only_update BEFORE UPDATE OF {columns} ON "
            f"{table} BEGIN SELECT RAISE(ABORT, '{table} are kept as written: add a new "
            "one instead'); END",
            f"CREATE TRIGGER {table}_append_only_delete BEFORE DELETE ON {table} BEGIN "
            f"SELECT RAISE(ABORT, '{table} are kept as written: add a new one instead'); "
            "END")


def checked_before_resealing(table: str, columns: tuple[str, ...]) -> tuple[str, ...]:
    """Statements that fail (a CHECK constraint naming the table) when any row of `table`
    does not match its seal over `columns`, the table's sealed columns before a
    migration: a migration that seals the rows again first checks them, so a row damaged
    before the upgrade is refused, not sealed as sound."""
    check = f"{table}_rows_match_their_seals"
    return (f"CREATE TEMP TABLE {check} (sound INTEGER CONSTRAINT {check} CHECK (sound), "
            "row INTEGER)",
            f"INSERT INTO {check} SELECT coalesce(seal = {call(table, columns)}, 0), rowid "
            f"FROM {table}",
            f"DROP TABLE {check}")


def verify(conn: sqlite3.Connection, path) -> None:
    """SchemaError naming what is damaged in the registry at `path`: its structure
    (SQLite's integrity check: pages, indexes against their tables, constraints; a
    damaged index would find the wrong patient or none) or the first row whose values do
    not match its seal; nothing when all is sound."""
    problems = [r[0] for r in conn.execute("PRAGMA integrity_check") if r[0] != "ok"]
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise SchemaError(
            f"the registry {path} is damaged: {' '.join(problems[0].split())}{more}. "
            "Nothing was read from it. Restore the registry from a backup (a "
            "registry.sqlite3.v*.bak beside it, or your own copy)")
    for table in SEALED:
        mismatch = f"seal IS NULL OR seal != {call(table)}"
        try:
            row = conn.execute(f"SELECT rowid FROM {table} WHERE {mismatch} LIMIT 1"
                               ).fetchone()
        except sqlite3.OperationalError as exc:
            if "user-defined function raised exception" not in str(exc):
                # the table's definition no longer names the columns the seal covers (a
                # changed byte in the schema's own text, which the integrity check does
                # not read): the structure is damaged, not just a row
                raise SchemaError(
                    f"the registry {path} is damaged: its table {table} no longer has the "
                    f"columns the console wrote ({' '.join(str(exc).split())}). Nothing "
                    "was read from it. Restore the registry from a backup (a "
                    "registry.sqlite3.v*.bak beside it, or your own copy)") from None
            # a value that cannot reach the seal (text that is not UTF-8): find its row
            row = _first_unreadable(conn, table, mismatch)
        if row is not None:
            raise SchemaError(
                f"the registry {path} is damaged: {table} row {row[0]} does not match its "
                "seal (changed on the disk, in a copy, or by a program other than the "
                "console). Nothing was read from it. Restore the registry from a backup "
                "(a registry.sqlite3.v*.bak beside it, or your own copy)")


def _first_unreadable(conn: sqlite3.Connection, table: str, mismatch: str) -> tuple:
    for (rowid,) in conn.execute(f"SELECT rowid FROM {table} ORDER BY rowid").fetchall():
        try:
            bad = conn.execute(f"SELECT 1 FROM {table} WHERE rowid = ? AND ({mismatch})",
                               (rowid,)).fetchone()
        except sqlite3.OperationalError:
            bad = (1,)
        if bad is not None:
            return (rowid,)
    return ("?",)
