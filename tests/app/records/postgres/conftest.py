"""The throwaway PostgreSQL server of the shared registry's tests (tests/postgres.py): one
per test process, started at the first test that needs it and stopped at the run's end.

A test that needs it never skips: when it cannot start, the test fails with one line saying
why. Which way it was started (initdb, or the package's cluster) is printed at the end of
the run (tests/conftest.py)."""

from __future__ import annotations

import pytest

from tests.postgres import ServerError, start

PATH_PROPERTY = "postgres_server"


@pytest.fixture(scope="session")
def postgres_server():
    try:
        server = start()
    except ServerError as exc:
        pytest.fail(f"the tests' PostgreSQL server did not start: {exc}", pytrace=False)
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
