"""Why the registry refuses NUL characters in text on both engines
(app.records.registry.values.checked_text; tests/app/records/test_registry_values.py): the
server cannot store them."""

from __future__ import annotations

import psycopg
import pytest


def test_postgresql_cannot_store_a_nul(postgres_server):
    """Why the check exists: the server refuses NUL in text outright."""
    with psycopg.connect(postgres_server.url(database="postgres").replace("+psycopg", "")) \
            as conn, pytest.raises(psycopg.DataError, match="NUL"):
        conn.execute("SELECT %s::text", ("a\0b",))
