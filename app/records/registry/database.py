"""The registry's SQLite file: a connection per call, the two kinds of transaction, SQLite's
errors as the registry's own (saying what to do), and the whole-file copy and checks.

Every connection lives for one call and is closed by a context manager, so a
`Database` holds no connection and may be used from several threads. A read that
cannot open its connection for want of room on the disk (WAL mode makes every reader
map, and maybe create, the `-shm` and `-wal` files) reads the registry's committed state
from an in-memory copy instead (`snapshot`), so a full disk still lets everything be
read; writes then fail, saying the disk is full. Each
connection has foreign keys on, a busy timeout and `synchronous=FULL` (a
registered trial survives a power cut). Every write is a `BEGIN IMMEDIATE`
transaction: the console that reads the next number is the one that inserts it.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import sqlite3
import weakref
from collections.abc import Iterator
from pathlib import Path

import sqlalchemy as sa

from app.errors import RegistryError, RegistryLoginRefused, RegistryUnreachable, SchemaError
from app.records.registry import seals
from app.records.registry.snapshot import needs_snapshot, snapshot_connection
from app.records.registry.url import login_refusal, server_place, shown_url

log = logging.getLogger(__package__)

BUSY_TIMEOUT_S = 10.0
CONNECT_TIMEOUT_S = 10
"""How long a station waits for the registry's server to answer a connection: long enough
for a busy network, short enough that a station says the server is away within seconds."""


class Database:
    """Connections to the registry: the SQLite file at `path`, or the PostgreSQL server of
    `server` (set by the registry that opens it; `path` is then None). `station`: the
    station this console is, which its trials and plan runs record
    (app.records.registry.provenance)."""

    path: Path | None
    server: sa.URL | None = None
    station: str | None = None
    research: bool = False
    """A researcher's login on the server (its research role): the registry reads through
    the views of the schema `research` (codes and data; names and typed text empty, by the
    server) and changes nothing."""
    bounded: bool = False
    """A station's window on the server: each wait for an answer bounded
    (app.records.registry.postgres.deadline), so a network that drops traffic is seen as
    unreachable within seconds, not when TCP gives up."""

    @property
    def where(self) -> str:
        """The registry as messages name it: its file, or its server's URL without the
        password."""
        if self.server is not None:
            return shown_url(self.server)
        return str(self.path)

    @property
    def on_server(self) -> bool:
        return self.server is not None

    def location(self) -> str:
        """Where this console records, as the window's title says it: '' for the data
        folder's own registry; on a department's server, this station and the server's
        host, port and database (never the login or its password)."""
        if self.server is None:
            return ""
        url = self.server
        who = "research login (codes and data)" if self.research else \
            f"station {self.station or '(unnamed)'}"
        return f"{who} · shared registry {server_place(url)}"

    # -- the engines ---------------------------------------------------------------------
    @functools.cached_property
    def _writer(self) -> sa.Engine:
        """SQLAlchemy's engine for writes: a new file connection per call (`_open`), or
        the server's small pool, whose connections the driver leaves in autocommit: the
        registry sends each transaction's BEGIN itself (`_on_server`)."""
        if self.server is not None:
            options = {"connect_timeout": CONNECT_TIMEOUT_S}
            if self.research:  # the registry's tables are research's views, by name
                options["options"] = "-c search_path=research,public"
            engine = sa.create_engine(self.server, pool_size=2, max_overflow=6,
                                      isolation_level="AUTOCOMMIT", connect_args=options)
            if not self.research:  # a station's connection, ready for its first Start
                from app.records.registry.postgres import deadline, warm
                sa.event.listen(engine, "connect", warm.on_connect)
                if self.bounded:
                    sa.event.listen(engine, "do_connect", deadline.on_do_connect)
            # the pool's connections are closed, not dropped, when the registry goes
            weakref.finalize(self, engine.dispose)
            return engine
        return _sqlite_engine(self._open)

    @functools.cached_property
    def _reader_engine(self) -> sa.Engine:
        if self.server is not None:
            return self._writer
        return _sqlite_engine(self._reader)

    def _open(self) -> sqlite3.Connection:
        """A connection to the registry file, as every write has it (the driver's own
        transactions off: the registry begins its own, BEGIN IMMEDIATE)."""
        conn = seals.register(sqlite3.connect(self.path, timeout=BUSY_TIMEOUT_S,
                                              isolation_level=None))
        try:
            conn.execute("PRAGMA foreign_keys = ON")
            conn.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
            conn.execute("PRAGMA synchronous = FULL")
        except BaseException:
            conn.close()
            raise
        return conn

    @contextlib.contextmanager
    def _connection(self) -> Iterator[sqlite3.Connection]:
        """The file's own connection, for what only SQLite has (its schema's migration,
        its backup, its integrity check); SQLite's errors as the registry's."""
        try:
            conn = self._open()
        except sqlite3.Error as exc:
            raise self._database_error(exc) from exc
        except UnicodeDecodeError as exc:  # a damaged schema's text, read at the PRAGMAs
            raise self._damaged(exc) from exc
        try:
            yield conn
        except (sqlite3.Error, UnicodeDecodeError) as exc:
            raise self._sqlite_error(exc) from exc
        finally:
            conn.close()

    @contextlib.contextmanager
    def _statements(self, engine: sa.Engine) -> Iterator[sa.Connection]:
        """A SQLAlchemy connection of `engine` whose drivers' errors become the registry's
        (the driver's own error stays the cause, as the schema's migration expects): also
        SQLite's own, raised by what the registry sends on the file's connection itself
        (BEGIN IMMEDIATE, the integrity check of a damaged file)."""
        try:
            with engine.connect() as conn:
                yield conn
        except sa.exc.DBAPIError as exc:
            raise self._driver_error(exc) from (exc.orig or exc)
        except (sqlite3.Error, UnicodeDecodeError) as exc:
            raise self._sqlite_error(exc) from exc

    # -- transactions --------------------------------------------------------------------
    @contextlib.contextmanager
    def _on_server(self, engine: sa.Engine, begin: str) -> Iterator[sa.Connection]:
        """A transaction on the server, begun by the registry's own `begin` statement: the
        connection's first round trip, which is also its check. A connection of the pool
        that the server or the network ended meanwhile (a restart, a drop) fails it before
        anything of the transaction was sent; SQLAlchemy then takes it, and the pool's other
        connections, out of service, and the transaction begins again, once, on a new
        connection. So a station reconnects by itself after an outage, as the pool's ping
        before every transaction (`pool_pre_ping`) let it, without that ping's round trip
        and CPU (three a trial's registration: docs/performance.md). Where the BEGIN fails
        on a new connection too, or the connection cannot be made, the server is
        unreachable (`RegistryUnreachable`). The transaction ends with the connection: its
        ROLLBACK, unless the caller sent COMMIT (or the driver's commit)."""
        for attempt in (1, 2):
            with self._statements(engine) as conn:
                try:
                    conn.exec_driver_sql(begin)
                except sa.exc.DBAPIError as exc:
                    if attempt == 1 and exc.connection_invalidated:
                        continue  # the connection was gone before anything was sent
                    raise
                yield conn
                return

    @contextlib.contextmanager
    def _write(self) -> Iterator[sa.Connection]:
        """One write transaction. On SQLite it is taken at once: BEGIN IMMEDIATE makes the
        read of a next number and its insert atomic across processes. On the server it is
        READ COMMITTED; what reads then writes locks its rows (statements.py)."""
        if self.server is not None:
            if self.research:
                raise RegistryError(
                    f"this login on {self.where} is a researcher's: it reads codes and data, "
                    "never names, and changes nothing; nothing was changed. A clinic login "
                    "records")
            with self._on_server(self._writer, "BEGIN") as conn:
                yield conn
                conn.commit()
            return
        with self._statements(self._writer) as conn:
            raw = conn.connection.driver_connection
            raw.execute("BEGIN IMMEDIATE")
            try:
                sound = self._verified(raw)  # nothing is written into a damaged registry
                yield conn
            except BaseException:
                rollback(raw)
                raise
            raw.execute("COMMIT")
        # What this transaction wrote its triggers sealed, and no one else could write
        # between the check and the commit (BEGIN IMMEDIATE held the lock): the file as it
        # is now, after the checkpoint the connection's close may have made, needs no check.
        self._still_sound(sound)

    @contextlib.contextmanager
    def _read(self) -> Iterator[sa.Connection]:
        """A read transaction: several SELECTs see one snapshot (on the server, REPEATABLE
        READ)."""
        if self.server is not None:
            with self._on_server(self._reader_engine,
                                 "BEGIN ISOLATION LEVEL REPEATABLE READ") as conn:
                yield conn
                conn.rollback()  # nothing to keep
            return
        sound = False
        with self._statements(self._reader_engine) as conn:
            raw = conn.connection.driver_connection
            raw.execute("BEGIN")
            try:
                sound = self._verified(raw)
                yield conn
            finally:
                rollback(raw)  # nothing to keep: ends the snapshot
        # a read changes nothing but what its close may checkpoint from the WAL
        self._still_sound(sound)

    def _still_sound(self, sound: bool) -> None:
        if sound:
            self._verified_state = file_state(self.path)

    def _verified(self, conn: sqlite3.Connection) -> bool:
        """Every row checked against its seal (seals.verify), once for each state of the
        file: its size and modification time, and its WAL's, as last checked by this
        object. False for a registry before v6 (being opened to migrate: no seals yet).
        A change another program makes to the file in the moment between a transaction's
        check and its connection's close is seen at the next change of the file."""
        version = conn.execute("PRAGMA user_version").fetchone()[0]
        if version < SEALED_FROM:
            return False
        state = file_state(self.path)
        if state is None or state != getattr(self, "_verified_state", None):
            seals.verify(conn, self.path)
            self._verified_state = state
        return True

    def _damaged(self, exc: Exception) -> SchemaError:
        return SchemaError(
            f"the registry {self.where} is damaged: a stored text is not readable "
            f"({' '.join(str(exc).split())}). Restore the registry from a backup (a "
            "registry.sqlite3.v*.bak beside it, or your own copy)")

    def _reader(self) -> sqlite3.Connection:
        """A connection for reading: the file's, or on a disk without room for what a WAL
        reader writes, the committed state in memory (`snapshot`)."""
        try:
            conn = seals.register(sqlite3.connect(self.path, timeout=BUSY_TIMEOUT_S,
                                                  isolation_level=None))
        except sqlite3.Error as exc:
            return self._snapshot(exc)
        try:
            conn.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
            conn.execute("PRAGMA user_version").fetchone()  # maps the WAL's index
        except sqlite3.Error as exc:
            conn.close()
            return self._snapshot(exc)
        return conn

    def _snapshot(self, exc: sqlite3.Error) -> sqlite3.Connection:
        if not needs_snapshot(exc):
            raise exc
        try:
            conn = seals.register(snapshot_connection(self.path))
        except (OSError, sqlite3.Error):
            raise exc from None
        log.info("registry %s read from a copy in memory: %s (the disk is full?)",
                 self.path, exc)
        return conn

    def _driver_error(self, exc: sa.exc.DBAPIError) -> RegistryError:
        """What SQLAlchemy raised for the driver, as the registry's error."""
        orig = exc.orig
        if isinstance(orig, sqlite3.Error):
            return self._sqlite_error(orig)
        return self._server_error(exc)

    def _sqlite_error(self, exc: sqlite3.Error | UnicodeDecodeError) -> RegistryError:
        """SQLite's own error as the registry's: a refused change (a constraint), a
        damaged stored text SQLite handed back undecodable, or the file's trouble."""
        if isinstance(exc, sqlite3.IntegrityError):
            return _refused(exc)
        if isinstance(exc, UnicodeDecodeError):
            return self._damaged(exc)
        return self._database_error(exc)

    def _server_error(self, exc: sa.exc.DBAPIError) -> RegistryError:
        reason = first_line(exc)
        state = getattr(exc.orig, "sqlstate", None) or ""
        if isinstance(exc, sa.exc.IntegrityError) or state.startswith("23"):
            return RegistryError(f"the registry refused a change ({reason}); nothing was "
                                 "saved. Reload and try again")
        if state == "53100":  # disk_full
            return RegistryError(f"the registry's server {self.where} cannot write: its disk "
                                 f"is full ({reason}); nothing was saved. Ask its "
                                 "administrator to free space, then try again")
        if state == "42501":  # insufficient_privilege
            return RegistryError(f"this station's login may not do that on the registry's "
                                 f"server {self.where} ({reason}); nothing was changed. Ask "
                                 "its administrator for the clinic role")
        if isinstance(exc, sa.exc.OperationalError) or exc.connection_invalidated:
            refused = login_refusal(reason, self.server, "the registry URL (registry.url "
                                    "in the config folder)")
            if refused:  # the server answered: a station records on its own meanwhile
                return RegistryLoginRefused(f"{refused}; nothing was saved")
            return RegistryUnreachable(
                f"cannot reach the registry's server {self.where} ({reason}): check that "
                "the server runs and that this station's network reaches it; nothing was "
                "saved")
        return RegistryError(f"the registry's server {self.where} refused ({reason}); "
                             "nothing was saved")

    def _database_error(self, exc: sqlite3.Error) -> RegistryError:
        text = " ".join(str(exc).split())  # SQLite may quote a damaged schema's lines
        if "locked" in text or "busy" in text:
            return RegistryError(
                f"the registry {self.path} is busy: another console is writing to it "
                f"(waited up to {BUSY_TIMEOUT_S:g} s). Try again; if it persists, close the "
                "other console"
            )
        if isinstance(exc, sqlite3.DatabaseError) and "not a database" in text:
            return SchemaError(
                f"{self.path} is not a registry database ({text}). Move it aside and "
                "restore the registry from a backup"
            )
        if needs_snapshot(exc):
            return RegistryError(
                f"the registry {self.path} cannot be written: {text}; the disk holding it is "
                "probably full. Free space on it, then try again; nothing was saved"
            )
        return RegistryError(
            f"the registry {self.path} cannot be used: {text}. Check the disk and its free "
            "space; restore from a backup if the file is damaged"
        )

    # -- the whole file --------------------------------------------------------------
    def _file_only(self, what: str, instead: str) -> None:
        if self.server is not None:
            raise RegistryError(f"{what} is made of a registry file; this console's registry "
                                f"is on the server {self.where}: use {instead}")

    def backup(self, target: str | Path) -> Path:
        """A consistent copy of the registry (SQLite's online backup), safe while
        other consoles write: for a researcher's export or before a risky change. Written
        as every file named by someone is (app.records.safewrite): a new file only (SQLite
        would copy into a database found there, replacing it), never among what a data
        folder keeps but below its exports/ and reports/, whole or not at all, 0600 from
        the start (a copy of the patients' records: its user's only)."""
        from app.records.safewrite import OutputRefused, atomic_path

        self._file_only("a copy of the registry", "pg_dump, by the server's administrator")
        with self._connection() as conn:
            try:
                with atomic_path(target, roots=(self.path.parent,)) as temporary, \
                        contextlib.closing(sqlite3.connect(temporary)) as copy:
                    conn.backup(copy)
            except OutputRefused as exc:
                raise RegistryError(f"cannot write a copy of the registry: {exc}") from None
            except (OSError, sqlite3.Error) as exc:
                raise RegistryError(
                    f"cannot write a copy of the registry to {target}: {exc}. Choose a "
                    "writable folder with free space"
                ) from exc
        return Path(os.path.abspath(target))

    def integrity_check(self) -> list[str]:
        """SQLite's integrity and foreign-key checks: an empty list when sound. On the
        server (which guards its own pages and keys) every row against its seal."""
        if self.server is not None:
            from app.records.registry.postgres import seals as server_seals

            if self.research:
                raise RegistryError(f"the seals of {self.where} are not checked on a "
                                    "researcher's login, which cannot read them: ask the "
                                    "clinic (`rehab db status`)")
            with self._read() as conn:
                try:
                    server_seals.verify(conn, self.where)
                except SchemaError as exc:
                    return [str(exc)]
            return []
        with self._connection() as conn:
            problems = [r[0] for r in conn.execute("PRAGMA integrity_check") if r[0] != "ok"]
            problems += [f"{table} row {rowid} points to a missing {parent}"
                         for table, rowid, parent, _ in conn.execute("PRAGMA foreign_key_check")]
        return problems


SEALED_FROM = 6
"""The schema version from which every row has its seal (schema.MIGRATE_V5_TO_V6)."""


def file_state(path: Path) -> tuple | None:
    """What changes when the registry's file or its WAL is written: their sizes and
    modification times (None when they cannot be read: then every call checks)."""
    try:
        main = os.stat(path)
    except OSError:
        return None
    try:
        wal = os.stat(f"{path}-wal")
    except OSError:
        wal = None
    # every connection makes an empty WAL when there is none: only one with frames counts
    wal_state = (wal.st_size, wal.st_mtime_ns) if wal is not None and wal.st_size else None
    return (main.st_size, main.st_mtime_ns, main.st_ino, wal_state)


def rollback(conn: sqlite3.Connection) -> None:
    """End the connection's transaction, if SQLite has not already."""
    # SQLite rolls back by itself after some errors (disk full); a second
    # ROLLBACK would then raise and hide the first error.
    if conn.in_transaction:
        conn.execute("ROLLBACK")


def _sqlite_engine(connect) -> sa.Engine:
    """SQLAlchemy over connections `connect` makes: none kept (a connection per call, so a
    registry may be used from several threads and holds no file open). No reset when one
    is given back: the registry has ended its transaction itself (COMMIT, or ROLLBACK), and
    the connection is closed; the pool's own rollback there doubled each call's cost (a
    patient read: 1.0 ms before SQLAlchemy, 2.1 ms with the reset, 1.1 ms without)."""
    return sa.create_engine("sqlite+pysqlite://", creator=connect, poolclass=sa.NullPool,
                            pool_reset_on_return=None)


def _refused(exc: sqlite3.IntegrityError) -> RegistryError:
    return RegistryError(
        f"the registry refused a change ({exc}); nothing was saved. Reload and try again")


def first_line(exc: sa.exc.DBAPIError) -> str:
    """The driver's first line, without SQLAlchemy's statement and links."""
    text = str(exc.orig) if exc.orig is not None else str(exc)
    first = next((line for line in text.splitlines() if line.strip()), type(exc).__name__)
    return " ".join(first.split())
