"""What a therapist records beside the robot's trials (schema v8, issue 31): the clinical
scales of a session, notes on a session or a trial, a trial marked invalid (or valid
again), and a patient's measurements corrected with an audit trail.

Nothing here edits a trial file or a row once written (the tables are append-only,
seals.APPEND_ONLY): a scale recorded again for a session supersedes the earlier entry,
which stays; a later validity mark supersedes an earlier one; a correction changes the
patient's row and keeps the old value, the new one, who, when and why beside it, in the
same transaction. Every entry says who made it (`rater`, `author`, `by`) and when (UTC).
"""

from __future__ import annotations

import datetime
import json
import logging
from dataclasses import dataclass

import sqlalchemy as sa

from app.errors import InvalidRecordError
from app.records.registry.database import Database
from app.records.registry.patients import (
    _CHANGEABLE,
    Patient,
    _patient_values,
    patient_by_code,
    patient_id,
)
from app.records.registry.sessions import session_id_of, session_of_a_record
from app.records.registry.statements import execute
from app.records.registry.trials import trial_by_id
from app.records.registry.values import (
    NAME_MAX_CHARS,
    TEXT_MAX_CHARS,
    checked_text,
    utc_now,
    utc_text,
)
from app.records.scales import ScaleScore, scale_values, score
from device.recording.trialfile import STATUS_RECORDING

log = logging.getLogger(__package__)

CORRECTABLE = tuple(sorted(_CHANGEABLE - {"notes"}))
"""The patient's fields a correction may change (notes are added, not corrected)."""


@dataclass(frozen=True, slots=True)
class ScaleEntry:
    """One scale recorded for a session: its score (app.records.scales), who rated it and
    when. A later entry of the same scale for the same session supersedes it."""

    id: int
    patient_code: str
    session_number: int
    session_date: datetime.date
    scale: str
    total: int | None
    detail: dict
    rater: str
    recorded_at: datetime.datetime

    def values(self) -> dict[str, float]:
        """The plotted values (app.records.scales.scale_values)."""
        return scale_values(self.scale, self.total, self.detail)


@dataclass(frozen=True, slots=True)
class Note:
    """A note on a session (`trial_id` None) or on one of its trials."""

    id: int
    patient_code: str
    session_number: int
    trial_id: int | None
    text: str
    author: str
    written_at: datetime.datetime


@dataclass(frozen=True, slots=True)
class TrialMark:
    """A trial marked invalid (`valid` False) or valid again, why, by whom and when. The
    latest mark of a trial is its validity; a trial never marked is valid."""

    id: int
    trial_id: int
    valid: bool
    reason: str
    marked_by: str
    marked_at: datetime.datetime


@dataclass(frozen=True, slots=True)
class Correction:
    """A patient's field corrected: its old and new values (as stored, JSON), why, by whom
    and when."""

    id: int
    patient_code: str
    field: str
    old_value: object
    new_value: object
    reason: str
    corrected_by: str
    corrected_at: datetime.datetime


def _who(name: str, value: object) -> str:
    text = checked_text(name, value, NAME_MAX_CHARS)
    if not text:
        raise InvalidRecordError(f"{name}: give the name of who records this")
    return text


def _why(name: str, value: object) -> str:
    text = checked_text(name, value, TEXT_MAX_CHARS)
    if not text:
        raise InvalidRecordError(f"{name}: say why, in a few words")
    return text


_SCALE_SELECT = """
    SELECT c.id, p.code, s.number, s.date, c.scale, c.total, c.detail, c.rater, c.recorded_at
    FROM scales c JOIN sessions s ON s.id = c.session_id JOIN patients p ON p.id = s.patient_id
"""
_NOTE_SELECT = """
    SELECT n.id, p.code, s.number, n.trial_id, n.text, n.author, n.written_at
    FROM notes n JOIN sessions s ON s.id = n.session_id JOIN patients p ON p.id = s.patient_id
"""
_MARK_SELECT = "SELECT id, trial_id, valid, reason, marked_by, marked_at FROM trial_marks"
LATEST_MARK = ("(SELECT m.reason FROM trial_marks m WHERE m.trial_id = t.id AND m.valid = 0 "
               "AND m.id = (SELECT max(id) FROM trial_marks WHERE trial_id = t.id))")
"""SQL: the reason trial `t` is invalid, NULL when it is valid (its latest mark)."""
INVALID_MARKS = ("SELECT m.trial_id AS trial_id, m.reason AS reason FROM trial_marks m "
                 "WHERE m.valid = 0 AND m.id = (SELECT max(id) FROM trial_marks WHERE "
                 "trial_id = m.trial_id)")
"""SQL: the trials whose latest mark is invalid, with its reason (a table to join: with no
marks it is empty, and the progress query costs what it did before schema v8)."""


class Clinical(Database):
    """Scales, notes, validity marks and corrections (schema v8)."""

    # -- scales ------------------------------------------------------------------------
    def record_scale(self, code: str, session_number: int, scale: str, *, rater: str,
                     total: int | None = None, parts: dict | None = None,
                     items: dict | None = None, grades: dict | None = None) -> ScaleEntry:
        """Record a scale for the patient's session (app.records.scales.score checks its
        ranges); a scale recorded again for the session supersedes the earlier entry. The
        patient's next session number opens that session (sessions.session_of_a_record:
        scales are taken before the first trial)."""
        checked: ScaleScore = score(scale, total=total, parts=parts, items=items,
                                    grades=grades)
        rater = _who("rater", rater)
        with self._write() as conn:
            session = session_of_a_record(conn, self.where, code, session_number,
                                          datetime.date.today())
            cursor = execute(conn,
                "INSERT INTO scales (session_id, scale, total, detail, rater, recorded_at) "
                "VALUES (?, ?, ?, ?, ?, ?) RETURNING id",
                (session, checked.scale, checked.total,
                 json.dumps(checked.detail, sort_keys=True), rater, utc_text(utc_now())))
            row = execute(conn, _SCALE_SELECT + " WHERE c.id = ?",
                          (cursor.scalar_one(),)).fetchone()
        log.info("patient %s session %d: %s recorded", code, session_number, scale)
        return _scale_from_row(row)

    def scale_entries(self, code: str, session_number: int | None = None) -> list[ScaleEntry]:
        """Every scale entry of the patient (or of one session), oldest first: the history,
        superseded entries included."""
        with self._read() as conn:
            rows = _rows_of(conn, self.where, _SCALE_SELECT, "c", code, session_number)
        return [_scale_from_row(r) for r in rows]

    def session_scales(self, code: str) -> dict[int, dict[str, ScaleEntry]]:
        """The scales in effect per session: {session number: {scale: latest entry}}."""
        current: dict[int, dict[str, ScaleEntry]] = {}
        for entry in self.scale_entries(code):
            current.setdefault(entry.session_number, {})[entry.scale] = entry
        return current

    def study_scales(self) -> dict[str, dict[int, dict[str, ScaleEntry]]]:
        """session_scales of every patient with any: {code: {session: {scale: entry}}}."""
        with self._read() as conn:
            rows = execute(conn, _SCALE_SELECT + " ORDER BY c.id").fetchall()
        out: dict[str, dict[int, dict[str, ScaleEntry]]] = {}
        for row in rows:
            entry = _scale_from_row(row)
            out.setdefault(entry.patient_code, {}).setdefault(
                entry.session_number, {})[entry.scale] = entry
        return out

    # -- notes -------------------------------------------------------------------------
    def add_note(self, code: str, session_number: int, text: str, *, author: str,
                 trial_id: int | None = None) -> Note:
        """A note on the patient's session, or on one of its trials (`trial_id`); the
        patient's next session number opens that session, as a scale does."""
        text = checked_text("note", text, TEXT_MAX_CHARS)
        if not text:
            raise InvalidRecordError("note: write something (it is empty)")
        author = _who("author", author)
        with self._write() as conn:
            session = session_of_a_record(conn, self.where, code, session_number,
                                          datetime.date.today())
            if trial_id is not None:
                trial = trial_by_id(conn, self.where, trial_id)
                if (trial.patient_code, trial.session_number) != (code, session_number):
                    raise InvalidRecordError(
                        f"trial {trial_id} is patient {trial.patient_code}'s session "
                        f"{trial.session_number}, not {code}'s session {session_number}")
            cursor = execute(conn,
                "INSERT INTO notes (session_id, trial_id, text, author, written_at) "
                "VALUES (?, ?, ?, ?, ?) RETURNING id",
                (session, trial_id, text, author, utc_text(utc_now())))
            row = execute(conn, _NOTE_SELECT + " WHERE n.id = ?",
                          (cursor.scalar_one(),)).fetchone()
        return _note_from_row(row)

    def notes(self, code: str, session_number: int | None = None) -> list[Note]:
        """The patient's notes (or one session's), oldest first."""
        with self._read() as conn:
            rows = _rows_of(conn, self.where, _NOTE_SELECT, "n", code, session_number)
        return [_note_from_row(r) for r in rows]

    # -- validity ----------------------------------------------------------------------
    def mark_trial(self, trial_id: int, *, valid: bool, reason: str, by: str) -> TrialMark:
        """Mark a finished trial invalid (`valid` False) or valid again, saying why. The
        trial, its file and its row stay as they are; the mark is a new row."""
        if not isinstance(valid, bool):
            raise InvalidRecordError(f"valid = {valid!r}: give True or False")
        reason = _why("reason", reason)
        by = _who("by", by)
        with self._write() as conn:
            trial = trial_by_id(conn, self.where, trial_id, lock=True)
            if trial.status == STATUS_RECORDING:
                raise InvalidRecordError(
                    f"trial {trial_id} is still recording; mark it once it has finished")
            latest = _latest_mark(conn, trial_id)
            if (latest.valid if latest else True) == valid:
                state = "valid" if valid else f"invalid ({latest.reason})"
                raise InvalidRecordError(f"trial {trial_id} is already {state}; nothing "
                                         "was changed")
            cursor = execute(conn,
                "INSERT INTO trial_marks (trial_id, valid, reason, marked_by, marked_at) "
                "VALUES (?, ?, ?, ?, ?) RETURNING id",
                (trial_id, int(valid), reason, by, utc_text(utc_now())))
            row = execute(conn, _MARK_SELECT + " WHERE id = ?",
                          (cursor.scalar_one(),)).fetchone()
        log.info("trial %d marked %s", trial_id, "valid" if valid else "invalid")
        return _mark_from_row(row)

    def trial_marks(self, trial_id: int) -> list[TrialMark]:
        """A trial's validity marks, oldest first (empty: never marked, valid)."""
        with self._read() as conn:
            trial_by_id(conn, self.where, trial_id)
            rows = execute(conn, _MARK_SELECT + " WHERE trial_id = ? ORDER BY id",
                                 (trial_id,)).fetchall()
        return [_mark_from_row(r) for r in rows]

    def invalid_trials(self, code: str | None = None) -> dict[int, TrialMark]:
        """The trials whose latest mark is invalid (of one patient, or all), with it."""
        where = ""
        args: tuple = ()
        with self._read() as conn:
            if code is not None:
                where = (" AND m.trial_id IN (SELECT t.id FROM trials t JOIN sessions s ON "
                         "s.id = t.session_id WHERE s.patient_id = ?)")
                args = (patient_id(conn, self.where, code),)
            rows = execute(conn,
                "SELECT m.id, m.trial_id, m.valid, m.reason, m.marked_by, m.marked_at "
                "FROM trial_marks m WHERE m.valid = 0 AND m.id = (SELECT max(id) FROM "
                "trial_marks WHERE trial_id = m.trial_id)" + where, args).fetchall()
        return {r[1]: _mark_from_row(r) for r in rows}

    # -- corrections -------------------------------------------------------------------
    def correct_patient(self, code: str, field: str, value: object, *, reason: str,
                        by: str) -> Patient:
        """Correct one of the patient's recorded fields (CORRECTABLE), keeping the old
        value, the new one, why, who and when (`corrections`). The new value is checked as
        at registration; a value equal to the old one is refused (nothing to correct)."""
        if field not in CORRECTABLE:
            raise InvalidRecordError(f"{field!r} cannot be corrected; give one of "
                                     f"{', '.join(CORRECTABLE)}")
        reason = _why("reason", reason)
        by = _who("by", by)
        with self._write() as conn:
            patient_id(conn, self.where, code, lock=True)  # read, then changed: held
            current = patient_by_code(conn, self.where, code)
            old = getattr(current, field)
            merged = {name: getattr(current, name) for name in _CHANGEABLE} | {field: value}
            values = _patient_values(**merged)
            new = (None if values["shoulder_x_m"] is None else
                   (values["shoulder_x_m"], values["shoulder_y_m"])) \
                if field == "shoulder_m" else values[field]
            if _stored(old) == _stored(new):
                raise InvalidRecordError(f"patient {code}'s {field} is already {old!r}; "
                                         "nothing to correct")
            assignments = ", ".join(f"{name} = ?" for name in values)
            execute(conn, f"UPDATE patients SET {assignments} WHERE code = ?",
                          (*values.values(), code))
            execute(conn,
                "INSERT INTO corrections (patient_id, field, old_value, new_value, reason, "
                "corrected_by, corrected_at) VALUES (?, ?, ?, ?, ?, ?, ?)",
                (patient_id(conn, self.where, code), field, _stored(old), _stored(new), reason,
                 by, utc_text(utc_now())))
            patient = patient_by_code(conn, self.where, code)
        log.info("patient %s: %s corrected", code, field)
        return patient

    def corrections(self, code: str) -> list[Correction]:
        """The patient's corrections, oldest first: the audit trail."""
        with self._read() as conn:
            rows = execute(conn,
                "SELECT c.id, p.code, c.field, c.old_value, c.new_value, c.reason, "
                "c.corrected_by, c.corrected_at FROM corrections c JOIN patients p ON "
                "p.id = c.patient_id WHERE c.patient_id = ? ORDER BY c.id",
                (patient_id(conn, self.where, code),)).fetchall()
        return [Correction(r[0], r[1], r[2], json.loads(r[3]), json.loads(r[4]), r[5], r[6],
                           datetime.datetime.fromisoformat(r[7])) for r in rows]


def _rows_of(conn: sa.Connection, where: str, select: str, alias: str, code: str,
             session_number: int | None) -> list:
    """The rows `select` gives (its table named `alias`, joined to its session as `s`) of
    the patient's every session, or of one, in the order they were written."""
    if session_number is None:
        return execute(conn, select + f" WHERE s.patient_id = ? ORDER BY {alias}.id",
                       (patient_id(conn, where, code),)).fetchall()
    return execute(conn, select + f" WHERE {alias}.session_id = ? ORDER BY {alias}.id",
                   (session_id_of(conn, where, code, session_number),)).fetchall()


def _stored(value: object) -> str:
    """A field's value as the audit keeps it: JSON (a shoulder as [x, y])."""
    return json.dumps(list(value) if isinstance(value, tuple) else value)


def _latest_mark(conn: sa.Connection, trial_id: int) -> TrialMark | None:
    row = execute(conn, _MARK_SELECT + " WHERE trial_id = ? ORDER BY id DESC LIMIT 1",
                        (trial_id,)).fetchone()
    return None if row is None else _mark_from_row(row)


def _scale_from_row(row: tuple) -> ScaleEntry:
    (entry_id, code, number, date, scale, total, detail, rater, recorded) = row
    return ScaleEntry(entry_id, code, number, datetime.date.fromisoformat(date), scale, total,
                      json.loads(detail), rater, datetime.datetime.fromisoformat(recorded))


def _note_from_row(row: tuple) -> Note:
    (note_id, code, number, trial_id, text, author, written) = row
    return Note(note_id, code, number, trial_id, text, author,
                datetime.datetime.fromisoformat(written))


def _mark_from_row(row: tuple) -> TrialMark:
    (mark_id, trial_id, valid, reason, by, marked) = row
    return TrialMark(mark_id, trial_id, bool(valid), reason, by,
                     datetime.datetime.fromisoformat(marked))
