"""Every row of the PostgreSQL registry sealed by the server with the digest the SQLite
registry computes (app.records.registry.seals.seal_of), and checked against it.

Why the same digest: a registry moves between the engines (a station's SQLite registry
synced to the server, a migration from today's file, a copy taken home); a row's seal must
say the same thing wherever it was written, so a check on either side catches a change made
on the other, and a test can hold one engine to the other (tests/app/records/postgres/
test_seals.py writes the same rows on both and compares the seals).

Why in the server: as on SQLite, no write path can forget it. SQLite calls a function each
console registers; PostgreSQL has SHA-256 itself (`sha256(bytea)`, PostgreSQL 11+), so the
seal is plain SQL and a BEFORE INSERT OR UPDATE trigger sets it on every row before it is
stored. A client cannot write a seal of its own: the trigger overwrites whatever it gave.

How each value becomes the bytes `seal_of` digests:

* NULL → `|n`; text → `|s<byte length>:<UTF-8 bytes>`; an integer → `|i<decimal>`.
* a float → `|f` and Python's `float.hex()`: its IEEE bits, read with `float8send`, written
  as `[-]0x1.<13 hex digits>p<±exponent>` (`0x0.…p-1022` below the normals), `inf`,
  `-inf`. Zero is `0x0.0p+0` whatever its sign: SQLite stores a REAL -0.0 as 0 and reads
  back 0.0, so that is what its seal covers. NaN never reaches a seal: SQLite stores it as
  NULL and the PostgreSQL tables refuse it (tables.py).
* The column's SQL type picks the function (`registry_seal_integer`, `_real`, `_text`):
  PostgreSQL's types are the ones SQLite stores for the console's values (tables.py).

Limits: PostgreSQL's text holds no NUL character and no lone surrogate (SQLite holds
both); such a value is refused by the server before any seal (the registry's text checks
refuse lone surrogates already; docs/stations.md).
"""

from __future__ import annotations

from sqlalchemy import BigInteger, Connection, Double, Table, Text, text

from app.errors import SchemaError
from app.records.registry.postgres.tables import metadata
from app.records.registry.seals import APPEND_ONLY, SEALED

_PART = {BigInteger: "registry_seal_integer", Double: "registry_seal_real",
         Text: "registry_seal_text"}

FUNCTIONS = (
    """CREATE FUNCTION registry_seal_text(v text) RETURNS bytea
        LANGUAGE sql STABLE PARALLEL SAFE AS $$
        SELECT CASE WHEN v IS NULL THEN convert_to('|n', 'UTF8')
               ELSE convert_to('|s' || octet_length(convert_to(v, 'UTF8')) || ':', 'UTF8')
                    || convert_to(v, 'UTF8') END $$""",
    """CREATE FUNCTION registry_seal_integer(v bigint) RETURNS bytea
        LANGUAGE sql STABLE PARALLEL SAFE AS $$
        SELECT convert_to(CASE WHEN v IS NULL THEN '|n' ELSE '|i' || v END, 'UTF8') $$""",
    # Python's float.hex(): Objects/floatobject.c float_hex, from the IEEE bits
    """CREATE FUNCTION registry_float_hex(v double precision) RETURNS text
        LANGUAGE plpgsql IMMUTABLE STRICT PARALLEL SAFE AS $$
        DECLARE
            bits bigint;
            exponent integer;
            fraction bigint;
            sign text;
        BEGIN
            IF v = 'Infinity'::float8 THEN RETURN 'inf'; END IF;
            IF v = '-Infinity'::float8 THEN RETURN '-inf'; END IF;
            IF v = 'NaN'::float8 THEN RETURN 'nan'; END IF;
            IF v = 0 THEN RETURN '0x0.0p+0'; END IF;  -- SQLite keeps -0.0 as 0
            bits := ('x' || encode(float8send(v), 'hex'))::bit(64)::bigint;
            exponent := ((bits >> 52) & 2047)::integer;
            fraction := bits & 4503599627370495;  -- the low 52 bits
            sign := CASE WHEN bits < 0 THEN '-' ELSE '' END;
            IF exponent = 0 THEN  -- a subnormal
                RETURN sign || '0x0.' || lpad(to_hex(fraction), 13, '0') || 'p-1022';
            END IF;
            RETURN sign || '0x1.' || lpad(to_hex(fraction), 13, '0') || 'p'
                || CASE WHEN exponent >= 1023 THEN '+' ELSE '' END || (exponent - 1023);
        END $$""",
    """CREATE FUNCTION registry_seal_real(v double precision) RETURNS bytea
        LANGUAGE sql STABLE PARALLEL SAFE AS $$
        SELECT convert_to(CASE WHEN v IS NULL THEN '|n'
                          ELSE '|f' || registry_float_hex(v) END, 'UTF8') $$""",
)
"""The per-type parts of a seal, shared by every table.

Why STABLE, not IMMUTABLE (schema v12, `PARTS_STABLE`): they are, as `convert_to` and `||` on
a number are, and PostgreSQL inlines a SQL function into the expression that calls it only
when the function claims no more than its body is. Declared IMMUTABLE they were never
inlined: each of a row's 13-18 parts was a call of its own, whose body the server parsed and
planned again in every transaction, so a trial's seal trigger cost 0.30 ms of the server's
time, a proposal's 0.15 ms. Inlined, 0.047 and 0.025 ms (the same digest; EXPLAIN ANALYZE's
trigger times, docs/performance.md)."""

PARTS_STABLE = tuple(
    f"ALTER FUNCTION {name} STABLE" for name in (
        "registry_seal_text(text)", "registry_seal_integer(bigint)",
        "registry_seal_real(double precision)"))
"""The parts of a seal made inlinable in a registry created before schema v12."""


def seal_function(table: Table) -> str:
    """The SQL function computing a row of `table`'s seal: `registry_seal_of_<table>`."""
    return f"registry_seal_of_{table.name}"


def _part(table: Table, column: str) -> str:
    kind = type(table.c[column].type)
    function = next((name for sql_type, name in _PART.items() if issubclass(kind, sql_type)),
                    None)
    if function is None:
        raise TypeError(f"{table.name}.{column}: no seal for a column of type {kind.__name__}")
    return f"public.{function}(r.{column})"


def table_statements(table: Table, columns: tuple[str, ...] | None = None
                     ) -> tuple[str, ...]:
    """The seal function of `table` (over `columns`, by default SEALED's, in that order) and
    the BEFORE trigger that seals each row as it is written. Named to fire last among the
    table's BEFORE triggers (they fire by name), after any that set a value."""
    name = table.name
    parts = " || ".join(_part(table, column) for column in columns or SEALED[name])
    function = seal_function(table)
    return (
        f"""CREATE FUNCTION {function}(r public.{name}) RETURNS text
            LANGUAGE sql STABLE PARALLEL SAFE AS $$
            SELECT encode(sha256(convert_to('{name}', 'UTF8') || {parts}), 'hex') $$""",
        f"""CREATE FUNCTION {name}_sealed() RETURNS trigger LANGUAGE plpgsql AS $$
            BEGIN
                NEW.seal := public.{function}(NEW);
                RETURN NEW;
            END $$""",
        f"CREATE TRIGGER zz_{name}_sealed BEFORE INSERT OR UPDATE ON {name} "
        f"FOR EACH ROW EXECUTE FUNCTION {name}_sealed()",
    )


def append_only_statements(table: str) -> tuple[str, ...]:
    """A trigger that refuses to change or delete a row of `table` once written, in the
    SQLite registry's words (seals.append_only): what a therapist recorded stays as it was
    recorded, a later row corrects it."""
    return (
        f"""CREATE FUNCTION {table}_kept_as_written() RETURNS trigger LANGUAGE plpgsql AS $$
            BEGIN
                RAISE EXCEPTION '{table} are kept as written: add a new one instead'
                    USING ERRCODE = 'integrity_constraint_violation';
            END $$""",
        f"CREATE TRIGGER {table}_append_only BEFORE UPDATE OR DELETE ON {table} "
        f"FOR EACH ROW EXECUTE FUNCTION {table}_kept_as_written()",
    )


def statements() -> tuple[str, ...]:
    """Everything that seals the registry's rows, after its tables are created."""
    out: list[str] = list(FUNCTIONS)
    for name in SEALED:
        out.extend(table_statements(metadata.tables[name]))
    for name in APPEND_ONLY:
        out.extend(append_only_statements(name))
    return tuple(out)


def _key(table: Table) -> str:
    return ", ".join(column.name for column in table.primary_key.columns)


def verify(conn: Connection, where: str) -> None:
    """SchemaError naming the first row of the registry at `where` whose values do not match
    its seal (changed by someone who bypassed the triggers: a superuser's session with
    triggers off, a restored dump edited by hand); nothing when all match. The server's
    own structure is its business (initdb --data-checksums, docs/stations.md)."""
    for name in SEALED:
        table = metadata.tables[name]
        row = conn.execute(text(
            f"SELECT {_key(table)} FROM {name} r WHERE r.seal IS NULL "
            f"OR r.seal <> public.{seal_function(table)}(r) LIMIT 1")).first()
        if row is not None:
            key = "/".join(str(value) for value in row)
            raise SchemaError(
                f"the registry {where} is damaged: {name} row {key} does not match its seal "
                "(changed by a program other than the console, with the server's seal "
                "triggers off). Nothing was read from it. Restore the registry from a "
                "backup")
