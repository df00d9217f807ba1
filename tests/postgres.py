"""A throwaway PostgreSQL server for the tests of the shared registry (issue 32), started by
the test run itself: nothing to set up by hand, and a test that needs it never skips.

Why a server of its own: the registry's PostgreSQL side (app.records.registry.postgres) is
proven only against a real server (its seals are computed by triggers, its roles and its
numbering are enforced by the server), and a test must not touch a department's database.

How (`start`):

* Debian's `postgresql` is installed when `initdb`/`pg_ctl` are missing
  (`scripts/postgres-server install`, which `scripts/setup-venv dev` runs too).
* **initdb** (the usual path): a temporary folder owned by the unprivileged `postgres`
  user when the run is root (`runuser -u postgres --`; the run's own user otherwise),
  `initdb` into it with a password superuser, and `pg_ctl start` on a free port, listening
  on 127.0.0.1 only (`-c listen_addresses=127.0.0.1`, its Unix socket in that folder).
  `stop` stops it and removes the folder.
* **package cluster** (the fallback): in some sandboxes `/dev/null` is a plain file and
  `initdb` run as `postgres` fails; the package's own cluster (`pg_ctlcluster 15 main
  start`) still works there. The run then starts that cluster (127.0.0.1 only, on its
  configured port, refused when another program holds it) unless it is running already,
  adds a password superuser of its own for the run, and at its end drops what it made and
  stops the cluster if it started it and no other test process (a pytest-xdist worker)
  still uses it.

`Server.path` says which path was taken; the run's summary prints it. Every failure is one
`ServerError` line saying why (the fixture fails the test with it). Each test module makes
databases of its own (`Server.create_database`), dropped at the end.

`python -m tests.postgres run` (what `scripts/postgres-server run` does) starts one by hand
and prints its address until Ctrl-C.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import pwd
import re
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SERVER_USER = "postgres"
"""The unprivileged user a root run starts the server as (Debian's package creates it)."""
HOST = "127.0.0.1"
START_WAIT_S = 600
"""How long `pg_ctl -w` may wait for the server to accept connections: only a hang reaches
it (a shared 2-core CI host can stall a process for 20 s and more)."""
CLUSTER_LOCK = Path(tempfile.gettempdir()) / "rehab-tests-postgres-cluster.lock"
CLUSTER_USERS = Path(tempfile.gettempdir()) / "rehab-tests-postgres-cluster.json"


class ServerError(RuntimeError):
    """The throwaway server could not be started: one line saying why."""


@dataclass
class Server:
    """A running throwaway server: its port on 127.0.0.1, its superuser's name and password
    (connections over TCP with a password), which `path` started it, and how to stop it."""

    port: int
    admin: str
    password: str
    path: str
    _stop: list = field(default_factory=list, repr=False)
    _databases: list[str] = field(default_factory=list, repr=False)
    _roles: list[str] = field(default_factory=list, repr=False)

    def url(self, user: str | None = None, password: str | None = None,
            database: str = "postgres") -> str:
        """A SQLAlchemy URL (psycopg 3) to `database` as `user` (the superuser by default)."""
        from sqlalchemy import URL

        return URL.create("postgresql+psycopg", username=user or self.admin,
                          password=password if user else self.password, host=HOST,
                          port=self.port, database=database).render_as_string(
                              hide_password=False)

    def admin_sql(self, *statements: str, database: str = "postgres") -> None:
        """Run statements as the superuser, each in its own transaction (autocommit)."""
        import psycopg

        with psycopg.connect(host=HOST, port=self.port, user=self.admin,
                             password=self.password, dbname=database,
                             autocommit=True) as conn:
            for statement in statements:
                conn.execute(statement)

    def create_database(self, prefix: str = "registry", template: str = "template0") -> str:
        """A new database (UTF-8, owned by the superuser), dropped at `stop`: empty, or a
        copy of the database `template` (which nobody may be connected to meanwhile)."""
        name = f"{prefix}_{os.getpid()}_{secrets.token_hex(4)}"
        self.admin_sql(f'CREATE DATABASE "{name}" TEMPLATE "{template}" ENCODING \'UTF8\' '
                       "LC_COLLATE 'C' LC_CTYPE 'C'")
        self._databases.append(name)
        return name

    def create_login(self, prefix: str, *member_of: str) -> tuple[str, str]:
        """A new login role with a password, member of `member_of`; dropped at `stop`.
        Returns its name and password."""
        name = f"{prefix}_{os.getpid()}_{secrets.token_hex(3)}"
        password = secrets.token_urlsafe(16)
        groups = f" IN ROLE {', '.join(member_of)}" if member_of else ""
        self.admin_sql(f"CREATE ROLE {name} LOGIN PASSWORD '{password}'{groups}")
        self._roles.append(name)
        return name, password

    def forget_role(self, name: str) -> None:
        """Drop `name` too at `stop` (a group role a test made)."""
        self._roles.append(name)

    def stop(self) -> None:
        """Drop what the run made, then stop the server (and remove its folder)."""
        with contextlib.suppress(Exception):
            self.admin_sql(*(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'
                             for name in reversed(self._databases)),
                           *(f"DROP ROLE IF EXISTS {name}" for name in reversed(self._roles)))
        self._databases.clear()
        self._roles.clear()
        while self._stop:
            with contextlib.suppress(Exception):
                self._stop.pop()()


# -- finding and installing the server's programs -------------------------------------------


def binaries() -> Path | None:
    """The folder holding `initdb` and `pg_ctl`: on the PATH, else the newest
    /usr/lib/postgresql/<version>/bin (Debian keeps them off the PATH)."""
    initdb, pg_ctl = shutil.which("initdb"), shutil.which("pg_ctl")
    if initdb and pg_ctl and Path(initdb).resolve().parent == Path(pg_ctl).resolve().parent:
        return Path(initdb).resolve().parent
    found = sorted(Path("/usr/lib/postgresql").glob("*/bin/pg_ctl"),
                   key=lambda p: int(p.parent.parent.name) if p.parent.parent.name.isdigit()
                   else 0)
    for pg_ctl_path in reversed(found):
        if (pg_ctl_path.parent / "initdb").exists():
            return pg_ctl_path.parent
    return None


def ensure_installed() -> Path:
    """The server's programs, installing Debian's `postgresql` first when they are missing
    (scripts/postgres-server install)."""
    found = binaries()
    if found is not None:
        return found
    done = subprocess.run([str(REPO / "scripts" / "postgres-server"), "install"],
                          capture_output=True, text=True, check=False)
    found = binaries()
    if done.returncode != 0 or found is None:
        why = (done.stderr or done.stdout).strip().splitlines()
        raise ServerError("PostgreSQL's server programs (initdb, pg_ctl) are missing and "
                          f"could not be installed: {why[-1] if why else 'no reason given'}")
    return found


# -- running a command as the server's user -------------------------------------------------


def _as_server_user(command: list[str]) -> list[str]:
    if os.geteuid() != 0:
        return command
    return ["runuser", "-u", SERVER_USER, "--", *command]


def _server_user() -> pwd.struct_passwd | None:
    if os.geteuid() != 0:
        return None
    try:
        return pwd.getpwnam(SERVER_USER)
    except KeyError:
        raise ServerError(f"the tests run as root and there is no user {SERVER_USER!r} to "
                          "run PostgreSQL as (Debian's postgresql package creates it)") from None


def _run(command: list[str], what: str, **kwargs) -> subprocess.CompletedProcess:
    done = subprocess.run(command, capture_output=True, text=True, check=False, **kwargs)
    if done.returncode != 0:
        lines = [line for line in (done.stderr or done.stdout).splitlines() if line.strip()]
        raise ServerError(f"{what} failed: {lines[-1].strip() if lines else done.returncode}")
    return done


def free_port() -> int:
    """A port nothing listens on at this moment on 127.0.0.1."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind((HOST, 0))
        return probe.getsockname()[1]


def _free(port: int) -> bool:
    """Whether the server could listen on `port` of 127.0.0.1 now (it binds with
    SO_REUSEADDR, so connections of a server just stopped do not hold the port)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((HOST, port))
        except OSError:
            return False
    return True


def _tail(path: Path) -> str:
    with contextlib.suppress(OSError):
        lines = [line for line in path.read_text(errors="replace").splitlines() if line]
        if lines:
            return lines[-1].strip()
    return "no log"


# -- the initdb path -------------------------------------------------------------------------


def start_initdb(bin_dir: Path) -> Server:
    """initdb into a temporary folder owned by the server's user, then start it on a free
    port of 127.0.0.1 with its socket in that folder (ServerError when initdb fails)."""
    user = _server_user()
    folder = Path(tempfile.mkdtemp(prefix="rehab-tests-postgres-"))
    try:
        return _start_initdb(bin_dir, folder, user)
    except BaseException:
        # a Ctrl-C while `pg_ctl start` ran may leave a server running on the folder
        if (folder / "data" / "postmaster.pid").exists():
            subprocess.run(_as_server_user([str(bin_dir / "pg_ctl"), "-D", str(folder / "data"),
                                            "-m", "immediate", "-w", "stop"]),
                           capture_output=True, check=False, cwd=folder)
        shutil.rmtree(folder, ignore_errors=True)
        raise


def _start_initdb(bin_dir: Path, folder: Path, user: pwd.struct_passwd | None) -> Server:
    password = secrets.token_urlsafe(24)
    secret = folder / "password"
    secret.write_text(password + "\n")
    secret.chmod(0o600)
    folder.chmod(0o700)
    if user is not None:
        for path in (folder, secret):
            os.chown(path, user.pw_uid, user.pw_gid)
    data = folder / "data"
    admin = "rehab_admin"
    _run(_as_server_user([str(bin_dir / "initdb"), "-D", str(data), "-U", admin,
                          f"--pwfile={secret}", "--auth=scram-sha-256", "--encoding=UTF8",
                          "--locale=C", "--no-sync"]), "initdb", cwd=folder)
    secret.unlink()
    log = folder / "server.log"
    for attempt in range(3):
        port = free_port()
        offset = log.stat().st_size if log.exists() else 0
        options = (f"-p {port} -k {folder} -c listen_addresses={HOST} -c fsync=off "
                   "-c full_page_writes=off")
        done = subprocess.run(
            _as_server_user([str(bin_dir / "pg_ctl"), "-D", str(data), "-l", str(log), "-w",
                             "-t", str(START_WAIT_S), "-o", options, "start"]),
            capture_output=True, text=True, check=False, cwd=folder)
        if done.returncode == 0:
            server = Server(port, admin, password, f"initdb in {folder} (port {port})")
            server._stop.append(lambda: shutil.rmtree(folder, ignore_errors=True))
            server._stop.append(lambda: subprocess.run(
                _as_server_user([str(bin_dir / "pg_ctl"), "-D", str(data), "-m", "fast",
                                 "-w", "-t", str(START_WAIT_S), "stop"]),
                capture_output=True, check=False, cwd=folder))
            return server
        why = _start_failure(log, offset) or (done.stderr or done.stdout).strip()
        # another program took the port between its choice and the start: choose again
        if "already in use" not in why or attempt == 2:
            raise ServerError(f"the throwaway server did not start: {why}")
    raise AssertionError("unreachable")


def _start_failure(log: Path, offset: int) -> str:
    """Why a start failed, from what the server logged in this attempt: its lines that say
    so (`could not bind …: Address already in use`, then `FATAL: could not create any
    TCP/IP sockets`) without their time stamps, else its last line."""
    try:
        with open(log, "rb") as file:
            file.seek(offset)
            text = file.read().decode(errors="replace")
    except OSError:
        return ""
    lines = [re.sub(r"^.*?\[\d+\]\s+", "", line).strip() for line in text.splitlines()]
    lines = [line for line in lines if line]
    telling = [line for line in lines
               if line.startswith(("FATAL", "ERROR", "PANIC")) or "could not" in line]
    return "; ".join(telling) if telling else (lines[-1] if lines else "")


# -- the package-cluster path ----------------------------------------------------------------


@contextlib.contextmanager
def _cluster_lock():
    with open(CLUSTER_LOCK, "a+") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def _cluster_users() -> dict:
    try:
        users = json.loads(CLUSTER_USERS.read_text())
    except (OSError, ValueError):
        users = {}
    users.setdefault("users", [])
    users.setdefault("started", False)
    # each user is "<pid>:<token>": one per server object, dropped when its process died
    users["users"] = [user for user in users["users"] if _alive(int(user.split(":")[0]))]
    return users


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def package_cluster() -> tuple[str, str, int, Path]:
    """The package's first cluster: its version, name, configured port and data folder."""
    if shutil.which("pg_lsclusters") is None:
        raise ServerError("no pg_lsclusters: Debian's postgresql-common is not installed")
    lines = _run(["pg_lsclusters", "--no-header"], "pg_lsclusters").stdout.splitlines()
    if not lines:
        raise ServerError("the postgresql package has no cluster (pg_lsclusters lists none)")
    version, name, port, _status, _owner, data, *_ = lines[0].split()
    return version, name, int(port), Path(data)


def _running_port(data: Path) -> int | None:
    """The port of the cluster running on `data` (its postmaster.pid), None when stopped."""
    try:
        lines = (data / "postmaster.pid").read_text().splitlines()
        pid, port = int(lines[0]), int(lines[3])
    except (OSError, ValueError, IndexError):
        return None
    return port if _alive(pid) else None


def start_package_cluster(why: str = "") -> Server:
    """The package's cluster, started on 127.0.0.1 only (on its configured port, which must
    be free) unless it runs already, with a password superuser of this run's own."""
    if os.geteuid() != 0:
        raise ServerError("the package's cluster is started with pg_ctlcluster as root; "
                          "this run is not root")
    version, name, configured, data = package_cluster()
    with _cluster_lock():
        users = _cluster_users()
        port = _running_port(data)
        if port is None:
            # on its configured port: pg_ctlcluster waits for the server on that port
            if not _free(configured):
                raise ServerError(f"the package's cluster {version}/{name} is stopped and "
                                  f"its port {configured} is taken by another program")
            _run(["pg_ctlcluster", version, name, "start", "--", "-o",
                  f"-c listen_addresses={HOST}", "-t", str(START_WAIT_S)],
                 f"pg_ctlcluster {version} {name} start")
            users["started"] = True
            port = _running_port(data)
            if port is None:
                raise ServerError(f"pg_ctlcluster {version} {name} started no server")
        me = f"{os.getpid()}:{secrets.token_hex(4)}"
        users["users"].append(me)
        CLUSTER_USERS.write_text(json.dumps(users))
    admin = f"rehab_admin_{os.getpid()}_{secrets.token_hex(3)}"
    password = secrets.token_urlsafe(24)
    socket_dir = "/var/run/postgresql"
    with contextlib.suppress(OSError, ValueError, IndexError):
        socket_dir = (data / "postmaster.pid").read_text().splitlines()[4] or socket_dir
    _run(_as_server_user(["psql", "-X", "-q", "-v", "ON_ERROR_STOP=1", "-h", socket_dir,
                          "-p", str(port), "-d", "postgres", "-f", "-"]),
         "creating the tests' superuser in the package's cluster",
         input=f"CREATE ROLE {admin} LOGIN SUPERUSER PASSWORD '{password}';\n", cwd="/")
    server = Server(port, admin, password,
                    f"package cluster {version}/{name} (port {port}{'; ' if why else ''}{why})")

    def leave() -> None:
        with _cluster_lock():
            users = _cluster_users()
            users["users"] = [user for user in users["users"] if user != me]
            if not users["users"] and users["started"]:
                subprocess.run(["pg_ctlcluster", version, name, "stop", "-m", "fast"],
                               capture_output=True, check=False)
                users["started"] = False
            CLUSTER_USERS.write_text(json.dumps(users))

    server._stop.append(leave)
    server._stop.append(lambda: _run(
        _as_server_user(["psql", "-X", "-q", "-h", socket_dir, "-p", str(port), "-d",
                         "postgres", "-c", f"DROP ROLE IF EXISTS {admin}"]),
        "dropping the tests' superuser", cwd="/"))
    return server


# -- either --------------------------------------------------------------------------------


FORCE_ENV = "REHAB_TEST_POSTGRES"
"""`cluster` makes `start` take the package cluster's path at once (to try that path on a
machine where initdb works); unset, initdb first."""


def start() -> Server:
    """A throwaway server by initdb, or by the package's cluster when initdb fails."""
    bin_dir = ensure_installed()
    if os.environ.get(FORCE_ENV) == "cluster":
        return start_package_cluster(f"{FORCE_ENV}=cluster")
    try:
        return start_initdb(bin_dir)
    except ServerError as initdb_error:
        if os.geteuid() != 0:
            raise
        try:
            return start_package_cluster(f"initdb failed: {initdb_error}")
        except ServerError as cluster_error:
            raise ServerError(f"{initdb_error}; and the package's cluster: {cluster_error}"
                              ) from None


def main(argv: list[str]) -> int:
    if argv != ["run"]:
        print("usage: python -m tests.postgres run", file=sys.stderr)
        return 2
    # Ctrl-C and kill stop the server, also where SIGINT came ignored (a job started with
    # `&` from a script inherits SIG_IGN, and Python then never raises KeyboardInterrupt)
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _interrupted)
    try:
        server = start()
    except ServerError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 0  # stopped while starting: start() removed what it made
    try:
        print(f"PostgreSQL ({server.path}): {server.url()}", flush=True)
        print("Ctrl-C stops it and removes it.", flush=True)
        with contextlib.suppress(KeyboardInterrupt):
            while True:
                signal.pause()
    finally:
        # no second Ctrl-C half-way through the stop: it would leave the folder behind
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        server.stop()
    print("Stopped and removed.", flush=True)
    return 0


def _interrupted(signum, frame) -> None:
    raise KeyboardInterrupt


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
