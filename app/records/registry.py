"""The registry of patients, sessions and trials: one SQLite file in the data folder.

Registration follows the thesis's registration tab (Appendix A.2): the therapist
gives the patient's first and last name, a session number and a trial number.
Here the patient is found by name (`find_patients`; `create_patient` gives a new
one a pseudonymous code), the numbers are filled in (`suggest_registration`)
and stay editable: `begin_trial` takes the numbers the therapist confirmed,
continues or opens that session, and refuses a trial number already used,
naming the next free one; `finish_trial` records the status and metrics at
Stop. Names live only in the `patients` table and never reach the log; every
file is named by code.

Storage (the DDL is in SCHEMA_V1 and the MIGRATE_* constants):

* `PRAGMA user_version` is the schema version; `MIGRATIONS` lists the forward
  steps from 0, the first of which is the historic v1 DDL, kept as it shipped.
  Opening an older registry copies it aside (`registry.sqlite3.v1-<UTC>.bak`)
  and migrates it in one transaction; a newer one is refused.
* WAL journal (readers never block the writer), foreign keys on, a busy timeout,
  `synchronous=FULL` (a registered trial survives a power cut).
* Two consoles on one data folder: every write is a `BEGIN IMMEDIATE`
  transaction, so the one that reads the next number is the one that inserts
  it; the other waits (busy timeout) and then sees it. UNIQUE constraints on
  (patient, session number) and (session, trial number) back this up.
* Parameters and metrics are JSON text, so a new metric needs no schema change;
  the progress query (`trial_summaries`) reads one patient's trials through the
  two UNIQUE indexes in order, with no sort, has SQLite extract the few key
  parameters, and parses all the rows' metrics in one json.loads.
* Every connection lives for one call and is closed by a context manager, so a
  `Registry` holds no connection and may be used from several threads.

WAL needs a local disk: on a network share use one console per data folder.
"""

from __future__ import annotations

import contextlib
import datetime
import json
import logging
import math
import re
import secrets
import sqlite3
import unicodedata
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

from app.errors import (
    DuplicateNumberError,
    InvalidRecordError,
    PatientNotFound,
    RegistryError,
    SchemaError,
    SessionNotFound,
    TrialNotFound,
)
from app.records.datadir import CODE_ALPHABET, CODE_PATTERN, TRIALS, DataDir
from core.arm import BODY_MASS_RANGE_KG, FOREARM_RANGE_M, UPPER_ARM_RANGE_M
from core.errors import CoreError, check_range
from core.trial import POSITION_RANGE_M, SIDES, TrialParameters
from device.recording.trialfile import STATUS_RECORDING, STATUSES
from device.sim.patients import PATIENT_KINDS

log = logging.getLogger(__name__)

BUSY_TIMEOUT_S = 10.0
CODE_LENGTH = 6
NAME_MAX_CHARS = 100
TEXT_MAX_CHARS = 10_000
BIRTH_YEAR_MIN = 1900
KEY_PARAMETERS = ("shape", "radius_m", "duration_s", "tolerance_rad", "assistance_level",
                  "controller")
"""The parameters that change what a trial's metrics mean: compare trials done at
equal values of these (progress, previous_trial(same_parameters=True))."""

_METRIC_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}")
_ALL_STATUSES = (STATUS_RECORDING, *STATUSES)

# ---------------------------------------------------------------- schema
# Historic: the DDL exactly as v1 shipped. Never edit; add a migration instead.
SCHEMA_V1 = (
    """CREATE TABLE patients (
        id INTEGER PRIMARY KEY,
        code TEXT NOT NULL UNIQUE,
        first_name TEXT,
        last_name TEXT,
        birth_year INTEGER,
        side TEXT CHECK (side IS NULL OR side IN ('right', 'left')),
        body_mass_kg REAL,
        upper_arm_m REAL,
        forearm_m REAL,
        shoulder_x_m REAL,
        shoulder_y_m REAL,
        notes TEXT NOT NULL DEFAULT '',
        created_at TEXT NOT NULL
    )""",
    """CREATE TABLE sessions (
        id INTEGER PRIMARY KEY,
        patient_id INTEGER NOT NULL REFERENCES patients (id) ON DELETE RESTRICT,
        number INTEGER NOT NULL CHECK (number >= 1),
        date TEXT NOT NULL,
        therapist TEXT NOT NULL DEFAULT '',
        notes TEXT NOT NULL DEFAULT '',
        UNIQUE (patient_id, number)
    )""",
    """CREATE TABLE trials (
        id INTEGER PRIMARY KEY,
        session_id INTEGER NOT NULL REFERENCES sessions (id) ON DELETE RESTRICT,
        number INTEGER NOT NULL CHECK (number >= 1),
        parameters TEXT NOT NULL,
        file TEXT NOT NULL UNIQUE,
        metrics TEXT NOT NULL DEFAULT '{}',
        status TEXT NOT NULL CHECK (status IN
            ('recording', 'complete', 'stopped_early', 'faulted', 'recording_lost')),
        started_at TEXT NOT NULL,
        ended_at TEXT,
        patient_kind TEXT,
        UNIQUE (session_id, number)
    )""",
)

# v2: which backend ran each trial (NULL for trials registered before v2, when
# it was not kept), and where a session took place (clinic room, home visit).
MIGRATE_V1_TO_V2 = (
    "ALTER TABLE trials ADD COLUMN backend TEXT",
    "ALTER TABLE sessions ADD COLUMN location TEXT NOT NULL DEFAULT ''",
)

MIGRATIONS: tuple[tuple[int, tuple[str, ...]], ...] = (
    (1, SCHEMA_V1),
    (2, MIGRATE_V1_TO_V2),
)
SCHEMA_VERSION = MIGRATIONS[-1][0]

_PATIENT_COLUMNS = ("code", "first_name", "last_name", "birth_year", "side", "body_mass_kg",
                    "upper_arm_m", "forearm_m", "shoulder_x_m", "shoulder_y_m", "notes",
                    "created_at")
_TRIAL_SELECT = """
    SELECT t.id, p.code, s.number, s.date, t.number, t.parameters, t.file, t.metrics,
           t.status, t.started_at, t.ended_at, t.backend, t.patient_kind
    FROM trials t
    JOIN sessions s ON s.id = t.session_id
    JOIN patients p ON p.id = s.patient_id
"""
# SQLite extracts the few parameters that matter: parsing every trial's whole
# parameter object in Python was a fifth of the progress query's time.
_SUMMARY_SELECT = f"""
    SELECT t.id, s.number, s.date, t.number, t.status, t.started_at, t.file,
           {", ".join(f"json_extract(t.parameters, '$.{name}')" for name in KEY_PARAMETERS)},
           t.metrics
    FROM trials t
    JOIN sessions s ON s.id = t.session_id
    WHERE s.patient_id = ?
    ORDER BY s.number, t.number
"""
_SESSION_SELECT = """
    SELECT s.id, p.code, s.number, s.date, s.therapist, s.location, s.notes,
           (SELECT count(*) FROM trials t WHERE t.session_id = s.id)
    FROM sessions s JOIN patients p ON p.id = s.patient_id
"""


# ---------------------------------------------------------------- records
@dataclass(frozen=True, slots=True)
class Patient:
    """A patient as the clinic registered them. `code` is the only identifier
    that leaves the registry; names may be None (a study may keep none)."""

    code: str
    first_name: str | None
    last_name: str | None
    birth_year: int | None
    side: str | None
    body_mass_kg: float | None
    upper_arm_m: float | None
    forearm_m: float | None
    shoulder_m: tuple[float, float] | None
    notes: str
    created_at: datetime.datetime

    @property
    def display_name(self) -> str:
        """'Last, First' for the window; the code when no name was entered."""
        names = [n for n in (self.last_name, self.first_name) if n]
        return ", ".join(names) if names else self.code

    def trial_overrides(self) -> dict:
        """The TrialParameters fields this patient defines, for
        `TrialParameters.replace(**patient.trial_overrides())`."""
        values = {
            "side": self.side,
            "body_mass_kg": self.body_mass_kg,
            "upper_arm_m": self.upper_arm_m,
            "forearm_m": self.forearm_m,
            "shoulder_m": self.shoulder_m,
        }
        return {k: v for k, v in values.items() if v is not None}


@dataclass(frozen=True, slots=True)
class Session:
    """One sitting: `number` counts a patient's sessions; `date` is the local day."""

    id: int
    patient_code: str
    number: int
    date: datetime.date
    therapist: str
    location: str
    notes: str
    n_trials: int


@dataclass(frozen=True, slots=True)
class Trial:
    """One trial, Start to Stop. `file` is relative to the data folder, with '/';
    `parameters` is `TrialParameters.to_dict()`; `metrics` maps names to floats
    (NaN where a metric was undefined). `backend` is None for trials registered
    before schema v2."""

    id: int
    patient_code: str
    session_number: int
    session_date: datetime.date
    number: int
    parameters: dict
    file: str
    metrics: dict[str, float]
    status: str
    started_at: datetime.datetime
    ended_at: datetime.datetime | None
    backend: str | None
    patient_kind: str | None

    @property
    def finished(self) -> bool:
        return self.status != STATUS_RECORDING

    def key_parameters(self) -> tuple:
        """KEY_PARAMETERS values, comparable between trials (see parameter_key)."""
        return parameter_key(self.parameters.get(name) for name in KEY_PARAMETERS)

    def trial_parameters(self) -> TrialParameters:
        """The parameters as a validated TrialParameters (raises CoreError if they no
        longer validate, e.g. a range narrowed since the trial was run)."""
        return TrialParameters.from_dict(self.parameters)


@dataclass(frozen=True, slots=True)
class TrialSummary:
    """A trial as a list or the progress view needs it: the KEY_PARAMETERS values
    (in that order, None where absent) instead of every parameter."""

    id: int
    session_number: int
    session_date: datetime.date
    number: int
    status: str
    started_at: datetime.datetime
    file: str
    key_parameters: tuple  # as stored; parameter_key() makes them comparable
    metrics: dict[str, float]


@dataclass(frozen=True, slots=True)
class Registration:
    """The numbers the registration tab proposes; the therapist may change them."""

    patient_code: str
    session_number: int
    trial_number: int
    new_session: bool


@dataclass(frozen=True, slots=True)
class BegunTrial:
    """What `begin_trial` hands to the recorder: the id to finish later and the
    file to write (absolute; its folder exists)."""

    trial_id: int
    patient_code: str
    session_number: int
    trial_number: int
    path: Path
    file: str
    started_at: datetime.datetime


# ---------------------------------------------------------------- registry
class Registry:
    """The registry of one data folder. Opening it creates or migrates the database."""

    def __init__(self, data_dir: DataDir | str | Path) -> None:
        if not isinstance(data_dir, DataDir):
            data_dir = DataDir(Path(data_dir).expanduser().absolute())
        self.data_dir = data_dir
        self.path = data_dir.registry_path
        data_dir.ensure()
        self._migrate()

    # -- connections --------------------------------------------------------
    @contextlib.contextmanager
    def _connection(self) -> Iterator[sqlite3.Connection]:
        try:
            conn = sqlite3.connect(self.path, timeout=BUSY_TIMEOUT_S, isolation_level=None)
        except sqlite3.Error as exc:
            raise self._database_error(exc) from exc
        try:
            conn.execute("PRAGMA foreign_keys = ON")
            conn.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
            conn.execute("PRAGMA synchronous = FULL")
            yield conn
        except sqlite3.IntegrityError as exc:
            raise RegistryError(
                f"the registry refused a change ({exc}); nothing was saved. Reload and try again"
            ) from exc
        except sqlite3.Error as exc:
            raise self._database_error(exc) from exc
        finally:
            conn.close()

    @contextlib.contextmanager
    def _write(self) -> Iterator[sqlite3.Connection]:
        """One write transaction, taken at once: BEGIN IMMEDIATE makes the read of
        a next number and its insert atomic across processes."""
        with self._connection() as conn:
            conn.execute("BEGIN IMMEDIATE")
            try:
                yield conn
            except BaseException:
                _rollback(conn)
                raise
            conn.execute("COMMIT")

    @contextlib.contextmanager
    def _read(self) -> Iterator[sqlite3.Connection]:
        """A read transaction: several SELECTs see one snapshot."""
        with self._connection() as conn:
            conn.execute("BEGIN")
            try:
                yield conn
            finally:
                _rollback(conn)  # nothing to keep: ends the snapshot

    def _database_error(self, exc: sqlite3.Error) -> RegistryError:
        text = str(exc)
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
        return RegistryError(
            f"the registry {self.path} cannot be used: {text}. Check the disk and its free "
            "space; restore from a backup if the file is damaged"
        )

    # -- schema ----------------------------------------------------------------
    def schema_version(self) -> int:
        with self._connection() as conn:
            return conn.execute("PRAGMA user_version").fetchone()[0]

    def _migrate(self) -> None:
        with self._connection() as conn:
            mode = conn.execute("PRAGMA journal_mode = WAL").fetchone()[0]
            if mode.lower() != "wal":
                log.warning("registry %s: journal mode is %s, not WAL (a network disk?); "
                            "use one console at a time on this data folder", self.path, mode)
            version = conn.execute("PRAGMA user_version").fetchone()[0]
            if version > SCHEMA_VERSION:
                raise self._too_new(version)
            if version == SCHEMA_VERSION:
                return
            if version > 0:
                self._back_up(conn, version)
            conn.execute("BEGIN IMMEDIATE")
            try:
                # Another console may have migrated while this one waited for the lock.
                version = conn.execute("PRAGMA user_version").fetchone()[0]
                if version > SCHEMA_VERSION:
                    raise self._too_new(version)
                for target, statements in MIGRATIONS:
                    if target <= version:
                        continue
                    try:
                        for statement in statements:
                            conn.execute(statement)
                    except sqlite3.Error as exc:
                        raise SchemaError(
                            f"the registry {self.path} could not be updated to schema "
                            f"v{target} ({exc}); nothing was changed, it is still v{version}. "
                            "Keep the file and report this with it"
                        ) from exc
                    conn.execute(f"PRAGMA user_version = {target}")
                    log.info("registry %s: schema migrated from v%d to v%d",
                             self.path, target - 1, target)
                problems = conn.execute("PRAGMA foreign_key_check").fetchall()
                if problems:
                    raise SchemaError(
                        f"registry {self.path}: {len(problems)} record(s) point to missing "
                        "patients or sessions; the migration was not applied. Restore the "
                        "registry from a backup"
                    )
            except BaseException:
                _rollback(conn)
                raise
            conn.execute("COMMIT")

    def _too_new(self, version: int) -> SchemaError:
        return SchemaError(
            f"the registry {self.path} has schema v{version}, written by a newer console; "
            f"this one reads up to v{SCHEMA_VERSION}. Update the console"
        )

    def _back_up(self, conn: sqlite3.Connection, version: int) -> None:
        stamp = datetime.datetime.now(datetime.UTC).strftime("%Y%m%dT%H%M%SZ")
        target = self.path.with_name(f"{self.path.name}.v{version}-{stamp}.bak")
        if target.exists():
            return
        with contextlib.closing(sqlite3.connect(target)) as copy:
            conn.backup(copy)
        log.info("registry %s: copy of schema v%d kept as %s before migrating",
                 self.path, version, target.name)

    # -- patients --------------------------------------------------------------
    def create_patient(
        self,
        first_name: str | None = None,
        last_name: str | None = None,
        *,
        birth_year: int | None = None,
        side: str | None = None,
        body_mass_kg: float | None = None,
        upper_arm_m: float | None = None,
        forearm_m: float | None = None,
        shoulder_m: tuple[float, float] | None = None,
        notes: str = "",
    ) -> Patient:
        """Register a patient and give them a new pseudonymous code. Two patients may
        share a name: look for an existing one first (`find_patients`)."""
        values = _patient_values(
            first_name=first_name, last_name=last_name, birth_year=birth_year, side=side,
            body_mass_kg=body_mass_kg, upper_arm_m=upper_arm_m, forearm_m=forearm_m,
            shoulder_m=shoulder_m, notes=notes,
        )
        values["created_at"] = _utc_text(_utc_now())
        with self._write() as conn:
            for _ in range(20):
                code = new_code()
                if not conn.execute("SELECT 1 FROM patients WHERE code = ?",
                                    (code,)).fetchone():
                    break
            else:  # pragma: no cover - 20 collisions in 10⁹ codes
                raise RegistryError("could not draw an unused patient code; try again")
            values["code"] = code
            columns = ", ".join(values)
            marks = ", ".join("?" * len(values))
            conn.execute(f"INSERT INTO patients ({columns}) VALUES ({marks})",
                         tuple(values.values()))
            patient = self._patient(conn, code)
        log.info("patient %s registered", code)
        return patient

    def update_patient(self, code: str, /, **changes) -> Patient:
        """Change any of create_patient's fields; the code and creation time stay."""
        allowed = {"first_name", "last_name", "birth_year", "side", "body_mass_kg",
                   "upper_arm_m", "forearm_m", "shoulder_m", "notes"}
        unknown = sorted(set(changes) - allowed)
        if unknown:
            raise InvalidRecordError(
                f"patient field(s) {', '.join(unknown)} cannot be changed; give any of "
                f"{', '.join(sorted(allowed))}"
            )
        with self._write() as conn:
            current = self._patient(conn, code)
            merged = {name: getattr(current, name) for name in allowed} | changes
            values = _patient_values(**merged)
            assignments = ", ".join(f"{name} = ?" for name in values)
            conn.execute(f"UPDATE patients SET {assignments} WHERE code = ?",
                         (*values.values(), code))
            patient = self._patient(conn, code)
        log.info("patient %s updated (%s)", code, ", ".join(sorted(changes)))
        return patient

    def patient(self, code: str) -> Patient:
        with self._read() as conn:
            return self._patient(conn, code)

    def patients(self) -> list[Patient]:
        """Every patient, by last name, first name, then code."""
        with self._read() as conn:
            rows = conn.execute(f"SELECT {', '.join(_PATIENT_COLUMNS)} FROM patients").fetchall()
        return sorted((_patient_from_row(r) for r in rows), key=_patient_order)

    def find_patients(self, first_name: str, last_name: str) -> list[Patient]:
        """Patients with exactly this name, ignoring case and accents: what the
        registration tab checks before creating a patient."""
        first, last = _fold(first_name), _fold(last_name)
        return [p for p in self.patients()
                if _fold(p.first_name) == first and _fold(p.last_name) == last]

    def search_patients(self, text: str, limit: int | None = 50) -> list[Patient]:
        """Patients whose code starts with `text`, or whose first or last name
        contains every word of it (ignoring case and accents)."""
        words = _fold(text).split()
        if not words:
            found = self.patients()
        else:
            prefix = text.strip().upper()
            found = [
                p for p in self.patients()
                if p.code.startswith(prefix)
                or all(w in _fold(p.first_name) or w in _fold(p.last_name) for w in words)
            ]
        return found if limit is None else found[:limit]

    def _patient(self, conn: sqlite3.Connection, code: str) -> Patient:
        row = conn.execute(f"SELECT {', '.join(_PATIENT_COLUMNS)} FROM patients WHERE code = ?",
                           (code,)).fetchone()
        if row is None:
            raise PatientNotFound(
                f"no patient has the code {code!r} in the registry {self.path}; search by "
                "name or code to find the right one"
            )
        return _patient_from_row(row)

    def _patient_id(self, conn: sqlite3.Connection, code: str) -> int:
        row = conn.execute("SELECT id FROM patients WHERE code = ?", (code,)).fetchone()
        if row is None:
            self._patient(conn, code)  # raises PatientNotFound with its message
        return row[0]

    # -- sessions --------------------------------------------------------------
    def next_session_number(self, code: str) -> int:
        with self._read() as conn:
            return _next_session_number(conn, self._patient_id(conn, code))

    def open_session(
        self,
        code: str,
        *,
        number: int | None = None,
        date: datetime.date | None = None,
        therapist: str = "",
        location: str = "",
        notes: str = "",
    ) -> Session:
        """Start a new session for the patient: `number` defaults to the next one;
        a number already used is refused, naming the next free one."""
        date = date or datetime.date.today()
        with self._write() as conn:
            patient_id = self._patient_id(conn, code)
            if number is None:
                number = _next_session_number(conn, patient_id)
            else:
                _check_number("session number", number)
                taken = conn.execute(
                    "SELECT date FROM sessions WHERE patient_id = ? AND number = ?",
                    (patient_id, number),
                ).fetchone()
                if taken:
                    free = _next_session_number(conn, patient_id)
                    raise DuplicateNumberError(
                        f"patient {code} already has a session {number} (on {taken[0]}); "
                        f"use {free}, the next free number, or continue session {number} by "
                        "registering a trial in it"
                    )
            session_id = _insert_session(conn, patient_id, number, date, therapist, location,
                                         notes)
            session = self._session_by_id(conn, session_id)
        log.info("patient %s: session %d opened", code, number)
        return session

    def update_session(self, code: str, number: int, /, **changes) -> Session:
        """Change a session's date, therapist, location or notes."""
        allowed = {"date", "therapist", "location", "notes"}
        unknown = sorted(set(changes) - allowed)
        if unknown:
            raise InvalidRecordError(
                f"session field(s) {', '.join(unknown)} cannot be changed; give any of "
                f"{', '.join(sorted(allowed))}"
            )
        values = {}
        for name, value in changes.items():
            if name == "date":
                if not isinstance(value, datetime.date):
                    raise InvalidRecordError(f"session date {value!r}: give a datetime.date")
                values[name] = value.isoformat()
            else:
                values[name] = _text(f"session {name}", value, TEXT_MAX_CHARS)
        with self._write() as conn:
            session_id = self._session_id(conn, code, number)
            if values:
                assignments = ", ".join(f"{name} = ?" for name in values)
                conn.execute(f"UPDATE sessions SET {assignments} WHERE id = ?",
                             (*values.values(), session_id))
            return self._session_by_id(conn, session_id)

    def session(self, code: str, number: int) -> Session:
        with self._read() as conn:
            return self._session_by_id(conn, self._session_id(conn, code, number))

    def sessions(self, code: str) -> list[Session]:
        """The patient's sessions by number."""
        with self._read() as conn:
            patient_id = self._patient_id(conn, code)
            rows = conn.execute(_SESSION_SELECT + " WHERE s.patient_id = ? ORDER BY s.number",
                                (patient_id,)).fetchall()
        return [_session_from_row(r) for r in rows]

    def _session_id(self, conn: sqlite3.Connection, code: str, number: int) -> int:
        patient_id = self._patient_id(conn, code)
        row = conn.execute("SELECT id FROM sessions WHERE patient_id = ? AND number = ?",
                           (patient_id, number)).fetchone()
        if row is None:
            raise SessionNotFound(
                f"patient {code} has no session {number}; their sessions are listed by "
                "Registry.sessions"
            )
        return row[0]

    def _session_by_id(self, conn: sqlite3.Connection, session_id: int) -> Session:
        row = conn.execute(_SESSION_SELECT + " WHERE s.id = ?", (session_id,)).fetchone()
        return _session_from_row(row)

    # -- registration ------------------------------------------------------------
    def suggest_registration(self, code: str, today: datetime.date | None = None) -> Registration:
        """The numbers to pre-fill: the next trial of today's session when the
        patient's latest session is today, else trial 1 of the next session."""
        today = today or datetime.date.today()
        with self._read() as conn:
            return _suggest(conn, code, self._patient_id(conn, code), today)

    def next_trial_number(self, code: str, session_number: int) -> int:
        """The next trial number in a session (1 when the session does not exist yet)."""
        with self._read() as conn:
            patient_id = self._patient_id(conn, code)
            row = conn.execute("SELECT id FROM sessions WHERE patient_id = ? AND number = ?",
                               (patient_id, session_number)).fetchone()
            return 1 if row is None else _next_trial_number(conn, row[0])

    def begin_trial(
        self,
        code: str,
        parameters: TrialParameters | Mapping,
        *,
        backend: str,
        session_number: int | None = None,
        trial_number: int | None = None,
        patient_kind: str | None = None,
        therapist: str = "",
        location: str = "",
        started_at: datetime.datetime | None = None,
    ) -> BegunTrial:
        """Register a trial as it starts (status 'recording') and return its id and file.

        `session_number` None: today's session if the latest is today, else a new
        one. A session number that does not exist yet opens that session (dated
        the start's local day, with `therapist` and `location`). `trial_number`
        None: the next in the session; a number already used raises
        DuplicateNumberError naming the next free one. `patient_kind` names the
        virtual patient of a simulated trial.
        """
        started_at = _aware(started_at or _utc_now(), "started_at")
        params = _parameters_dict(parameters)
        backend = _text("backend", backend, NAME_MAX_CHARS)
        if not backend:
            raise InvalidRecordError("backend is empty: give the name of the robot backend "
                                     "that runs the trial (e.g. 'simulator')")
        if patient_kind is not None and patient_kind not in PATIENT_KINDS:
            raise InvalidRecordError(
                f"patient_kind {patient_kind!r}: give one of {', '.join(PATIENT_KINDS)} for a "
                "simulated trial, or None for a real patient"
            )
        for name, number in (("session number", session_number),
                             ("trial number", trial_number)):
            if number is not None:
                _check_number(name, number)
        # The folder is made outside the transaction: the write lock is held for
        # database work only.
        if _is_code(code):
            self.data_dir.ensure(TRIALS, code)
        local_day = started_at.astimezone().date()
        with self._write() as conn:
            patient_id = self._patient_id(conn, code)
            if session_number is None:
                session_number = _suggest(conn, code, patient_id, local_day).session_number
            row = conn.execute("SELECT id FROM sessions WHERE patient_id = ? AND number = ?",
                               (patient_id, session_number)).fetchone()
            if row is None:
                session_id = _insert_session(conn, patient_id, session_number, local_day,
                                             therapist, location, "")
                log.info("patient %s: session %d opened", code, session_number)
            else:
                session_id = row[0]
            if trial_number is None:
                trial_number = _next_trial_number(conn, session_id)
            else:
                taken = conn.execute(
                    "SELECT started_at FROM trials WHERE session_id = ? AND number = ?",
                    (session_id, trial_number),
                ).fetchone()
                if taken:
                    free = _next_trial_number(conn, session_id)
                    raise DuplicateNumberError(
                        f"patient {code} session {session_number} already has a trial "
                        f"{trial_number} (started {taken[0]}); use {free}, the next free "
                        "number, or leave the trial number empty to number it automatically"
                    )
            file = self.data_dir.trial_file(code, session_number, trial_number, started_at)
            cursor = conn.execute(
                "INSERT INTO trials (session_id, number, parameters, file, metrics, status, "
                "started_at, backend, patient_kind) VALUES (?, ?, ?, ?, '{}', ?, ?, ?, ?)",
                (session_id, trial_number, json.dumps(params), file, STATUS_RECORDING,
                 _utc_text(started_at), backend, patient_kind),
            )
            trial_id = cursor.lastrowid
        log.info("trial %d registered: patient %s session %d trial %d (%s)",
                 trial_id, code, session_number, trial_number, backend)
        return BegunTrial(trial_id, code, session_number, trial_number,
                          self.data_dir.resolve(file), file, started_at)

    def finish_trial(
        self,
        trial_id: int,
        status: str,
        metrics: Mapping[str, float],
        ended_at: datetime.datetime | None = None,
    ) -> Trial:
        """Record how a trial ended: status one of complete, stopped_early, faulted,
        recording_lost; metrics as computed (NaN allowed). A trial is finished once."""
        if status not in STATUSES:
            raise InvalidRecordError(
                f"trial status {status!r}: give one of {', '.join(STATUSES)}"
            )
        ended_at = _aware(ended_at or _utc_now(), "ended_at")
        metrics_json = _metrics_json(metrics)
        with self._write() as conn:
            trial = self._trial(conn, trial_id)
            if trial.finished:
                raise RegistryError(
                    f"trial {trial_id} was already finished ({trial.status} at "
                    f"{trial.ended_at}); use update_metrics to store recomputed metrics"
                )
            if ended_at < trial.started_at:
                raise InvalidRecordError(
                    f"trial {trial_id} would end at {ended_at.isoformat()}, before it started "
                    f"({trial.started_at.isoformat()}): check the computer's clock"
                )
            conn.execute("UPDATE trials SET status = ?, metrics = ?, ended_at = ? WHERE id = ?",
                         (status, metrics_json, _utc_text(ended_at), trial_id))
            trial = self._trial(conn, trial_id)
        log.info("trial %d finished: %s, %d metric(s)", trial_id, status, len(trial.metrics))
        return trial

    def update_metrics(self, trial_id: int, metrics: Mapping[str, float], *,
                       replace: bool = False) -> Trial:
        """Store recomputed metrics: merged into the trial's (or replacing them all)."""
        checked = json.loads(_metrics_json(metrics))
        with self._write() as conn:
            trial = self._trial(conn, trial_id)
            merged = checked if replace else {**_metrics_json_ready(trial.metrics), **checked}
            conn.execute("UPDATE trials SET metrics = ? WHERE id = ?",
                         (json.dumps(merged, allow_nan=False), trial_id))
            return self._trial(conn, trial_id)

    # -- trials ------------------------------------------------------------------
    def trial(self, trial_id: int) -> Trial:
        with self._read() as conn:
            return self._trial(conn, trial_id)

    def trials(self, code: str, session_number: int) -> list[Trial]:
        """The trials of one session, by number."""
        with self._read() as conn:
            session_id = self._session_id(conn, code, session_number)
            rows = conn.execute(_TRIAL_SELECT + " WHERE t.session_id = ? ORDER BY t.number",
                                (session_id,)).fetchall()
        return _trials_from_rows(rows)

    def unfinished_trials(self) -> list[Trial]:
        """Every trial still recording, oldest first (after a console's crash, those
        `app.trials.finalize.finish_interrupted` finishes)."""
        with self._read() as conn:
            rows = conn.execute(_TRIAL_SELECT + " WHERE t.status = 'recording' ORDER BY t.id"
                                ).fetchall()
        return _trials_from_rows(rows)

    def trials_for_patient(self, code: str) -> list[Trial]:
        """Every trial of a patient, by session number then trial number."""
        with self._read() as conn:
            patient_id = self._patient_id(conn, code)
            rows = conn.execute(
                _TRIAL_SELECT + " WHERE s.patient_id = ? ORDER BY s.number, t.number",
                (patient_id,),
            ).fetchall()
        return _trials_from_rows(rows)

    def trial_summaries(self, code: str) -> list[TrialSummary]:
        """Every trial of a patient, by session then trial number, without the full
        parameters: the progress query (about half the cost of trials_for_patient)."""
        with self._read() as conn:
            rows = conn.execute(_SUMMARY_SELECT, (self._patient_id(conn, code),)).fetchall()
        if not rows:
            return []
        metrics = _parse_metrics(row[-1] for row in rows)
        date = datetime.date.fromisoformat
        moment = datetime.datetime.fromisoformat
        k = len(KEY_PARAMETERS)
        # Most trials share a few parameter sets: one tuple per set, not per trial,
        # keeps fewer objects alive for the garbage collector to walk.
        shared: dict[tuple, tuple] = {}
        return [
            TrialSummary(r[0], r[1], date(r[2]), r[3], r[4], moment(r[5]), r[6],
                         shared.setdefault(r[7:7 + k], r[7:7 + k]), values)
            for r, values in zip(rows, metrics, strict=True)
        ]

    def previous_trial(
        self,
        trial_id: int,
        *,
        earlier_session: bool = False,
        same_parameters: bool = False,
        statuses: Iterable[str] = ("complete",),
    ) -> Trial | None:
        """The patient's latest trial before this one, to report the change since.

        earlier_session: only trials of earlier sessions (change since the last session).
        same_parameters: only trials done at the same KEY_PARAMETERS, where the
            metrics compare directly.
        statuses: the statuses that count (by default complete trials only).
        """
        statuses = tuple(statuses)
        unknown = sorted(set(statuses) - set(_ALL_STATUSES))
        if unknown:
            raise InvalidRecordError(
                f"status(es) {', '.join(unknown)}: give any of {', '.join(_ALL_STATUSES)}"
            )
        with self._read() as conn:
            trial = self._trial(conn, trial_id)
            patient_id = self._patient_id(conn, trial.patient_code)
            if earlier_session:
                before = "s.number < ?"
                args: tuple = (trial.session_number,)
            else:
                before = "(s.number < ? OR (s.number = ? AND t.number < ?))"
                args = (trial.session_number, trial.session_number, trial.number)
            marks = ", ".join("?" * len(statuses)) or "NULL"
            rows = conn.execute(
                _TRIAL_SELECT + f" WHERE s.patient_id = ? AND {before} AND t.status IN ({marks})"
                " ORDER BY s.number DESC, t.number DESC",
                (patient_id, *args, *statuses),
            )
            key = trial.key_parameters()
            for row in rows:
                candidate = _trial_from_row(row)
                if not same_parameters or candidate.key_parameters() == key:
                    return candidate
        return None

    def backup(self, target: str | Path) -> Path:
        """A consistent copy of the registry (SQLite's online backup), safe while
        other consoles write: for a researcher's export or before a risky change."""
        target = Path(target)
        with self._connection() as conn:
            try:
                target.parent.mkdir(parents=True, exist_ok=True)
                with contextlib.closing(sqlite3.connect(target)) as copy:
                    conn.backup(copy)
            except (OSError, sqlite3.Error) as exc:
                raise RegistryError(
                    f"cannot write a copy of the registry to {target}: {exc}. Choose a "
                    "writable folder with free space"
                ) from exc
        return target

    def trial_path(self, trial: Trial | int) -> Path:
        """The absolute path of a trial's file (which may be missing)."""
        if not isinstance(trial, Trial):
            trial = self.trial(trial)
        return self.data_dir.resolve(trial.file)

    def integrity_check(self) -> list[str]:
        """SQLite's integrity and foreign-key checks: an empty list when sound."""
        with self._connection() as conn:
            problems = [r[0] for r in conn.execute("PRAGMA integrity_check") if r[0] != "ok"]
            problems += [f"{table} row {rowid} points to a missing {parent}"
                         for table, rowid, parent, _ in conn.execute("PRAGMA foreign_key_check")]
        return problems

    def _trial(self, conn: sqlite3.Connection, trial_id: int) -> Trial:
        row = conn.execute(_TRIAL_SELECT + " WHERE t.id = ?", (trial_id,)).fetchone()
        if row is None:
            raise TrialNotFound(
                f"no trial has the id {trial_id!r} in the registry {self.path}; list the "
                "patient's trials to find it"
            )
        return _trial_from_row(row)


# ---------------------------------------------------------------- helpers
def parameter_key(values: Iterable) -> tuple:
    """Parameter values made comparable: floats to 9 significant digits, so that
    one exercise reached through different unit conversions is one exercise."""
    return tuple(
        float(f"{v:.9g}") if isinstance(v, float) and math.isfinite(v) else v for v in values
    )


def _rollback(conn: sqlite3.Connection) -> None:
    # SQLite rolls back by itself after some errors (disk full); a second
    # ROLLBACK would then raise and hide the first error.
    if conn.in_transaction:
        conn.execute("ROLLBACK")


def new_code() -> str:
    """A fresh pseudonymous code: 'P' and 6 random Crockford base32 characters."""
    return "P" + "".join(secrets.choice(CODE_ALPHABET) for _ in range(CODE_LENGTH))


def _is_code(code: object) -> bool:
    return isinstance(code, str) and CODE_PATTERN.fullmatch(code) is not None


def _utc_now() -> datetime.datetime:
    return datetime.datetime.now(datetime.UTC)


def _utc_text(moment: datetime.datetime) -> str:
    return moment.astimezone(datetime.UTC).isoformat(timespec="microseconds")


def _aware(moment: datetime.datetime, name: str) -> datetime.datetime:
    if not isinstance(moment, datetime.datetime) or moment.tzinfo is None:
        raise InvalidRecordError(
            f"{name} {moment!r}: give a datetime with a time zone (e.g. datetime.UTC)"
        )
    return moment


def _fold(text: str | None) -> str:
    """Case- and accent-free form for matching names typed differently."""
    if not text:
        return ""
    decomposed = unicodedata.normalize("NFKD", text.casefold())
    return "".join(c for c in decomposed if not unicodedata.combining(c)).strip()


def _patient_order(patient: Patient) -> tuple:
    return (_fold(patient.last_name), _fold(patient.first_name), patient.code)


def _text(name: str, value: object, max_chars: int) -> str:
    if not isinstance(value, str):
        raise InvalidRecordError(f"{name}: give text, not {type(value).__name__}")
    value = value.strip()
    if len(value) > max_chars:
        raise InvalidRecordError(f"{name} has {len(value)} characters; keep it to {max_chars}")
    return value


def _optional_name(name: str, value: object) -> str | None:
    if value is None:
        return None
    return _text(name, value, NAME_MAX_CHARS) or None


def _optional_range(name: str, value: object, low: float, high: float, unit: str,
                    why: str = "") -> float | None:
    if value is None:
        return None
    try:
        return check_range(name, value, low, high, unit, why)
    except CoreError as exc:
        raise InvalidRecordError(str(exc)) from None


def _patient_values(*, first_name, last_name, birth_year, side, body_mass_kg, upper_arm_m,
                    forearm_m, shoulder_m, notes) -> dict:
    this_year = datetime.date.today().year
    if birth_year is not None and (
        isinstance(birth_year, bool) or not isinstance(birth_year, int)
        or not BIRTH_YEAR_MIN <= birth_year <= this_year
    ):
        raise InvalidRecordError(
            f"birth_year = {birth_year!r} is not allowed; give a year {BIRTH_YEAR_MIN}-"
            f"{this_year}, or None"
        )
    if side is not None and side not in SIDES:
        raise InvalidRecordError(f"side = {side!r}: give one of {', '.join(SIDES)}, or None "
                                 "(the affected side)")
    if shoulder_m is None:
        shoulder = (None, None)
    else:
        try:
            x, y = shoulder_m
        except (TypeError, ValueError):
            raise InvalidRecordError(
                f"shoulder_m = {shoulder_m!r}: give a pair (x, y) in m in the robot frame"
            ) from None
        shoulder = (_optional_range("shoulder_m[x]", x, *POSITION_RANGE_M, "m"),
                    _optional_range("shoulder_m[y]", y, *POSITION_RANGE_M, "m"))
    return {
        "first_name": _optional_name("first_name", first_name),
        "last_name": _optional_name("last_name", last_name),
        "birth_year": birth_year,
        "side": side,
        "body_mass_kg": _optional_range("body_mass_kg", body_mass_kg, *BODY_MASS_RANGE_KG,
                                        "kg", "Winter's segment proportions hold for adults"),
        "upper_arm_m": _optional_range("upper_arm_m", upper_arm_m, *UPPER_ARM_RANGE_M, "m",
                                       "shoulder to elbow of an adult"),
        "forearm_m": _optional_range("forearm_m", forearm_m, *FOREARM_RANGE_M, "m",
                                     "elbow to wrist of an adult"),
        "shoulder_x_m": shoulder[0],
        "shoulder_y_m": shoulder[1],
        "notes": _text("notes", notes if notes is not None else "", TEXT_MAX_CHARS),
    }


def _patient_from_row(row: tuple) -> Patient:
    (code, first, last, birth_year, side, mass, upper, fore, sx, sy, notes, created) = row
    shoulder = None if sx is None or sy is None else (sx, sy)
    return Patient(code, first, last, birth_year, side, mass, upper, fore, shoulder, notes,
                   datetime.datetime.fromisoformat(created))


def _session_from_row(row: tuple) -> Session:
    session_id, code, number, date, therapist, location, notes, n_trials = row
    return Session(session_id, code, number, datetime.date.fromisoformat(date), therapist,
                   location, notes, n_trials)


def _trial_from_row(row: tuple) -> Trial:
    return _trials_from_rows([row])[0]


def _trials_from_rows(rows: list[tuple]) -> list[Trial]:
    # One json.loads over all rows instead of two per row: listing a patient's
    # trials costs mostly JSON parsing, and this removes the per-call overhead.
    if not rows:
        return []
    parameters = json.loads("[" + ",".join(r[5] for r in rows) + "]")
    metrics = _parse_metrics(r[7] for r in rows)
    trials = []
    for row, params, values in zip(rows, parameters, metrics, strict=True):
        (trial_id, code, session_number, session_date, number, _, file, _, status,
         started_at, ended_at, backend, patient_kind) = row
        trials.append(Trial(
            trial_id, code, session_number, datetime.date.fromisoformat(session_date), number,
            params, file, values, status, datetime.datetime.fromisoformat(started_at),
            None if ended_at is None else datetime.datetime.fromisoformat(ended_at),
            backend, patient_kind,
        ))
    return trials


def _parse_metrics(texts: Iterable[str]) -> list[dict[str, float]]:
    """Stored metrics back to floats; JSON has no NaN, so undefined ones are null."""
    parsed = json.loads("[" + ",".join(texts) + "]")
    nan = math.nan
    return [
        {k: nan if v is None else v for k, v in values.items()}
        if None in values.values() else values
        for values in parsed
    ]


def _metrics_json_ready(metrics: Mapping[str, float]) -> dict:
    return {k: v if math.isfinite(v) else None for k, v in metrics.items()}


def _metrics_json(metrics: Mapping[str, float]) -> str:
    if not isinstance(metrics, Mapping):
        raise InvalidRecordError("metrics: give a mapping of metric names to numbers")
    out = {}
    for name, value in metrics.items():
        if not isinstance(name, str) or not _METRIC_NAME.fullmatch(name):
            raise InvalidRecordError(
                f"metric name {name!r}: use letters, digits and '_', with the units in it "
                "(e.g. rmse_x_m)"
            )
        if isinstance(value, bool) or not isinstance(value, int | float):
            try:
                value = float(value)  # numpy scalars
            except (TypeError, ValueError):
                raise InvalidRecordError(
                    f"metric {name} = {value!r}: give a number (NaN if undefined)"
                ) from None
        value = float(value)
        out[name] = value if math.isfinite(value) else None
    return json.dumps(out, allow_nan=False)


def _parameters_dict(parameters: TrialParameters | Mapping) -> dict:
    if isinstance(parameters, TrialParameters):
        return parameters.to_dict()
    if not isinstance(parameters, Mapping):
        raise InvalidRecordError("parameters: give a core.trial.TrialParameters")
    try:
        return TrialParameters.from_dict(dict(parameters)).to_dict()
    except (CoreError, TypeError) as exc:
        raise InvalidRecordError(f"trial parameters refused: {exc}") from None


def _check_number(name: str, number: object) -> None:
    if isinstance(number, bool) or not isinstance(number, int) or not 1 <= number <= 999_999:
        raise InvalidRecordError(f"{name} {number!r}: give a whole number from 1 to 999999")


def _next_session_number(conn: sqlite3.Connection, patient_id: int) -> int:
    row = conn.execute("SELECT max(number) FROM sessions WHERE patient_id = ?",
                       (patient_id,)).fetchone()
    return (row[0] or 0) + 1


def _next_trial_number(conn: sqlite3.Connection, session_id: int) -> int:
    row = conn.execute("SELECT max(number) FROM trials WHERE session_id = ?",
                       (session_id,)).fetchone()
    return (row[0] or 0) + 1


def _suggest(conn: sqlite3.Connection, code: str, patient_id: int,
             today: datetime.date) -> Registration:
    latest = conn.execute(
        "SELECT id, number, date FROM sessions WHERE patient_id = ? ORDER BY number DESC "
        "LIMIT 1", (patient_id,),
    ).fetchone()
    if latest is not None and latest[2] == today.isoformat():
        return Registration(code, latest[1], _next_trial_number(conn, latest[0]), False)
    return Registration(code, _next_session_number(conn, patient_id), 1, True)


def _insert_session(conn: sqlite3.Connection, patient_id: int, number: int,
                    date: datetime.date, therapist: str, location: str, notes: str) -> int:
    if not isinstance(date, datetime.date):
        raise InvalidRecordError(f"session date {date!r}: give a datetime.date")
    cursor = conn.execute(
        "INSERT INTO sessions (patient_id, number, date, therapist, location, notes) "
        "VALUES (?, ?, ?, ?, ?, ?)",
        (patient_id, number, date.isoformat(), _text("therapist", therapist, NAME_MAX_CHARS),
         _text("location", location, NAME_MAX_CHARS), _text("notes", notes, TEXT_MAX_CHARS)),
    )
    return cursor.lastrowid


