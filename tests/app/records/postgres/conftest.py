"""A registry database of today's schema on the tests' PostgreSQL server, with a login of
each role, for the tests of the server's own side (tables, seals, numbering, roles). The
server itself is tests/app/records/conftest.py's `postgres_server`."""

from __future__ import annotations

import pytest
import sqlalchemy as sa

from app.records.registry.postgres import Roles, create_registry
from tests.postgres import Server


class Registry:
    """A registry database of today's schema on the server, with a login of each role."""

    def __init__(self, server: Server) -> None:
        self.server = server
        self.database = server.create_database()
        tag = self.database.rsplit("_", 1)[-1]
        self.roles = Roles(clinic=f"clinic_{tag}", research=f"research_{tag}")
        with self.engine() as engine, engine.begin() as conn:
            create_registry(conn, self.roles)
        server.forget_role(self.roles.clinic)
        server.forget_role(self.roles.research)
        self.clinic_login = server.create_login("clinic_login", self.roles.clinic)
        self.research_login = server.create_login("research_login", self.roles.research)

    def url(self, login: tuple[str, str] | None = None) -> str:
        """The database's URL as `login` (name, password), the owner by default."""
        return self.server.url(*(login or (None, None)), database=self.database)

    def engine(self, login: tuple[str, str] | None = None) -> _Engine:
        return _Engine(self.url(login))


class _Engine:
    """An engine without a pool, disposed of at the end of a `with`."""

    def __init__(self, url: str) -> None:
        self.engine = sa.create_engine(url, poolclass=sa.NullPool)

    def __enter__(self) -> sa.Engine:
        return self.engine

    def __exit__(self, *_) -> None:
        self.engine.dispose()


@pytest.fixture(scope="module")
def registry(postgres_server) -> Registry:
    """A new registry database for the module's tests."""
    return Registry(postgres_server)


@pytest.fixture
def station(tmp_path, monkeypatch):
    """A station's config folder (REHAB_CONFIG_DIR) and data folder of the test's own;
    `point(url)` writes the private URL file."""
    config = tmp_path / "config"
    config.mkdir(mode=0o700)
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(config))
    monkeypatch.setenv("REHAB_DATA_DIR", str(tmp_path / "data"))

    def point(url: str):
        path = config / "registry.url"
        path.write_text(url + "\n")
        path.chmod(0o600)
        return path
    return point
