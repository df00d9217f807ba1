"""The registry's SQL, written once for both engines (SQLite and PostgreSQL) and run through
SQLAlchemy 2 Core (issue 32, docs/stations.md).

The registry's statements are plain SQL text that both engines read as it stands: joins,
subqueries, `INSERT … RETURNING id` (SQLite ≥ 3.35), `coalesce`, `LIMIT`. They keep the
DB-API's `?` placeholders in the order of their values, as the registry wrote them before
it had two engines; `execute` hands them to SQLAlchemy as `text()` with numbered binds,
so each engine's driver gets its own parameter style. Three things differ between the
engines, and are written once here rather than in each statement:

* `json_value(column, 'name')`: a member of a JSON text column as the JSON holds it (a
  number as a number, a string as text, NULL when absent). SQLite: `json_extract(column,
  '$.name')`. PostgreSQL: `(column::jsonb -> 'name')`, which psycopg returns parsed (the
  same Python number or string).
* `json_text(column, 'name')`: the member as text, for comparisons and `coalesce` with text.
  SQLite: `json_extract` (the registry's members compared so are strings); PostgreSQL:
  `->>`.
* `FOR NO KEY UPDATE` / `FOR UPDATE` after a SELECT: the row lock a read-then-write sequence
  takes on the server, where stations write at once under READ COMMITTED. SQLite has no
  row locks and needs none: every write transaction is `BEGIN IMMEDIATE`, one writer at a
  time, so the clause is dropped there.

The translation is made once per statement and engine (`functools.lru_cache`), and so are
the statement's result columns (`_with_columns`): a plain `text()` makes SQLAlchemy build its
result's metadata from the cursor's description at every execution (about 4 µs a column:
75 µs for the 18 columns `finish_trial` returns, on the VM of docs/performance.md), while a
`text().columns(…)`, positional, has it built once and kept with the compiled statement.
"""

from __future__ import annotations

import functools
import re
import threading
from collections.abc import Sequence

import sqlalchemy as sa

SQLITE, POSTGRESQL = "sqlite", "postgresql"

_QUOTED_OR_MARK = re.compile(r"'(?:[^']|'')*'|\?")
_JSON = re.compile(r"json_(value|text)\(\s*([\w.]+)\s*,\s*'(\w+)'\s*\)")
_ROW_LOCK = re.compile(r"\s+FOR (?:NO KEY )?UPDATE\b")


def execute(conn: sa.Connection, statement: str, params: Sequence = ()) -> sa.CursorResult:
    """Run one registry statement (`?` placeholders, the helpers above) with its values."""
    key = (statement, conn.dialect.name)
    known = _with_columns.get(key)
    values = {f"p{i}": value for i, value in enumerate(params)}
    if known is not None:
        return conn.execute(known, values)
    clause = _compiled(*key)
    result = conn.execute(clause, values)
    description = result.cursor.description if result.returns_rows else None
    if description and "*" not in statement:  # a `*`'s columns may change with the schema
        known = clause.columns(*(sa.column(d[0]) for d in description))
        with _keeping:  # a registry may be used from several threads
            if len(_with_columns) >= _KEPT:  # statements made of values (`IN (?, ?, …)`)
                del _with_columns[next(iter(_with_columns))]  # the oldest
            _with_columns[key] = known
    return result


_keeping = threading.Lock()
_KEPT = 512
_with_columns: dict[tuple[str, str], sa.TextualSelect] = {}
"""The last `_KEPT` statements that returned rows, each with its result's columns as its
first execution's cursor named them, in their order (positional: the names only label the
row's members; a statement's columns are fixed by its text)."""


@functools.lru_cache(maxsize=512)
def _compiled(statement: str, dialect: str) -> sa.TextClause:
    return sa.text(translated(statement, dialect))


def translated(statement: str, dialect: str) -> str:
    """`statement` as the engine `dialect` reads it, with `:p0`, `:p1`, … for its `?`."""
    if dialect == SQLITE:
        statement = _JSON.sub(r"json_extract(\2, '$.\3')", statement)
        statement = _ROW_LOCK.sub("", statement)
    elif dialect == POSTGRESQL:
        statement = _JSON.sub(
            lambda m: f"({m[2]}::jsonb {'->' if m[1] == 'value' else '->>'} '{m[3]}')",
            statement)
    else:
        raise ValueError(f"the registry runs on SQLite and PostgreSQL, not {dialect}")
    counter = iter(range(10_000))
    # a `?` inside a quoted literal is text, not a placeholder; a literal's ':' is escaped
    # so that text() does not take it for a bind
    return _QUOTED_OR_MARK.sub(
        lambda m: f":p{next(counter)}" if m[0] == "?" else m[0].replace(":", r"\:"),
        statement)
