"""The registry on both of its engines (issue 32): the tests' throwaway PostgreSQL server,
and `open_registry`, a registry on SQLite (the data folder's file) and on PostgreSQL (a
database of its own on that server, logged in as a station's clinic login), so that the
registry's suite runs on both, never skipping.

The server (tests/postgres.py) is one per test process, started at the first test that
needs it and stopped at the run's end. When it cannot start, a test that needs it fails
with one line saying why. Which way it was started (initdb, or the package's cluster) is
printed at the end of the run (tests/conftest.py)."""

from __future__ import annotations

import secrets
from pathlib import Path

import pytest
import sqlalchemy as sa

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.postgres import Roles, create_registry
from tests.postgres import Server, ServerError, start

PATH_PROPERTY = "postgres_server"
ENGINES = ("sqlite", "postgresql")


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


class ServerRegistries:
    """Registries on the server for the tests: one database made as a department's owner
    makes it (`create_registry`, the clinic and research roles), copied for each test
    (`CREATE DATABASE … TEMPLATE`, a file copy: a registry in a few tens of ms), and a
    station's login of the clinic role."""

    def __init__(self, server: Server) -> None:
        self.server = server
        self.template = server.create_database("registry_template")
        tag = secrets.token_hex(3)
        self.roles = Roles(clinic=f"clinic_{tag}", research=f"research_{tag}")
        engine = sa.create_engine(server.url(database=self.template), poolclass=sa.NullPool)
        try:
            with engine.begin() as conn:
                create_registry(conn, self.roles)
        finally:
            engine.dispose()
        server.forget_role(self.roles.clinic)
        server.forget_role(self.roles.research)
        self.station = server.create_login("station", self.roles.clinic)

    def new(self) -> sa.URL:
        """A new registry database; the URL a station uses to reach it."""
        name = self.server.create_database("registry", template=self.template)
        # the copy's data is the template's; who may connect to a database is not copied
        self.server.admin_sql(f'REVOKE ALL ON DATABASE "{name}" FROM PUBLIC',
                              f'GRANT CONNECT ON DATABASE "{name}" TO {self.roles.clinic}, '
                              f"{self.roles.research}")
        return sa.make_url(self.server.url(*self.station, database=name))


@pytest.fixture(scope="session")
def server_registries(postgres_server) -> ServerRegistries:
    return ServerRegistries(postgres_server)


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
