"""Registry files as an older console left them, for the tests of each migration."""

from __future__ import annotations

import contextlib
import sqlite3
from collections.abc import Iterator
from pathlib import Path

from app.records.registry import MIGRATIONS, seals


@contextlib.contextmanager
def registry_at(folder: Path, version: int) -> Iterator[sqlite3.Connection]:
    """A registry file in `folder` as the console of schema `version` made it (its DDL
    replayed as each version shipped, with the seal function registered for the versions
    that seal), open for the test to fill, each statement committed as it runs; closed at
    the end."""
    folder.mkdir(parents=True, exist_ok=True)
    with contextlib.closing(seals.register(sqlite3.connect(folder / "registry.sqlite3",
                                                           isolation_level=None))) as conn:
        for step, statements in MIGRATIONS:
            if step > version:
                break
            for statement in statements:
                conn.execute(statement)
        conn.execute(f"PRAGMA user_version = {version}")
        yield conn
