"""This station's standby registry as the station keeps it (docs/stations.md, Offline
stations): held for the console's life (one console per data folder works offline), built
whole from the server's rows of the patients this station works with or brought up to date
in place (refresh.py), never built over records it holds that the server does not, set
aside when damaged, and kept current between trials (`keep_current`). `StationRegistry`
(the package) answers the calls and goes offline and back; this is its standby's part.
"""

from __future__ import annotations

import contextlib
import datetime
import fcntl
import logging
import os
import sqlite3
import threading
import weakref
from collections.abc import Callable
from pathlib import Path

from app.errors import RegistryError, RegistryUnreachable
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.database import file_state
from app.records.station.mirror import (
    OFFLINE,
    StandbyDataDir,
    build_standby,
    changes,
    manifest,
    patient_rows,
    stamp,
    standby_path,
    standby_rows,
)
from app.records.station.refresh import (
    mirrored_seals,
    refresh_patient,
    server_changes,
    write_changes,
)
from app.records.station.waiting import clear_refusal
from device.safewrite import OutputRefused, make_private_folders

# the station's logger, as before the standby had a module of its own
log = logging.getLogger(__package__)


class Standby:
    """The standby's part of a StationRegistry (the module's doc): the station sets these
    attributes, and says whether it is `offline`, the server's URL as shown (`where`) and
    how it goes offline (`_go_offline`)."""

    data_dir: DataDir
    held: bool
    sync_problem: str
    close: Callable[[], None]
    _one: threading.RLock
    _server: Registry | None
    _standby: Registry | None
    _built: tuple | None
    _recent: list[str]

    def _standby_registry(self) -> Registry:
        if self._standby is None:
            if not standby_path(self.data_dir).exists():
                self._build(None)  # never reached the server: new patients only
            self._standby = Registry(StandbyDataDir(self.data_dir.root, self.data_dir.source),
                                     station=self.station)
        return self._standby

    def _set_aside_if_damaged(self) -> None:
        """A standby that fails its checks (its structure, a row against its seal) is moved
        aside as `damaged-<UTC>.sqlite3`, never read nor sent nor built over: what it holds
        is kept for the registry's owner, and the station starts from the server (or, cut
        off, from an empty standby)."""
        path = standby_path(self.data_dir)
        if not path.exists():
            return
        try:
            self._pending()
        except RegistryError as exc:
            kept = path.with_name(f"damaged-{stamp()}.sqlite3")
            for suffix in ("", "-wal", "-shm"):
                with contextlib.suppress(FileNotFoundError):
                    os.rename(f"{path}{suffix}", f"{kept}{suffix}")
            self._standby = None
            clear_refusal(self.data_dir)  # it was about the standby set aside
            self.sync_problem = (f"this station's standby registry was damaged ({exc}); it is "
                                 f"kept as {kept} for the registry's owner, and records made "
                                 "offline that it held were not sent")
            log.error("%s", self.sync_problem)

    def _pending(self) -> bool:
        """Whether the standby holds records the server does not have."""
        if not standby_path(self.data_dir).exists():
            return False
        with self._standby_registry()._read() as conn:
            raw = conn.connection.driver_connection
            return bool(changes(standby_rows(raw), manifest(raw)))

    def _mirror(self, only: list[str] | None = None) -> None:
        """The standby made the server's rows of the recent patients (never over records it
        holds that the server does not): `only` these patients brought up to date in place
        when the standby is as this object last left it (refresh.py), else built whole. A
        failure is logged: the session goes on online, and an unreachable server makes the
        station go offline."""
        path = standby_path(self.data_dir)
        try:
            if only is not None and self._built is not None \
                    and not self._changed_since_built(path):
                with self._server._read() as conn:
                    for code in only:
                        refresh_patient(path, conn, code)
                self._built = file_state(path)
                return
        except RegistryUnreachable as exc:
            self._go_offline(exc)
            return
        except (RegistryError, sqlite3.Error, OSError) as exc:
            log.warning("this station's standby registry is built whole again (%s)", exc)
        try:
            with self._server._read() as conn:
                rows = patient_rows(conn, self._recent)
        except RegistryUnreachable as exc:
            self._go_offline(exc)
            return
        except RegistryError as exc:
            log.error("this station's standby registry was not updated: %s", exc)
            return
        self._build(rows)

    def _build(self, rows: dict | None) -> None:
        path = standby_path(self.data_dir)
        if path.exists() and self._changed_since_built(path) and self._pending():
            log.error("the standby registry %s holds records the server does not have: it "
                      "was not rebuilt", path)
            return
        try:
            build_standby(self.data_dir, rows or {}, self.where,
                          datetime.datetime.now(datetime.UTC).isoformat())
        except (OSError, RegistryError) as exc:
            log.error("this station's standby registry could not be written: %s", exc)
            return
        self._standby = None
        self._built = file_state(path)

    def _changed_since_built(self, path: Path) -> bool:
        return self._built is None or file_state(path) != self._built

    def _hold(self) -> bool:
        """Hold this data folder's standby for this console's life (an advisory lock)."""
        folder = self.data_dir.root / OFFLINE
        try:
            make_private_folders(folder)
            lock = open(folder / "station.lock", "a")  # noqa: SIM115  held while alive
            self.close = weakref.finalize(self, lock.close)
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except (OSError, OutputRefused) as exc:
            self.close()
            log.warning("another console holds this data folder's standby registry (or it "
                        "cannot be made: %s): this one records on the server only", exc)
            return False
        return True

    def keep_current(self) -> None:
        """Online: bring the standby's copy of the patient this station works with now up to
        the server's (what other stations recorded for them meanwhile), so that a trial
        recorded here after the network drops is numbered after theirs. The window calls it
        now and then between trials (ui/window/station.py); one round trip when nothing
        changed. Offline, on a second console or a researcher's login: nothing.

        The server is asked without holding the other calls (as `try_sync` reaches it): on
        a silent network its answer waits out the bounded wait
        (app.records.registry.postgres.deadline), and a call of the window's meanwhile
        waited behind it. So is it for the rare whole build (the standby not as this object
        left it). The standby is written under the lock, and only when nothing changed it
        since it was read (a write mirrored meanwhile brought it current); a write that
        fails leaves it to be built whole next time."""
        path = standby_path(self.data_dir)
        with self._one:
            if self.offline or not self.held or self._server is None \
                    or self._server.research or not self._recent:
                return
            server, code, built = self._server, self._recent[-1], self._built
            recent, state = list(self._recent), file_state(path)
            # the standby not as last left (rare: a failure, another program): built whole
            # from the server's rows, read off the lock as the changes are (it held every
            # call behind its bounded wait on a silent network)
            whole = built is None or self._changed_since_built(path)
            if not whole:
                try:
                    ours = mirrored_seals(path, code)
                except sqlite3.Error as exc:
                    log.warning("this station's standby registry is built whole again (%s)",
                                exc)
                    whole = True
        try:
            with server._read() as conn:
                found = (patient_rows(conn, recent) if whole
                         else server_changes(conn, code, ours))
        except RegistryUnreachable as exc:
            with self._one:
                if not self.offline and self._server is server:
                    self._go_offline(exc)
            return
        except RegistryError as exc:
            log.warning("this station's standby registry was not brought up to date: %s", exc)
            return
        with self._one:
            if found is None or self.offline or self._server is not server \
                    or self._built is not built or file_state(path) != state:
                return  # the next call (or a write's mirror meanwhile) keeps it current
            if whole:
                if self._recent == recent:
                    self._build(found)
                return
            try:
                write_changes(path, found)
            except (RegistryError, sqlite3.Error, OSError) as exc:
                # built whole at the next keep_current (or write), off the lock
                log.warning("this station's standby registry is built whole again (%s)", exc)
                self._built = None
                return
            self._built = file_state(path)
