"""The tests' throwaway PostgreSQL server (tests/postgres.py): on 127.0.0.1 only, reached
over TCP with a password, and gone when stopped."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys

import psycopg
import pytest

import tests.postgres
from tests.postgres import FORCE_ENV, HOST, REPO, start, start_initdb


def test_the_server_listens_on_127_0_0_1_only_and_asks_for_a_password(postgres_server):
    server = postgres_server
    with psycopg.connect(host=HOST, port=server.port, user=server.admin,
                         password=server.password, dbname="postgres") as conn:
        assert conn.execute("SHOW listen_addresses").fetchone()[0] == "127.0.0.1"
        assert conn.execute("SELECT inet_server_addr()::text").fetchone()[0] in (
            "127.0.0.1", "127.0.0.1/32")
    with pytest.raises(psycopg.OperationalError, match="password authentication failed"):
        psycopg.connect(host=HOST, port=server.port, user=server.admin,
                        password=server.password + "x", dbname="postgres").close()


def test_a_login_the_run_makes_connects_over_tcp(postgres_server):
    name, password = postgres_server.create_login("smoke")
    with psycopg.connect(host=HOST, port=postgres_server.port, user=name, password=password,
                         dbname="postgres") as conn:
        assert conn.execute("SELECT current_user").fetchone()[0] == name


def test_a_stopped_server_is_gone(postgres_server):
    """A second server, started and stopped: its port closes (and on the initdb path its
    folder goes); the package's cluster stays up while the first server still uses it."""
    server = start()
    server.stop()
    if server.path.startswith("initdb"):
        folder = server.path.split(" ")[2]
        assert not os.path.exists(folder)
        with socket.socket() as probe:
            assert probe.connect_ex((HOST, server.port)) != 0
    with psycopg.connect(host=HOST, port=postgres_server.port, user=postgres_server.admin,
                         password=postgres_server.password, dbname="postgres") as conn:
        assert conn.execute("SELECT 1").fetchone()[0] == 1


def test_a_port_taken_between_its_choice_and_the_start_is_chosen_again(postgres_server,
                                                                         monkeypatch):
    if not postgres_server.path.startswith("initdb"):
        # the package's cluster runs on its configured port: no port is chosen
        assert "initdb failed" in postgres_server.path or FORCE_ENV in postgres_server.path
        return
    with socket.socket() as taken:
        taken.bind((HOST, 0))
        taken.listen()
        held = taken.getsockname()[1]
        ports = iter([held])
        free = tests.postgres.free_port
        monkeypatch.setattr(tests.postgres, "free_port", lambda: next(ports, None) or free())
        server = start_initdb(tests.postgres.binaries())
    try:
        assert server.port != held
        with psycopg.connect(host=HOST, port=server.port, user=server.admin,
                             password=server.password, dbname="postgres") as conn:
            assert conn.execute("SELECT 1").fetchone()[0] == 1
    finally:
        server.stop()


STOP_BOUND_S = 120


def test_ctrl_c_stops_the_server_run_by_hand_and_removes_it(postgres_server):
    """`python -m tests.postgres run` (scripts/postgres-server run) ignored Ctrl-C when its
    shell had started it as a job with `&`: SIGINT came ignored, Python never raised
    KeyboardInterrupt, and the server ran on until killed. Sent SIGINT, it stops the
    server, removes its folder and exits 0, however it was started."""
    # as a background job of a script: SIGINT ignored from the start, by the shell's trap
    # (an ignored signal stays ignored across exec). Not preexec_fn: it makes subprocess
    # fork this test process, which JAX (loaded by other tests in it) warns against
    helper = subprocess.Popen(
        ["sh", "-c", 'trap "" INT; exec "$0" -m tests.postgres run', sys.executable],
        cwd=REPO, text=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        env={**os.environ, "PYTHONPATH": str(REPO)})
    try:
        lines = []
        while not lines or not lines[-1].startswith("Ctrl-C"):
            line = helper.stdout.readline()
            assert line, f"the helper ended before its server ran: {''.join(lines)}"
            lines.append(line)
        path = lines[0].split("(", 1)[1].split("):", 1)[0]
        helper.send_signal(signal.SIGINT)
        # a bound for a helper that never stops, not a timing: stopping takes a second
        rest, _ = helper.communicate(timeout=STOP_BOUND_S)
    finally:
        if helper.poll() is None:
            helper.terminate()  # SIGTERM: its server stopped before it goes
            helper.communicate(timeout=STOP_BOUND_S)
    assert helper.returncode == 0, rest
    assert "Stopped and removed." in rest
    if path.startswith("initdb"):
        folder, port = path.split(" ")[2], int(path.rsplit(" ", 1)[1].rstrip(")"))
        assert not os.path.exists(folder)
        with socket.socket() as probe:
            assert probe.connect_ex((HOST, port)) != 0
