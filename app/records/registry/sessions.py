"""The registry's sessions: one sitting of a patient, numbered from 1 per patient.

A session is opened explicitly (`open_session`) or by its first record, whatever it is:
a trial (`begin_trial` in app.records.registry.trials), or a scale or a note
(app.records.registry.clinical: therapists take the Fugl-Meyer before the robot's first
trial). Both number it in one place (`open_or_continue`), the patient's row locked first,
so a session a scale opened and the trial after it are one session, also when two stations
race. A number already used is refused, naming the next free one; the UNIQUE constraint on
(patient, session number) backs this up when two consoles number at once.
"""

from __future__ import annotations

import datetime
import logging
from dataclasses import dataclass
from pathlib import Path

import sqlalchemy as sa

from app.errors import InvalidRecordError, SessionNotFound
from app.records.registry.database import Database
from app.records.registry.numbering import refuse_number
from app.records.registry.patients import patient_id
from app.records.registry.statements import execute
from app.records.registry.values import (
    NAME_MAX_CHARS,
    TEXT_MAX_CHARS,
    check_number,
    checked_text,
)

# The registry's one logger, named as it was before the registry had modules.
log = logging.getLogger(__package__)

_SESSION_SELECT = """
    SELECT s.id, p.code, s.number, s.date, s.therapist, s.location, s.notes,
           (SELECT count(*) FROM trials t WHERE t.session_id = s.id)
    FROM sessions s JOIN patients p ON p.id = s.patient_id
"""
_CHANGEABLE = {"date", "therapist", "location", "notes"}


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


class Sessions(Database):
    """Opening, changing and listing a patient's sessions."""

    def next_session_number(self, code: str) -> int:
        with self._read() as conn:
            return next_session_number_of(conn, patient_id(conn, self.where, code))

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
        """Start a new session for the patient: `number` defaults to the next one; any
        other is refused (used, or it would leave a gap: numbering.py), naming the next."""
        date = date or datetime.date.today()
        with self._write() as conn:
            patient = patient_id(conn, self.where, code, lock=True)
            free = next_session_number_of(conn, patient)
            if number is None:
                number = free
            else:
                check_number("session number", number)
            if number != free:
                taken = execute(conn,
                    "SELECT date FROM sessions WHERE patient_id = ? AND number = ?",
                    (patient, number),
                ).fetchone()
                raise refuse_number(
                    "session", number, free, whose=f"patient {code}",
                    used_on=datetime.date.fromisoformat(taken[0]) if taken else None,
                    advice=(f", or continue session {number} by registering a trial in it"
                            if taken else ""))
            session_id = insert_session(conn, patient, number, date, therapist, location, notes)
            session = _session_by_id(conn, session_id)
        log.info("patient %s: session %d opened", code, number)
        return session

    def update_session(self, code: str, number: int, /, **changes) -> Session:
        """Change a session's date, therapist, location or notes."""
        unknown = sorted(set(changes) - _CHANGEABLE)
        if unknown:
            raise InvalidRecordError(
                f"session field(s) {', '.join(unknown)} cannot be changed; give any of "
                f"{', '.join(sorted(_CHANGEABLE))}"
            )
        values = {}
        for name, value in changes.items():
            if name == "date":
                if not isinstance(value, datetime.date):
                    raise InvalidRecordError(f"session date {value!r}: give a datetime.date")
                values[name] = value.isoformat()
            else:
                values[name] = checked_text(f"session {name}", value, TEXT_MAX_CHARS)
        with self._write() as conn:
            session_id = session_id_of(conn, self.where, code, number)
            if values:
                assignments = ", ".join(f"{name} = ?" for name in values)
                execute(conn, f"UPDATE sessions SET {assignments} WHERE id = ?",
                              (*values.values(), session_id))
            return _session_by_id(conn, session_id)

    def session(self, code: str, number: int) -> Session:
        with self._read() as conn:
            return _session_by_id(conn, session_id_of(conn, self.where, code, number))

    def sessions(self, code: str) -> list[Session]:
        """The patient's sessions by number."""
        with self._read() as conn:
            patient = patient_id(conn, self.where, code)
            rows = execute(conn, _SESSION_SELECT + " WHERE s.patient_id = ? ORDER BY s.number",
                                 (patient,)).fetchall()
        return [_session_from_row(r) for r in rows]


# -- shared with the trials ------------------------------------------------------------
def session_id_of(conn: sa.Connection, registry: Path, code: str, number: int) -> int:
    """The row id of the patient's session `number` (SessionNotFound if none)."""
    patient = patient_id(conn, registry, code)
    row = execute(conn, "SELECT id FROM sessions WHERE patient_id = ? AND number = ?",
                        (patient, number)).fetchone()
    if row is None:
        # said to whoever typed the number (the window, `rehab scales add`): which numbers
        # there are, not the API that lists them
        numbers = [n for (n,) in execute(
            conn, "SELECT number FROM sessions WHERE patient_id = ? ORDER BY number",
            (patient,)).fetchall()]
        there = (f"their sessions are {_listed(numbers)}" if numbers else
                 "they have none yet: a session begins with its first trial")
        raise SessionNotFound(f"patient {code} has no session {number}; {there}")
    return row[0]


def session_of_a_record(conn: sa.Connection, registry: Path, code: str, number: int,
                        day: datetime.date) -> int:
    """The row id of the patient's session `number` for a scale or a note written in it: an
    existing session, or the patient's next one, opened by this record (dated `day`) as a
    trial opens it (`open_or_continue`, the patient's row locked first). Any other number
    is refused in one line naming the numbers possible (SessionNotFound)."""
    check_number("session number", number)
    patient = patient_id(conn, registry, code, lock=True)
    latest, asked, _ = sessions_for_a_trial(conn, patient, number)
    next_number = 1 if latest is None else latest[1] + 1
    if asked is None and number != next_number:
        numbers = [n for (n,) in execute(
            conn, "SELECT number FROM sessions WHERE patient_id = ? ORDER BY number",
            (patient,)).fetchall()]
        there = (f"give one of their sessions ({_listed(numbers)}) or {next_number}, which "
                 "opens the next" if numbers else
                 "they have none yet: give 1, which opens their first")
        raise SessionNotFound(f"patient {code} has no session {number}; {there}")
    return open_or_continue(conn, code, patient, number, latest, asked, day)[0]


def open_or_continue(conn: sa.Connection, code: str, patient: int, number: int | None,
                     latest: tuple | None, asked: tuple | None, day: datetime.date,
                     therapist: str = "", location: str = "") -> tuple[int, int, int]:
    """(id, number, next trial number) of the session a new record goes in, from what
    `sessions_for_a_trial` read under the patient's lock: `asked` when there is one, else
    the patient's next session, opened now (dated `day`, with `therapist` and `location`);
    `number` None takes the next, another number is refused (numbering.py). The one place
    a trial, a scale or a note opens a session."""
    if asked is not None:
        return asked[0], asked[1], asked[3]
    next_number = 1 if latest is None else latest[1] + 1
    if number is None:
        number = next_number
    elif number != next_number:
        raise refuse_number("session", number, next_number, whose=f"patient {code}",
                            used_on=None)
    session_id = insert_session(conn, patient, number, day, therapist, location, "")
    log.info("patient %s: session %d opened", code, number)
    return session_id, number, 1  # a session opened now has no trial yet


def _listed(numbers: list[int]) -> str:
    """'1, 2 and 3', or the first two and the last four of a long list."""
    shown = [str(n) for n in numbers]
    if len(shown) > 6:
        shown = [*shown[:2], "…", *shown[-4:]]
    return shown[0] if len(shown) == 1 else f"{', '.join(shown[:-1])} and {shown[-1]}"


def next_session_number_of(conn: sa.Connection, patient: int) -> int:
    """The number after the patient's highest session number (1 for the first)."""
    row = execute(conn, "SELECT max(number) FROM sessions WHERE patient_id = ?",
                        (patient,)).fetchone()
    return (row[0] or 0) + 1


_SESSIONS = ("SELECT s.id, s.number, s.date, (SELECT coalesce(max(t.number), 0) + 1 FROM "
             "trials t WHERE t.session_id = s.id) AS free FROM sessions s "
             "WHERE s.patient_id = ? AND (s.number = ? OR s.number = (SELECT max(number) "
             "FROM sessions WHERE patient_id = ?)) ORDER BY s.number DESC")
_CARRYING = ("SELECT s.id, s.number, s.date, s.free{nulls} FROM (" + _SESSIONS + ") s "
             "UNION ALL SELECT NULL, NULL, NULL, NULL, {columns} FROM ({also}) a")
"""_SESSIONS and another read in one statement: each row the sessions' four columns, then
the other read's."""


def sessions_for_a_trial(conn: sa.Connection, patient: int, number: int | None,
                         also: Carried | None = None
                         ) -> tuple[tuple | None, tuple | None, list[tuple]]:
    """The patient's latest session and their session `number` (None: none asked for),
    each (id, number, date, its next trial number) or None where there is none: all a new
    trial's numbering needs, in one read (a round trip to a server); and the rows of `also`,
    another read of the same transaction carried in that round trip, in no given order ([]
    without it)."""
    if also is None:
        return *_latest_and_asked(
            execute(conn, _SESSIONS, (patient, number, patient)).fetchall(), number), []
    # one statement: the sessions' rows, then `also`'s, each side's columns NULL in the
    # other's rows (UNION ALL keeps each column's type, no cast), told apart by the first
    # column, a session's id: never NULL
    rows, carried = [], []
    for row in execute(conn, carrying(also), (patient, number, patient, *also.values)
                       ).fetchall():
        if row[0] is None:
            carried.append(row[4:])
        else:
            rows.append(row[:4])
    rows.sort(key=lambda row: row[1], reverse=True)  # as _SESSIONS orders them
    return *_latest_and_asked(rows, number), carried


def carrying(also: Carried) -> str:
    """The statement of `sessions_for_a_trial` carrying `also` (its values: the patient, the
    session number asked for, the patient again, then `also`'s)."""
    return _CARRYING.format(also=also.statement, nulls=", NULL" * len(also.columns),
                            columns=", ".join(f"a.{name}" for name in also.columns))


def _latest_and_asked(rows: list[tuple], number: int | None) -> tuple[tuple | None,
                                                                      tuple | None]:
    return rows[0] if rows else None, next((row for row in rows if row[1] == number), None)


@dataclass(frozen=True, slots=True)
class Carried:
    """A read `sessions_for_a_trial` carries in its round trip: its statement (`?`
    placeholders), their values, and the names of its columns."""

    statement: str
    values: tuple
    columns: tuple[str, ...]


def insert_session(conn: sa.Connection, patient: int, number: int,
                   date: datetime.date, therapist: str, location: str, notes: str) -> int:
    """Insert a session row (number already checked); returns its id."""
    if not isinstance(date, datetime.date):
        raise InvalidRecordError(f"session date {date!r}: give a datetime.date")
    cursor = execute(conn,
        "INSERT INTO sessions (patient_id, number, date, therapist, location, notes) "
        "VALUES (?, ?, ?, ?, ?, ?) RETURNING id",
        (patient, number, date.isoformat(), checked_text("therapist", therapist, NAME_MAX_CHARS),
         checked_text("location", location, NAME_MAX_CHARS),
         checked_text("notes", notes, TEXT_MAX_CHARS)),
    )
    return cursor.scalar_one()


def _session_by_id(conn: sa.Connection, session_id: int) -> Session:
    row = execute(conn, _SESSION_SELECT + " WHERE s.id = ?", (session_id,)).fetchone()
    return _session_from_row(row)


def _session_from_row(row: tuple) -> Session:
    session_id, code, number, date, therapist, location, notes, n_trials = row
    return Session(session_id, code, number, datetime.date.fromisoformat(date), therapist,
                   location, notes, n_trials)
