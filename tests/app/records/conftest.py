"""The registry on both of its engines (issue 32): `open_registry`, a registry on SQLite (the
data folder's file) and on PostgreSQL (a database of its own on the tests' server, logged in
as a station's clinic login), so that the registry's suite runs on both, never skipping.
The server and its registries are tests/conftest.py's `postgres_server` and
`server_registries` (tests/registries.py)."""

from __future__ import annotations

from pathlib import Path

import pytest
import sqlalchemy as sa

from app.records.datadir import DataDir
from app.records.registry import Registry

ENGINES = ("sqlite", "postgresql")


@pytest.fixture(params=ENGINES)
def registry_engine(request) -> str:
    """Each engine the registry runs on, in turn."""
    return request.param


@pytest.fixture
def open_registry(request, registry_engine, tmp_path):
    """`open_registry(data_dir=None, **options) -> Registry`: the test's registry on the
    engine of this run. SQLite: the data folder's file (`tmp_path/data` by default).
    PostgreSQL: the test's database on the server (the same one each time the test opens
    it again), the data folder keeping the trial files."""
    url: list[sa.URL] = []

    def opened(data_dir: DataDir | Path | None = None, **options) -> Registry:
        data_dir = data_dir if data_dir is not None else DataDir(tmp_path / "data")
        if registry_engine == "sqlite":
            return Registry(data_dir, **options)
        if not url:
            url.append(request.getfixturevalue("server_registries").new())
        return Registry(data_dir, server=url[0], **options)

    return opened
