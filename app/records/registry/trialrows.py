"""A trial as the registry reads it: its row (TRIAL_SELECT, and TRIAL_RETURNING for the row an
UPDATE wrote), the `Trial` it is read into, its key parameters (which trials compare) and
its assistance levels as stored. Registering, finishing and listing trials is trials.py's;
the queries, the proposals, the trial store and the clinical record read trials with these.
"""

from __future__ import annotations

import datetime
import json
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import sqlalchemy as sa

from app.errors import InvalidRecordError, TrialNotFound
from app.records.assistance import AssistanceInEffect
from app.records.registry.statements import execute
from app.records.registry.values import parse_metrics
from core.trial import TrialParameters
from device.recording.trialfile import STATUS_RECORDING

KEY_PARAMETERS = ("shape", "radius_m", "duration_s", "tolerance_rad", "assistance_level",
                  "controller", "assessment", "game")
"""The parameters that change what a trial's metrics mean: compare trials done at
equal values of these (progress, previous_trial(same_parameters=True)). An assessment
task's run or a game is never compared with the plain exercise of the same shape: its
protocol, or what the patient was asked to do, is another."""

_KEY_DEFAULTS = {"assessment": "", "game": ""}
"""What a trial stored before a key parameter existed ran: no assessment, no game
(core.trial.TrialParameters' defaults), so it stays comparable with the trials after."""


def key_values(parameters) -> tuple:
    """A trial's KEY_PARAMETERS values as stored (None where absent, the default where the
    parameter came later), in that order; parameter_key makes them comparable."""
    return tuple(parameters.get(name, _KEY_DEFAULTS.get(name)) for name in KEY_PARAMETERS)

TRIAL_SELECT = """
    SELECT t.id, p.code, s.number, s.date, t.number, t.parameters, t.file, t.metrics,
           t.status, t.started_at, t.ended_at, t.backend, t.patient_kind, t.end_reason,
           t.assistance, t.station, t.checksum, t.stored_in
    FROM trials t
    JOIN sessions s ON s.id = t.session_id
    JOIN patients p ON p.id = s.patient_id
"""
"""A trial row as `trial_from_row` and `trials_from_rows` read it; add WHERE and ORDER BY."""

TRIAL_RETURNING = """
    RETURNING id,
        (SELECT p.code FROM sessions s JOIN patients p ON p.id = s.patient_id
         WHERE s.id = trials.session_id),
        (SELECT s.number FROM sessions s WHERE s.id = trials.session_id),
        (SELECT s.date FROM sessions s WHERE s.id = trials.session_id),
        number, parameters, file, metrics, status, started_at, ended_at, backend,
        patient_kind, end_reason, assistance, station, checksum, stored_in
"""
"""TRIAL_SELECT's row, of the trial an UPDATE wrote (after `UPDATE trials … WHERE …`): the
row as written, without reading it again (a round trip to a server). Its session's and
patient's columns by subqueries, which both engines allow in RETURNING (a join does not:
SQLite's RETURNING names the changed table only)."""


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
    end_reason: str = ""
    """Why the trial ended so (a fault's message, a lost recording's cause); '' when it
    ended normally or was registered before schema v4."""
    assistance: AssistanceInEffect | None = None
    """The assistance levels the trial ran with, read from its file when it was finished
    (start, end, each live change with its time); None before it finished, for a trial
    registered before schema v5 or whose file could not be read: then only its built
    level (`parameters`) is known."""
    station: str | None = None
    """The station that recorded it (app.records.registry.provenance); None before v10."""
    checksum: str | None = None
    """The SHA-256 of its file as it was finished; None before it finished, without a file,
    or before v10."""
    stored_in: str | None = None
    """The shared trial store's folder its file was copied to and proven whole in, at the
    same relative path (app.records.registry.stores); None while it is only in the data
    folder."""

    @property
    def finished(self) -> bool:
        return self.status != STATUS_RECORDING

    @property
    def assist(self) -> str:
        """The assistance mode it ran (set at Build, never changed during a trial);
        "thesis" for trials recorded before the modes existed, which is what they ran."""
        return str(self.parameters.get("assist", "thesis"))

    def key_parameters(self) -> tuple:
        """KEY_PARAMETERS values, comparable between trials (see parameter_key)."""
        return parameter_key(key_values(self.parameters))

    def trial_parameters(self) -> TrialParameters:
        """The parameters as a validated TrialParameters (raises CoreError if they no
        longer validate, e.g. a range narrowed since the trial was run)."""
        return TrialParameters.from_dict(self.parameters)


def parameter_key(values: Iterable) -> tuple:
    """Parameter values made comparable: floats to 9 significant digits, so that
    one exercise reached through different unit conversions is one exercise."""
    return tuple(
        float(f"{v:.9g}") if isinstance(v, float) and math.isfinite(v) else v for v in values
    )


def trial_by_id(conn: sa.Connection, registry: Path | str, trial_id: int, *,
                lock: bool = False) -> Trial:
    """The trial with this id; TrialNotFound naming the registry file if none. `lock`: the
    transaction changes it after reading it, so on the server its row is locked first
    (two stations finishing or marking one trial take turns; SQLite's BEGIN IMMEDIATE
    already does)."""
    if lock:
        execute(conn, "SELECT id FROM trials WHERE id = ? FOR NO KEY UPDATE", (trial_id,))
    row = execute(conn, TRIAL_SELECT + " WHERE t.id = ?", (trial_id,)).fetchone()
    if row is None:
        raise TrialNotFound(
            f"no trial has the id {trial_id!r} in the registry {registry}; list the "
            "patient's trials to find it"
        )
    return trial_from_row(row)


def trial_from_row(row: tuple) -> Trial:
    return trials_from_rows([row])[0]


def trials_from_rows(rows: list[tuple]) -> list[Trial]:
    """TRIAL_SELECT rows as Trials."""
    # One json.loads over all rows instead of two per row: listing a patient's
    # trials costs mostly JSON parsing, and this removes the per-call overhead.
    if not rows:
        return []
    parameters = json.loads("[" + ",".join(r[5] for r in rows) + "]")
    metrics = parse_metrics(r[7] for r in rows)
    trials = []
    for row, params, values in zip(rows, parameters, metrics, strict=True):
        (trial_id, code, session_number, session_date, number, _, file, _, status,
         started_at, ended_at, backend, patient_kind, end_reason, levels, station,
         checksum, stored_in) = row
        trials.append(Trial(
            trial_id, code, session_number, datetime.date.fromisoformat(session_date), number,
            params, file, values, status, datetime.datetime.fromisoformat(started_at),
            None if ended_at is None else datetime.datetime.fromisoformat(ended_at),
            backend, patient_kind, end_reason, assistance_from_json(levels), station,
            checksum, stored_in,
        ))
    return trials


def assistance_json(assistance: AssistanceInEffect | None) -> str | None:
    """The levels a trial ran with as stored (None: not known)."""
    if assistance is None:
        return None
    if not isinstance(assistance, AssistanceInEffect):
        raise InvalidRecordError("assistance: give an app.records.assistance."
                                 "AssistanceInEffect, or None when the file could not say")
    values = assistance.to_dict()
    AssistanceInEffect.from_dict(values)  # refuses levels out of 0-1, NaN
    return json.dumps(values, allow_nan=False)


def assistance_from_json(text: str | None) -> AssistanceInEffect | None:
    return None if text is None else AssistanceInEffect.from_dict(json.loads(text))
