"""The throwaway PostgreSQL server of the shared registry's tests (tests/postgres.py): one
per test process, started at the first test that needs it and stopped at the run's end.

A test that needs it never skips: when it cannot start, the test fails with one line saying
why. Which way it was started (initdb, or the package's cluster) is printed at the end of
the run (tests/conftest.py)."""

from __future__ import annotations

import pytest
import sqlalchemy as sa

from app.records.registry.postgres import Roles, create_registry
from tests.postgres import Server, ServerError, start

PATH_PROPERTY = "postgres_server"


@pytest.fixture(scope="session")
def postgres_server():
    try:
        server, problem = start(), None
    except ServerError as exc:
        server, problem = None, str(exc)
    if server is None:  # failed outside the except: one line, no chained traceback
        pytest.fail(f"the tests' PostgreSQL server did not start: {problem}", pytrace=False)
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture(autouse=True)
def _say_which_server(request):
    """The server's path in the report of every test that used it (tests/conftest.py
    prints it once at the end, from any pytest-xdist worker)."""
    if "postgres_server" in request.fixturenames:
        server = request.getfixturevalue("postgres_server")
        request.node.user_properties.append((PATH_PROPERTY, server.path))


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
