"""The registry's trials: numbering them as the registration tab does, registering one at
Start, recording how it ended at Stop, and listing them.

Registration follows the thesis's registration tab (Appendix A.2): the therapist
gives the patient, a session number and a trial number. The numbers are filled in
(`suggest_registration`) and stay editable: `begin_trial` takes the numbers the
therapist confirmed, continues or opens that session, and refuses a trial number
already used, naming the next free one; `finish_trial` records the status and
metrics at Stop. The UNIQUE constraint on (session, trial number) backs the
numbering up when two consoles register at once.

A trial's row, the `Trial` it is read into and its key parameters are trialrows.py's (kept
importable from here).
"""

from __future__ import annotations

import datetime
import json
import logging
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import sqlalchemy as sa

from app.errors import InvalidRecordError, RegistryError
from app.records.assistance import AssistanceInEffect
from app.records.datadir import TRIALS, DataDir
from app.records.registry.database import Database
from app.records.registry.numbering import refuse_number
from app.records.registry.patients import is_code, patient_id
from app.records.registry.provenance import checked_checksum, file_checksum
from app.records.registry.sessions import (
    Carried,
    open_or_continue,
    session_id_of,
    sessions_for_a_trial,
)
from app.records.registry.statements import execute
from app.records.registry.trialrows import (
    KEY_PARAMETERS,
    TRIAL_RETURNING,
    TRIAL_SELECT,
    Trial,
    assistance_from_json,
    assistance_json,
    key_values,
    parameter_key,
    trial_by_id,
    trial_from_row,
    trials_from_rows,
)
from app.records.registry.values import (
    NAME_MAX_CHARS,
    aware,
    check_number,
    checked_text,
    metrics_json,
    metrics_json_ready,
    parameters_dict,
    utc_now,
    utc_text,
)
from core.trial import TrialParameters
from device.recording.trialfile import STATUS_RECORDING, STATUSES
from device.sim.patient_parameters import PATIENT_KINDS

__all__ = [  # a trial's row and record, read here and by the registry's other modules
    "KEY_PARAMETERS", "STATUS_RECORDING", "TRIAL_RETURNING", "TRIAL_SELECT", "BegunTrial",
    "Registration", "Trial", "Trials", "assistance_from_json", "assistance_json",
    "key_values", "parameter_key", "trial_by_id", "trial_from_row", "trials_from_rows"]

# The registry's one logger, named as it was before the registry had modules.
log = logging.getLogger(__package__)


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


class Trials(Database):
    """Numbering, registering, finishing and listing trials. Trial files live in
    `data_dir` (set by the registry that opens the file)."""

    data_dir: DataDir

    # -- registration ------------------------------------------------------------------
    def suggest_registration(self, code: str, today: datetime.date | None = None) -> Registration:
        """The numbers to pre-fill: the next trial of today's session when the
        patient's latest session is today, else trial 1 of the next session."""
        today = today or datetime.date.today()
        with self._read() as conn:
            return _suggest(conn, code, patient_id(conn, self.where, code), today)

    def next_trial_number(self, code: str, session_number: int) -> int:
        """The next trial number in a session (1 when the session does not exist yet)."""
        with self._read() as conn:
            patient = patient_id(conn, self.where, code)
            row = execute(conn, "SELECT id FROM sessions WHERE patient_id = ? AND number = ?",
                                (patient, session_number)).fetchone()
            return 1 if row is None else _next_trial_number_in(conn, row[0])

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
        one. The patient's next session number opens that session (dated the start's
        local day, with `therapist` and `location`). `trial_number` None: the next in
        the session. A number that is not the next (used, or it would leave a gap)
        raises DuplicateNumberError naming the next free one (numbering.py).
        `patient_kind` names the virtual patient of a simulated trial.
        """
        started_at = aware(started_at or utc_now(), "started_at")
        params = json.dumps(parameters_dict(parameters))  # as stored, and as decided on
        backend = checked_text("backend", backend, NAME_MAX_CHARS)
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
                check_number(name, number)
        # The folder is made outside the transaction: the write lock is held for
        # database work only.
        if is_code(code):
            self.data_dir.ensure(TRIALS, code)
        local_day = started_at.astimezone().date()
        with self._write() as conn:
            # Each statement is a round trip to a server (bench/registration.py): the lock
            # first, on its own (what is read after it is what the station before left);
            # then all the sessions say in one read, which carries the registry's other
            # read at Start (the pending proposal: app.records.registry.proposals), decided
            # after the insert with what it returned.
            patient = patient_id(conn, self.where, code, lock=True)
            latest, asked, read = sessions_for_a_trial(
                conn, patient, session_number, self._read_at_start(patient, params))
            if session_number is None and latest is not None and \
                    latest[2] == local_day.isoformat():
                asked = latest  # today's session goes on
            session_id, session_number, free = open_or_continue(
                conn, code, patient, session_number, latest, asked, local_day, therapist,
                location)
            if trial_number is None:
                trial_number = free
            elif trial_number != free:
                taken = execute(conn,
                    "SELECT started_at FROM trials WHERE session_id = ? AND number = ?",
                    (session_id, trial_number),
                ).fetchone()
                raise refuse_number(
                    "trial", trial_number, free, whose=f"patient {code} session {session_number}",
                    used_on=datetime.datetime.fromisoformat(taken[0]) if taken else None)
            file = self.data_dir.trial_file(code, session_number, trial_number, started_at)
            cursor = execute(conn,
                "INSERT INTO trials (session_id, number, parameters, file, metrics, status, "
                "started_at, backend, patient_kind, station) "
                "VALUES (?, ?, ?, ?, '{}', ?, ?, ?, ?, ?) RETURNING id",
                (session_id, trial_number, params, file, STATUS_RECORDING,
                 utc_text(started_at), backend, patient_kind, self.station),
            )
            trial_id = cursor.scalar_one()
            self._trial_begun(conn, trial_id, params, read)
        log.info("trial %d registered: patient %s session %d trial %d (%s)",
                 trial_id, code, session_number, trial_number, backend)
        return BegunTrial(trial_id, code, session_number, trial_number,
                          self.data_dir.resolve(file), file, started_at)

    def withdraw_trial(self, trial_id: int, why: str) -> None:
        """Take back a trial registered at Start whose file was never written (a headless
        run refused for lack of disk space, say): the registry keeps only trials that
        exist. Refused for a finished trial or one whose file exists."""
        with self._write() as conn:
            trial = trial_by_id(conn, self.where, trial_id, lock=True)
            if trial.finished or self.data_dir.resolve(trial.file).exists():
                raise RegistryError(
                    f"trial {trial_id} has its file or has finished; it stays registered")
            self._trial_withdrawn(conn, trial_id)
            execute(conn, "DELETE FROM trials WHERE id = ?", (trial_id,))
        log.warning("trial %d withdrawn, its file was never written: %s", trial_id, why)

    def _trial_withdrawn(self, conn: sa.Connection, trial_id: int) -> None:
        """Called in withdraw_trial's transaction before the trial's row goes (the
        proposals it decided go back to pending: app.records.registry.proposals)."""

    def _read_at_start(self, patient: int, parameters: str) -> Carried | None:
        """What else begin_trial reads, after the patient's lock and before the trial's
        insert, in its numbering's round trip (sessions.sessions_for_a_trial), given the
        new trial's parameters' JSON as stored; None: nothing. Its rows go to
        `_trial_begun`."""
        return None

    def _trial_begun(self, conn: sa.Connection, trial_id: int, parameters: str,
                     read: list[tuple]) -> None:
        """Called in begin_trial's transaction once the trial is inserted, with its
        parameters' JSON as stored and the rows of `_read_at_start`'s read; the registry's
        proposals decide the patient's pending one here (app.records.registry.proposals)."""

    # -- the end of a trial ------------------------------------------------------------
    def finish_trial(
        self,
        trial_id: int,
        status: str,
        metrics: Mapping[str, float],
        ended_at: datetime.datetime | None = None,
        reason: str = "",
        assistance: AssistanceInEffect | None = None,
        backend: str | None = None,
        checksum: str | None = None,
    ) -> Trial:
        """Record how a trial ended: status one of complete, stopped_early, faulted,
        recording_lost; metrics as computed (NaN allowed); `reason`, why it ended so (a
        fault's message), kept here because the file may not hold it; `assistance`, the
        levels it ran with as its file recorded them (None when the file could not say);
        `backend`, the robot as the file names it (a simulator's seed of this trial), in
        place of the one given at Start (None keeps that); `checksum`, its file's SHA-256
        as finished (provenance.file_checksum; None without a file). A trial is finished
        once."""
        if status not in STATUSES:
            raise InvalidRecordError(
                f"trial status {status!r}: give one of {', '.join(STATUSES)}"
            )
        ended_at = aware(ended_at or utc_now(), "ended_at")
        stored = metrics_json(metrics)
        levels = assistance_json(assistance)
        if backend is not None:
            backend = checked_text("backend", backend, NAME_MAX_CHARS) or None
        checksum = checked_checksum(checksum)
        with self._write() as conn:
            # One statement (a round trip to a server; bench/registration.py): the update
            # of a trial still recording, which returns the row as written. On the server it
            # waits for a station finishing the same trial, then finds it finished.
            row = execute(conn, "UPDATE trials SET status = ?, metrics = ?, ended_at = ?, "
                                "end_reason = ?, assistance = ?, backend = coalesce(?, "
                                "backend), checksum = ? WHERE id = ? AND status = ? "
                                + TRIAL_RETURNING,
                          (status, stored, utc_text(ended_at), str(reason), levels, backend,
                           checksum, trial_id, STATUS_RECORDING)).fetchone()
            if row is None:  # none, or finished: which, in the registry's words
                trial = trial_by_id(conn, self.where, trial_id)
                raise RegistryError(
                    f"trial {trial_id} was already finished ({trial.status} at "
                    f"{trial.ended_at}); use update_metrics to store recomputed metrics"
                )
            trial = trial_from_row(row)
            if ended_at < trial.started_at:  # raised in the transaction: nothing is kept
                raise InvalidRecordError(
                    f"trial {trial_id} would end at {ended_at.isoformat()}, before it started "
                    f"({trial.started_at.isoformat()}): check the computer's clock"
                )
        log.info("trial %d finished: %s, %d metric(s)%s", trial_id, status, len(trial.metrics),
                 f" ({reason})" if reason else "")
        return trial

    def update_metrics(self, trial_id: int, metrics: Mapping[str, float], *,
                       replace: bool = False) -> Trial:
        """Store recomputed metrics: merged into the trial's (or replacing them all)."""
        checked = json.loads(metrics_json(metrics))
        with self._write() as conn:
            trial = trial_by_id(conn, self.where, trial_id, lock=True)
            merged = checked if replace else {**metrics_json_ready(trial.metrics), **checked}
            execute(conn, "UPDATE trials SET metrics = ? WHERE id = ?",
                          (json.dumps(merged, allow_nan=False), trial_id))
            return trial_by_id(conn, self.where, trial_id)

    # -- reading -----------------------------------------------------------------------
    def trial(self, trial_id: int) -> Trial:
        with self._read() as conn:
            return trial_by_id(conn, self.where, trial_id)

    def trials(self, code: str, session_number: int) -> list[Trial]:
        """The trials of one session, by number."""
        with self._read() as conn:
            session_id = session_id_of(conn, self.where, code, session_number)
            rows = execute(conn, TRIAL_SELECT + " WHERE t.session_id = ? ORDER BY t.number",
                                 (session_id,)).fetchall()
        return trials_from_rows(rows)

    def unfinished_trials(self) -> list[Trial]:
        """This station's trials still recording, oldest first (after a console's crash,
        those `app.trials.finalize.finish_interrupted` finishes). Another station's are its
        own: it may be recording them now, into files this console cannot see. A trial
        recorded before stations (none) counts as this one's."""
        with self._read() as conn:
            rows = execute(conn, TRIAL_SELECT + " WHERE t.status = 'recording' AND "
                                 "(t.station = ? OR t.station IS NULL) ORDER BY t.id",
                                 (self.station,)).fetchall()
        return trials_from_rows(rows)

    def trials_for_patient(self, code: str) -> list[Trial]:
        """Every trial of a patient, by session number then trial number."""
        with self._read() as conn:
            patient = patient_id(conn, self.where, code)
            rows = execute(conn,
                TRIAL_SELECT + " WHERE s.patient_id = ? ORDER BY s.number, t.number",
                (patient,),
            ).fetchall()
        return trials_from_rows(rows)

    def verify_trial_file(self, trial: Trial | int) -> str | None:
        """Why the trial's file is not the one recorded, None when it is (its SHA-256 is the
        checksum kept at its end, in the data folder and in the shared trial store when it
        was copied there) or when no checksum was kept (before schema v10, a trial not
        finished or without a file)."""
        if not isinstance(trial, Trial):
            trial = self.trial(trial)
        if trial.checksum is None:
            return None
        places = [(self.data_dir.resolve(trial.file), "the trial store or a backup")]
        if trial.stored_in is not None:  # its copy in the shared trial store (schema v11)
            places.append((Path(trial.stored_in, trial.file), "the station's data folder"))
        for path, restore_from in places:
            try:
                found = file_checksum(path)
            except OSError as exc:
                return f"trial {trial.id}'s file {path} cannot be read ({exc.strerror or exc})"
            if found != trial.checksum:
                return (f"trial {trial.id}'s file {path} is not the one recorded: its SHA-256 "
                        f"is {found[:12]}…, the registry's {trial.checksum[:12]}… (changed or "
                        f"replaced since it was finished): restore it from {restore_from}")
        return None

    def trial_path(self, trial: Trial | int) -> Path:
        """The absolute path of a trial's file (which may be missing)."""
        if not isinstance(trial, Trial):
            trial = self.trial(trial)
        return self.data_dir.resolve(trial.file)


# -- numbering -------------------------------------------------------------------------
def _next_trial_number_in(conn: sa.Connection, session_id: int) -> int:
    row = execute(conn, "SELECT max(number) FROM trials WHERE session_id = ?",
                        (session_id,)).fetchone()
    return (row[0] or 0) + 1


def _suggest(conn: sa.Connection, code: str, patient: int,
             today: datetime.date) -> Registration:
    latest, _, _ = sessions_for_a_trial(conn, patient, None)
    if latest is not None and latest[2] == today.isoformat():
        return Registration(code, latest[1], latest[3], False)
    return Registration(code, 1 if latest is None else latest[1] + 1, 1, True)
