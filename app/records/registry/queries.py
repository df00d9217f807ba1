"""Questions across a patient's trials: the progress rows (`trial_summaries`) and the
trial to compare a new one with (`previous_trial`).

The progress query reads one patient's trials through the two UNIQUE indexes in
order, with no sort, reads the few key parameters once per distinct parameter text,
and parses all the rows' metrics in one json.loads (bench/registry.py measures it on
SQLite, bench/stations.py on PostgreSQL).
"""

from __future__ import annotations

import datetime
import gc
import json
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from app.errors import InvalidRecordError
from app.records.assistance import AssistanceInEffect
from app.records.registry.clinical import INVALID_MARKS, LATEST_MARK
from app.records.registry.database import Database
from app.records.registry.patients import patient_id
from app.records.registry.statements import execute
from app.records.registry.trials import (
    TRIAL_SELECT,
    Trial,
    assistance_from_json,
    key_values,
    trial_by_id,
    trial_from_row,
)
from app.records.registry.values import parse_metrics
from device.recording.trialfile import STATUS_RECORDING, STATUSES

_ALL_STATUSES = (STATUS_RECORDING, *STATUSES)

# The parameters come as their stored text and are parsed once per distinct text: most
# trials share a few parameter sets. Having the engine extract the key parameters
# (json_extract, `::jsonb ->`) parses every row's text once per parameter: on PostgreSQL
# that was 85 ms of the server's 87 for a patient's 1,000 trials (bench/stations.py), and
# parsing each row's whole object in Python was a fifth of the query's time on SQLite.
_SUMMARY_SELECT = """
    SELECT t.id, s.number, s.date, t.number, t.status, t.started_at, t.file,
           t.parameters, t.assistance, t.station, t.stored_in, t.checksum, t.metrics
    FROM trials t
    JOIN sessions s ON s.id = t.session_id
    WHERE s.patient_id = ?
    ORDER BY s.number, t.number
"""


def _key_parameters(text: str) -> tuple[tuple, str]:
    """KEY_PARAMETERS as stored (None where absent), and the assistance mode ("thesis"
    where absent), from a trial's parameters text."""
    parameters = json.loads(text)
    assist = parameters.get("assist")
    return key_values(parameters), "thesis" if assist is None else assist


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
    assist: str = "thesis"
    """The assistance mode (parameters' `assist`; "thesis" for trials before the modes)."""
    assistance: AssistanceInEffect | None = None
    """The levels the trial ran with (Trial.assistance); None when only the built level,
    in `key_parameters`, is known."""
    invalid_reason: str | None = None
    """Why the trial was marked invalid (its latest mark, schema v8); None when valid."""
    station: str | None = None
    """The station that recorded it (Trial.station, schema v10); None before."""
    stored_in: str | None = None
    """The shared trial store holding its proven copy (Trial.stored_in, schema v11): the
    file is at `file` below it; None when not copied (yet)."""
    checksum: str | None = None
    """Its file's SHA-256 as finished (Trial.checksum, schema v10); None before it finished,
    without a file, or before v10."""


def _summaries(rows: list, invalid: dict[int, str]) -> list[TrialSummary]:
    """The progress rows from _SUMMARY_SELECT's rows and the invalid marks by trial id."""
    metrics = parse_metrics(row[-1] for row in rows)
    date = datetime.date.fromisoformat
    moment = datetime.datetime.fromisoformat
    # Most trials share a few parameter sets: each text parsed once, and one tuple per
    # set, not per trial, keeps fewer objects alive for the garbage collector to walk.
    keys: dict[str, tuple] = {}
    out = []
    for r, values in zip(rows, metrics, strict=True):
        found = keys.get(r[7])
        if found is None:
            found = keys[r[7]] = _key_parameters(r[7])
        out.append(TrialSummary(r[0], r[1], date(r[2]), r[3], r[4], moment(r[5]), r[6],
                                found[0], values, found[1], assistance_from_json(r[8]),
                                invalid.get(r[0]), r[9], r[10], r[11]))
    return out


@contextmanager
def _collector_paused() -> Iterator[None]:
    """No garbage collection while the progress rows are read and built.

    Reading and building them makes some 4,000 container objects (a row, a dict of
    metrics and a summary per trial, none in a cycle), enough to start the collector's
    full pass over every live object of the process: 35-70 ms in a console or a bench
    holding a few hundred thousand, which set the query's p99 (bench/stations.py: CPU p50
    21 ms, p99 80-90 ms). Nothing made here needs collecting; the collector resumes as it
    was (a caller may have paused it) and counts these objects at its next pass."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


class Queries(Database):
    """Reading across a patient's trials."""

    def trial_summaries(self, code: str, *, include_invalid: bool = False
                        ) -> list[TrialSummary]:
        """Every trial of a patient, by session then trial number, without the full
        parameters: the progress query (about half the cost of trials_for_patient).
        Trials marked invalid (app.records.registry.clinical) are left out unless
        `include_invalid`; then their `invalid_reason` says why."""
        with _collector_paused(), self._read() as conn:
            rows = execute(conn, _SUMMARY_SELECT, (patient_id(conn, self.where, code),)
                                 ).fetchall()
            # the marks are few: read apart and looked up, the query costs what it did
            # before schema v8 (a subquery per trial added a third to it)
            invalid = dict(execute(conn, INVALID_MARKS).fetchall())
            if invalid and not include_invalid:
                rows = [r for r in rows if r[0] not in invalid]
            return _summaries(rows, invalid) if rows else []

    def previous_trial(
        self,
        trial_id: int,
        *,
        earlier_session: bool = False,
        same_parameters: bool = False,
        same_shape: bool = False,
        statuses: Iterable[str] = ("complete",),
        include_invalid: bool = False,
    ) -> Trial | None:
        """The patient's latest trial before this one, to report the change since.

        earlier_session: only trials of earlier sessions (change since the last session).
        same_parameters: only trials done at the same KEY_PARAMETERS, where the
            metrics compare directly.
        same_shape: only trials of the same exercise shape (a D with a D, not with a
            circle done in between), which is what a report compares.
        statuses: the statuses that count (by default complete trials only).
        include_invalid: trials marked invalid count too (by default they do not).
        """
        statuses = tuple(statuses)
        unknown = sorted(set(statuses) - set(_ALL_STATUSES))
        if unknown:
            raise InvalidRecordError(
                f"status(es) {', '.join(unknown)}: give any of {', '.join(_ALL_STATUSES)}"
            )
        with self._read() as conn:
            trial = trial_by_id(conn, self.where, trial_id)
            patient = patient_id(conn, self.where, trial.patient_code)
            if earlier_session:
                before = "s.number < ?"
                args: tuple = (trial.session_number,)
            else:
                before = "(s.number < ? OR (s.number = ? AND t.number < ?))"
                args = (trial.session_number, trial.session_number, trial.number)
            marks = ", ".join("?" * len(statuses)) or "NULL"
            rows = execute(conn,
                TRIAL_SELECT + f" WHERE s.patient_id = ? AND {before} AND t.status IN ({marks})"
                + ("" if include_invalid else f" AND {LATEST_MARK} IS NULL")
                +
                " ORDER BY s.number DESC, t.number DESC",
                (patient, *args, *statuses),
            )
            key = trial.key_parameters()
            for row in rows:
                candidate = trial_from_row(row)
                if same_parameters and candidate.key_parameters() != key:
                    continue
                if same_shape and (candidate.parameters.get("shape")
                                   != trial.parameters.get("shape")):
                    continue
                return candidate
        return None
