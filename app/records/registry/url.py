"""Where the registry is: its URL, read from a file private to its user (issue 32).

A console records in the SQLite registry of its data folder (`sqlite:///…/registry.sqlite3`,
the default: nothing changes for a single console). A department's stations share one
PostgreSQL registry instead (`postgresql://user:password@host:port/database`). The URL may
hold the login's password, so it is never read from the settings file (which holds no
secret and may be readable by others) but from `registry.url` in the config folder
(app.records.settings.config_dir: `REHAB_CONFIG_DIR` when set), on one line (blank lines
and lines starting with `#` aside).

The file is trusted only when no one else could have read or replaced it, checked as the
installation's signing key is (app.records.signing): a plain file, not a symbolic link
(opened with O_NOFOLLOW: a link could be turned to another file, or name one others can
read; the settings file, which holds no secret, is instead followed through its link:
app.records.settings.linked_file), owned by this user,
readable and writable by no one else (`chmod 600`), in a folder of this user's alone
(device.safewrite.folder_problem). Anything else is refused in one line saying what is
wrong and what to do; the console never falls back to another registry then, since a
station that silently recorded in its own file would split a patient's records.

The password is never shown: every message and `rehab db status` print the URL with it
masked (`***`).
"""

from __future__ import annotations

import errno
import os
import stat
from dataclasses import dataclass
from pathlib import Path

import sqlalchemy as sa
from sqlalchemy.exc import ArgumentError

from app.errors import RegistryURLError
from app.records.datadir import OFFLINE, DataDir
from app.records.settings import ENV_CONFIG_DIR, config_dir
from device.safewrite import folder_problem, os_reason, shown, user_name

URL_NAME = "registry.url"
MAX_URL_BYTES = 4096
"""A URL is a line; a file of more than a few kilobytes is not a URL file."""

SQLITE, POSTGRESQL = "sqlite", "postgresql"
DRIVERS = {SQLITE: "pysqlite", POSTGRESQL: "psycopg"}
"""The one driver of each engine this console talks to (psycopg 3 for PostgreSQL)."""

ALIASES = {"postgres": POSTGRESQL}
"""`postgres://` is libpq's other spelling of `postgresql://` (psql and most tools take
both), so a URL copied from them reads as the same server."""

EXAMPLES = ("sqlite:////absolute/path/registry.sqlite3 or "
            "postgresql://user:password@host:port/database")


@dataclass(frozen=True)
class RegistryURL:
    """The registry's URL (with its password: never print it, print `shown`) and where it
    came from (the URL file, or the data folder's default)."""

    url: sa.URL
    source: str

    @property
    def engine(self) -> str:
        return self.url.get_backend_name()

    @property
    def path(self) -> Path:
        """The SQLite registry's file (SQLite only)."""
        return Path(self.url.database or "")

    @property
    def shown(self) -> str:
        """The URL with its password masked, as its file gives it (`shown_url`)."""
        return shown_url(self.url)

    @property
    def server(self) -> str:
        """`host:port` of a PostgreSQL server (its default port when the URL gives none)."""
        return f"{self.url.host}:{self.url.port or 5432}"


def shown_url(url: sa.URL) -> str:
    """The URL as messages show it: its password masked and without the driver the console
    adds (`postgresql://…` as the URL file says it, not `postgresql+psycopg://…`)."""
    return url.set(drivername=url.get_backend_name()).render_as_string(hide_password=True)


def server_place(url: sa.URL) -> str:
    """`host:port/database` of a PostgreSQL registry, as messages and the window's title
    name it (never the login or its password)."""
    return f"{url.host}:{url.port or 5432}/{url.database}"


def url_file() -> Path:
    """The registry URL file: `registry.url` in the config folder."""
    return config_dir() / URL_NAME


def registry_url(data_dir: DataDir, path: str | os.PathLike | None = None) -> RegistryURL:
    """The registry's URL: the one in the URL file `path` (url_file() by default) when it
    is there, else the SQLite registry of `data_dir`. RegistryURLError in one line when the
    file is there but not private to this user, or holds no URL this console can use."""
    path = Path(path) if path is not None else url_file()
    text = read_private_line(path)
    if text is None and (data_dir.root / OFFLINE).is_dir() \
            and not data_dir.registry_path.exists():
        # a station's folder (its standby) with its URL file out of reach (another HOME,
        # sudo, a wrong REHAB_CONFIG_DIR): it said "the registry … is missing, but … holds
        # trial files: restore the registry from a backup", which the station never had
        raise RegistryURLError(
            f"the data folder {data_dir.root} is a station's on a shared registry (it has "
            f"an {OFFLINE} folder), but there is no registry URL file at {shown(path)}: run "
            "this as the station's user, set REHAB_CONFIG_DIR to the folder that holds its "
            "registry.url, or put that file there (mode 600; README, Several stations)")
    if text is None:
        default = sa.URL.create(f"{SQLITE}+{DRIVERS[SQLITE]}",
                                database=str(data_dir.registry_path))
        return RegistryURL(default, f"the data folder given by the {data_dir.source}; no "
                                    f"registry URL file at {shown(path)}")
    return RegistryURL(parse_url(text, path), f"the URL file {shown(path)}")


def read_private_line(path: Path) -> str | None:
    """The one line of the private file `path`, None when there is no such file."""
    def refused(problem: str, advice: str) -> RegistryURLError:
        return RegistryURLError(f"the registry URL file {shown(path)} {problem}: {advice}")

    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0) | \
        getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        return None
    except OSError as exc:
        if exc.errno == errno.ELOOP and os.path.islink(path):
            raise refused("is a symbolic link", "whoever owns it could turn it to another "
                          f"file; put the URL in a plain file there and run `chmod 600 "
                          f"{shown(path)}`") from None
        raise refused(f"cannot be read ({os_reason(exc)})",
                      f"it must be a file of yours; run `chmod 600 {shown(path)}` as its "
                      "owner, or remove it to use the data folder's registry") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise refused("is not a plain file", "put the registry URL on one line in a "
                          "plain file")
        if os.name == "posix" and info.st_uid != os.geteuid():
            raise refused(f"belongs to {user_name(info.st_uid)}, not to "
                          f"{user_name(os.geteuid())}",
                          "the console reads a URL (and its password) only from a file of "
                          "the user who runs it; copy it into a file of yours and run "
                          "`chmod 600` on it")
        if os.name == "posix" and info.st_mode & 0o077:
            raise refused(f"can be read or written by others (mode "
                          f"{stat.S_IMODE(info.st_mode):o})",
                          f"run `chmod 600 {shown(path)}`; if others may have read a "
                          "password in it, change that password on the server")
        problem = folder_problem(path.parent)
        if problem:
            raise refused(f"lies in {shown(path.parent)}, which {problem}",
                          "whoever can write there could replace the file; run `chmod 700 "
                          f"{shown(path.parent)}` or set {ENV_CONFIG_DIR} to a private "
                          "folder")
        data = os.read(fd, MAX_URL_BYTES + 1)
    except OSError as exc:
        raise refused(f"cannot be read ({os_reason(exc)})", "check the file and its disk"
                      ) from None
    finally:
        os.close(fd)
    if len(data) > MAX_URL_BYTES:
        raise refused(f"is more than {MAX_URL_BYTES} bytes", f"it holds one URL, e.g. "
                      f"{EXAMPLES}")
    try:
        lines = [line.strip() for line in data.decode("utf-8").splitlines()]
    except UnicodeDecodeError:
        raise refused("is not UTF-8 text", f"write the URL on one line, e.g. {EXAMPLES}"
                      ) from None
    lines = [line for line in lines if line and not line.startswith("#")]
    if len(lines) != 1:
        raise refused(f"holds {len(lines)} lines of text, not one URL",
                      f"write the URL alone on one line, e.g. {EXAMPLES}")
    return lines[0]


def parse_url(text: str, where: Path) -> sa.URL:
    """The registry URL `text` (from the file `where`) made SQLAlchemy's, with this
    console's driver; RegistryURLError naming what is wrong. Its own words never
    repeat the text, which may hold a password."""
    def refused(problem: str) -> RegistryURLError:
        return RegistryURLError(f"the registry URL in {shown(where)} {problem}")

    try:
        url = sa.make_url(text)
    except (ArgumentError, ValueError):
        raise refused(f"is not a URL that can be read: write it as {EXAMPLES} (a port is a "
                      "number; a password with @, : or / is written %40, %3A, %2F)") from None
    # The scheme is read from the text alone: SQLAlchemy's get_driver_name() would load
    # the dialect the scheme names, and one it has not (`postgres`, `http`) raised there.
    scheme, _, driver = url.drivername.partition("+")
    engine = ALIASES.get(scheme, scheme)
    if engine not in DRIVERS:
        raise refused(f"has the scheme {scheme!r}, which this console does not know: give "
                      f"{EXAMPLES}")
    if driver and driver != DRIVERS[engine]:
        raise refused(f"asks for the driver {driver!r}: this console talks to {engine} "
                      f"with {DRIVERS[engine]}; write {engine}://…")
    url = url.set(drivername=f"{engine}+{DRIVERS[engine]}")
    if engine == SQLITE:
        name = url.database or ""
        if not name or name == ":memory:" or name.startswith("file:"):
            raise refused("names no file: write sqlite:////absolute/path/registry.sqlite3")
        if not os.path.isabs(name):
            raise refused(f"names the relative path {shown(name)!r}: give an absolute one, "
                          "sqlite:////absolute/path/registry.sqlite3 (four slashes)")
        if url.host or url.query:
            raise refused("has a host or options, which a SQLite file has not: write "
                          "sqlite:////absolute/path/registry.sqlite3")
        return url
    if not url.host:
        raise refused("names no server: write postgresql://user:password@host:port/database")
    if not url.database:
        raise refused(f"names no database on {url.host}: write "
                      "postgresql://user:password@host:port/database")
    if url.port is not None and not 1 <= url.port <= 65535:
        raise refused(f"has the port {url.port}: give one from 1 to 65535 (PostgreSQL's "
                      "is 5432)")
    return url


def login_refusal(reason: str, url: sa.URL, source: str) -> str | None:
    """What to do when the server answered but would not let this login in, from its
    reason (libpq's words: a refused connection has no SQLSTATE to read); None for any
    other failure (no answer, a network down), which the caller names as unreachable.
    `source` says where the URL came from (the URL file). Never the password."""
    server, user, database = f"{url.host}:{url.port or 5432}", url.username, url.database
    if "password authentication failed" in reason:
        # the server says the same of a login it has not (it never tells which)
        return (f"the registry's server {server} refused the login {user} with its password "
                f"({reason}): correct the user or password in {source}, or have the "
                f"registry's owner set it (ALTER ROLE {user} PASSWORD '…', or CREATE ROLE "
                f"{user} LOGIN PASSWORD '…' IN ROLE rehab_clinic)")
    if f'role "{user}" does not exist' in reason:
        return (f"the registry's server {server} has no login {user} ({reason}): correct "
                f"the user in {source}, or have the registry's owner create it (CREATE ROLE "
                f"{user} LOGIN PASSWORD '…' IN ROLE rehab_clinic)")
    if f'database "{database}" does not exist' in reason:
        return (f"the registry's server {server} has no database {database} ({reason}): "
                f"correct the database in {source}, or create it (createdb --owner "
                f"rehab_owner {database})")
    if "permission denied for database" in reason:
        return (f"the login {user} may not connect to the database {database} on "
                f"{server} ({reason}): the registry's owner makes it a station's or a "
                f"researcher's (GRANT rehab_clinic TO {user}, or rehab_research)")
    if "no pg_hba.conf entry" in reason:
        return (f"the registry's server {server} does not let this computer log in as "
                f"{user} ({reason}): its administrator allows this computer's network in "
                "pg_hba.conf (e.g. hostssl rehab all 10.1.2.0/24 scram-sha-256) and reloads "
                "the server")
    return None
