"""Registries on the tests' PostgreSQL server (tests/postgres.py) for the tests that run the
registry on both engines (tests/app/records/conftest.py) and the window on a department's
shared registry (tests/ui/test_window_shared_registry.py). The fixtures are in
tests/conftest.py: `postgres_server` (one per test process) and `server_registries`."""

from __future__ import annotations

import secrets

import sqlalchemy as sa

from app.records.registry.postgres import Roles, create_registry
from tests.postgres import Server


class ServerRegistries:
    """Registries on the server for the tests: one database made as a department's owner
    makes it (`create_registry`, the clinic and research roles), copied for each test
    (`CREATE DATABASE … TEMPLATE`, a file copy: a registry in a few tens of ms), a
    station's login of the clinic role and a researcher's of the research role."""

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
        self.researcher = server.create_login("researcher", self.roles.research)

    def new(self) -> sa.URL:
        """A new registry database; the URL a station uses to reach it."""
        name = self.server.create_database("registry", template=self.template)
        # the copy's data is the template's; who may connect to a database is not copied
        self.server.admin_sql(f'REVOKE ALL ON DATABASE "{name}" FROM PUBLIC',
                              f'GRANT CONNECT ON DATABASE "{name}" TO {self.roles.clinic}, '
                              f"{self.roles.research}")
        return sa.make_url(self.server.url(*self.station, database=name))

    def as_researcher(self, url: sa.URL) -> sa.URL:
        """The URL of the same registry with the researcher's login."""
        name, password = self.researcher
        return url.set(username=name, password=password)
