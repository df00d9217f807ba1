"""A station on the department's shared registry that never stops a session because the
network is down (issue 32; docs/stations.md, Offline stations).

`StationRegistry` is the window's `RecordStore` on a PostgreSQL registry. Online, every call
goes to the server, and after each one that records something the patients this station
works with are mirrored into its standby registry (`mirror`). When the server cannot be
reached (`RegistryUnreachable`), the call, and every one after it, is answered by the
standby: the trial goes on and the next ones are recorded, numbered as the server would
number them, their files in the data folder as always; `offline_reason` says so for the
window. Between trials (`try_sync`, which the window calls every few seconds while offline)
it reaches the server again and sends what it recorded (`sync`), then is online again.

One console per data folder works offline: the standby is the data folder's, and a second
console on the same folder (which would rebuild it under the first) reads and writes the
server only (`held` is False; the window says so).

The standby's part (holding, building, refreshing and keeping it current) is standby.py's;
sending the offline records is sync.py's, their renumbering renumber.py's and a file's
second name secondname.py's.
"""

from __future__ import annotations

import functools
import logging
import threading
from collections.abc import Callable
from typing import Any

import sqlalchemy as sa

from app.errors import PatientNotFound, RegistryError, RegistryLoginRefused, RegistryUnreachable
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.patients import is_code
from app.records.registry.url import server_place, shown_url
from app.records.station import secondname
from app.records.station.mirror import changes, keep_sent, manifest, standby_path, standby_rows
from app.records.station.standby import Standby
from app.records.station.sync import Synced, SyncRefused, already_sent, replay
from app.records.station.waiting import clear_refusal, keep_refusal
from core.errors import capitalised

log = logging.getLogger(__name__)

WRITES = frozenset((
    "add_note", "begin_plan_run", "begin_trial", "change_block", "correct_patient",
    "create_patient", "end_plan_run", "finish_trial", "interrupt_runs", "mark_trial",
    "open_session", "record_plan_rest", "record_plan_trial", "record_proposal",
    "record_reanalysis", "record_rewritten", "record_stored", "record_scale", "save_plan",
    "update_metrics", "update_patient", "update_session", "withdraw_trial"))
"""The calls that record something: after each, online, the standby is mirrored again."""

UNREACHABLE, LOGIN_REFUSED, SYNC_REFUSED = "unreachable", "login refused", "sync refused"
"""`StationRegistry.offline_cause`: why the station records on its own."""

MIRRORED_PATIENTS = 8
"""The patients a standby holds: the last this station opened or recorded for (a
station's session is one patient at a time; a day's few fit)."""

__all__ = ["LOGIN_REFUSED", "MIRRORED_PATIENTS", "SYNC_REFUSED", "UNREACHABLE", "StationRegistry",
           "SyncRefused", "Synced"]


class StationRegistry(Standby):
    """The shared registry at `server` as one station uses it (the module's doc)."""

    def __init__(self, data_dir: DataDir, server: sa.URL, *, station: str,
                 connect: Callable[..., Registry] | None = None) -> None:
        if connect is None:  # the window's: a network that drops traffic is seen in seconds
            connect = functools.partial(Registry, bounded=True)
        self.data_dir = data_dir
        self.station = station
        self.offline_reason = ""
        """Why this station records on its own ('' while it reaches the server)."""
        self.sync_problem = ""
        """Why the last attempt to send the offline records was refused ('' when none)."""
        self.offline_cause = ""
        """Why it records on its own as the latest attempt found (UNREACHABLE, LOGIN_REFUSED,
        SYNC_REFUSED; '' online): the status bar's words."""
        self.synced: list[Synced] = []
        """What each sync sent, in order (the window refreshes what it shows after one)."""
        self._url = server
        self._connect = connect
        self._recent: list[str] = []  # patient codes mirrored, the latest last
        self._open: set[int] = set()  # trials begun and not yet finished or withdrawn
        self._patient_of: dict[int, str] = {}  # the patient of each trial begun here
        self._runs: set[int] = set()  # plan runs begun and not yet ended
        # One call at a time: the window's thread and its job thread (a trial finished, a
        # sync) share this object, and a sync must not come between two calls' ids.
        self._one = threading.RLock()
        self._server: Registry | None = None
        self._standby: Registry | None = None
        self._built: tuple | None = None  # the standby as this object built it
        self.close: Callable[[], None] = lambda: None
        """Let another console hold the standby (the window calls it as it closes)."""
        self.held = self._hold()
        if self.held:
            self._set_aside_if_damaged()
        try:
            self._server = connect(data_dir, server=server, station=station)
        except RegistryUnreachable as exc:
            if not self.held:
                raise
            self._go_offline(exc)
            return
        if not self.held or self._server.research:
            return  # a second console on this folder, or a researcher: the server only
        if self._pending():
            self.offline_reason = "records made while the shared registry was unreachable " \
                                  "are waiting to be sent"
            self.offline_cause = UNREACHABLE
            self.try_sync()
        else:
            self._mirror()

    # -- what the window reads -----------------------------------------------------------
    @property
    def offline(self) -> bool:
        return bool(self.offline_reason)

    @property
    def research(self) -> bool:
        return self._server is not None and self._server.research

    def location(self) -> str:
        if self._server is not None:
            return self._server.location()
        return f"station {self.station} · shared registry {server_place(self._url)}"

    @property
    def where(self) -> str:
        return shown_url(self._url)

    # -- every other call ----------------------------------------------------------------
    def __getattr__(self, name: str) -> Any:
        if name.startswith("_") or not callable(getattr(Registry, name, None)):
            raise AttributeError(name)

        def call(*args, **kwargs):
            return self._call(name, args, kwargs)
        call.__name__ = name
        call.__doc__ = getattr(Registry, name).__doc__
        return call

    def _call(self, name: str, args: tuple, kwargs: dict) -> Any:
        with self._one:
            return self._answer(name, args, kwargs)

    def _answer(self, name: str, args: tuple, kwargs: dict) -> Any:
        if not self.offline:
            try:
                result = getattr(self._server, name)(*args, **kwargs)
            except RegistryUnreachable as exc:
                if not self.held:
                    raise
                self._go_offline(exc)
            else:
                self._after(name, args, kwargs, result)
                return result
        try:
            result = getattr(self._standby_registry(), name)(*args, **kwargs)
        except PatientNotFound as exc:
            raise PatientNotFound(
                f"{exc}: while the shared registry cannot be reached this station has only "
                "the patients it opened since it last reached it (and any registered "
                "here meanwhile)") from None
        self._track(name, args, kwargs, result)
        return result

    def _after(self, name: str, args: tuple, kwargs: dict, result: Any) -> None:
        """Online: keep the standby a mirror of the patients this station works with."""
        if not self.held or self.research:
            return
        switched = self._track(name, args, kwargs, result)
        if switched or name in WRITES:
            # the patient the station works with now, brought up to date when named anew
            # (another station may have recorded for them since), and the patient a write
            # by a trial's id was for (a trial finished on the job thread after the
            # therapist opened the next patient)
            only = self._recent[-1:]
            written = self._written_patient(name, args, kwargs, result) \
                if name in WRITES else None
            if written is not None and written not in only and written in self._recent:
                only = [written, *only]
            self._mirror(only=only)

    def _written_patient(self, name: str, args: tuple, kwargs: dict,
                         result: Any) -> str | None:
        """The patient a write by a trial's id was for, when this station knows it."""
        code = getattr(result, "patient_code", None)
        if isinstance(code, str):
            return code
        trial_id = args[0] if args else kwargs.get("trial_id")
        return self._patient_of.get(trial_id) if isinstance(trial_id, int) else None

    def _track(self, name: str, args: tuple, kwargs: dict, result: Any) -> bool:
        """Note the patient a call names (the latest first to mirror) and the trials open;
        whether the patient is now the station's current one and was not before (new to
        the standby, or named again after another)."""
        if name == "begin_trial":
            self._open.add(result.trial_id)
            self._patient_of[result.trial_id] = result.patient_code
        elif name in ("finish_trial", "withdraw_trial"):
            self._open.discard(args[0] if args else kwargs.get("trial_id"))
        elif name == "begin_plan_run":
            self._runs.add(result)
        elif name == "end_plan_run":
            self._runs.discard(args[0] if args else kwargs.get("run_id"))
        code = getattr(result, "code", None) if name == "create_patient" else \
            (args[0] if args else kwargs.get("code"))
        if not (isinstance(code, str) and is_code(code)):
            return False
        switched = self._recent[-1:] != [code]
        self._recent = [*(c for c in self._recent if c != code), code][-MIRRORED_PATIENTS:]
        return switched

    # -- offline and back ----------------------------------------------------------------
    def _shown(self) -> str:
        return f"the shared registry {server_place(self._url)}"

    def _go_offline(self, exc: RegistryUnreachable) -> None:
        self._not_reached(exc)
        log.warning("the shared registry cannot be reached; this station records on its "
                    "own until it returns: %s", exc)

    def _not_reached(self, exc: RegistryUnreachable) -> None:
        """Why the server was not reached this time (`exc`): `offline_reason`, `offline_cause`."""
        if isinstance(exc, RegistryLoginRefused):  # not the network: say what to do
            self.offline_reason = (f"{self._shown()} refused this station's login: this "
                                   "station records on its own and sends its records once "
                                   f"it is let in. {capitalised(str(exc))}")
            self.offline_cause = LOGIN_REFUSED
        else:
            self.offline_reason = (f"{self._shown()} cannot be reached: this station records "
                                   "on its own and sends its records when it returns")
            self.offline_cause = UNREACHABLE

    def try_sync(self) -> Synced | None:
        """Offline and between trials: reach the server, send what this station recorded
        meanwhile, and be online again. What was sent (None while still offline; an empty
        Synced when nothing was waiting). A refusal stays in `sync_problem`, the records
        stay where they are and the station goes on recording on its own. Never while a
        trial or a plan run is open (their ids would change under them)."""
        with self._one:
            if not self._may_sync():
                return None
            server = self._server
        # The server reached without holding the other calls: offline they are answered by
        # the standby and never touch the server, and the window's own (a trial's numbers
        # read after it ends) waited behind this one's bounded wait on a silent network
        # (app.records.registry.postgres.deadline), the window frozen meanwhile.
        try:
            if server is None:
                server = self._connect(self.data_dir, server=self._url, station=self.station)
            else:
                server.schema_version()  # reached: nothing to send proves nothing
        except RegistryUnreachable as exc:
            with self._one:
                self._not_reached(exc)
            return None
        except RegistryError as exc:
            return self._sync_refused(exc)
        with self._one:
            self._server = server
            return self._try_sync()

    def _may_sync(self) -> bool:
        return self.offline and not self._open and not self._runs and self.held

    def _try_sync(self) -> Synced | None:
        if not self._may_sync():
            return None  # a trial or a plan run begun while the server was reached
        try:
            synced = self._sync()
        except RegistryUnreachable as exc:
            self._not_reached(exc)
            return None
        except RegistryError as exc:
            return self._sync_refused(exc)
        self.offline_reason = self.sync_problem = self.offline_cause = ""
        clear_refusal(self.data_dir)
        self.synced.append(synced)
        self._mirror()
        return synced

    def _sync_refused(self, exc: RegistryError) -> None:
        """The sync refused (`exc`): kept in `sync_problem`, logged once; nothing lost."""
        problem = (f"the records this station made offline were not sent: {exc}. Nothing "
                   f"is lost: they stay in {standby_path(self.data_dir)} and this station "
                   "goes on recording on its own until the registry's owner resolves it "
                   "(docs/stations.md, Offline stations)")
        if self.sync_problem != problem:
            log.error("%s", problem)
            try:
                keep_refusal(self.data_dir, problem)  # for `rehab db status`
            except OSError as exc:  # the station goes on: only the status line lacks it
                log.warning("the sync's refusal was not kept for rehab db status: %s", exc)
        self.sync_problem = problem
        self.offline_cause = SYNC_REFUSED

    def _sync(self) -> Synced:
        path = standby_path(self.data_dir)
        if not path.exists():
            return Synced({}, {}, {})
        standby = self._standby_registry()
        with standby._read() as conn:  # its seals checked: a damaged standby is not sent
            raw = conn.connection.driver_connection
            work = changes(standby_rows(raw), manifest(raw))
        if not work:
            return Synced({}, {}, {})
        with self._server._write() as conn:
            if already_sent(conn, work):
                synced = Synced({}, {}, {})
                log.warning("the offline records had arrived at the last attempt")
            else:
                synced = replay(conn, work, self._shown(), self.station)
                # before the commit: a trial registered under a second name is found by it
                # once the server has it
                secondname.make(self.data_dir, synced.second_names)
        for moved in synced.renumbered:  # kept in the registry too (sync.py, renumber.py)
            log.warning("sent under the server's next free number: %s", moved.line)
        kept = keep_sent(path)
        self._standby = self._built = None
        log.info("sent the offline records to the shared registry: %s added, %s changed; "
                 "the standby kept as %s", synced.added, synced.changed, kept.name)
        return synced
