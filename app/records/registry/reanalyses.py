"""A finished trial's figures re-computed from its file (app.trials.reanalyse, `rehab
reanalyse`), stored with their record: the new metrics and a note on the trial saying which
analysis made them, when, by whom, and what each changed figure was before, in one
transaction (both or neither).

Why a note: the notes are the registry's append-only, sealed record of what was said of a
trial (schema v8, app.records.registry.clinical), on both engines, and what a reader of
the trial (the window's clinical record, the session report) already shows beside it; the
figures' history then needs no schema of its own. The trial's validity marks and its file
are left as they are.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from app.errors import InvalidRecordError, RegistryError
from app.records.registry.database import Database
from app.records.registry.statements import execute
from app.records.registry.trials import Trial, trial_by_id
from app.records.registry.values import (
    NAME_MAX_CHARS,
    TEXT_MAX_CHARS,
    checked_text,
    metrics_json,
    utc_now,
    utc_text,
)
from device.recording.trialfile import STATUS_RECORDING


def same_metrics(a: Mapping[str, float], b: Mapping[str, float]) -> bool:
    """Whether two sets of metrics hold the same figures (NaN equal to NaN)."""
    return a.keys() == b.keys() and all(
        a[k] == b[k] or (math.isnan(a[k]) and math.isnan(b[k])) for k in a)


class Reanalyses(Database):
    """Storing a trial's re-computed figures with their record."""

    def record_reanalysis(self, trial_id: int, before: Mapping[str, float],
                          metrics: Mapping[str, float], note: str, *, by: str) -> Trial:
        """Replace trial `trial_id`'s metrics by `metrics` and add `note` (by `by`) on the
        trial, in one transaction. Refused (nothing stored) when the trial is still
        recording or its metrics are no longer `before` (changed meanwhile, by another
        station or an assessment's figures: analyse it again)."""
        stored = metrics_json(metrics)
        note = checked_text("note", note, TEXT_MAX_CHARS)
        by = checked_text("by", by, NAME_MAX_CHARS)
        if not note or not by:
            raise InvalidRecordError("a re-analysis is recorded with a note and who ran it")
        with self._write() as conn:
            trial = trial_by_id(conn, self.where, trial_id, lock=True)
            if trial.status == STATUS_RECORDING:
                raise RegistryError(f"trial {trial_id} is still recording; its figures are "
                                    "computed when it ends")
            if not same_metrics(trial.metrics, before):
                raise RegistryError(f"trial {trial_id}'s figures changed while it was "
                                    "re-analysed; nothing was stored: run it again")
            execute(conn, "UPDATE trials SET metrics = ? WHERE id = ?", (stored, trial_id))
            execute(conn,
                    "INSERT INTO notes (session_id, trial_id, text, author, written_at) "
                    "SELECT session_id, id, ?, ?, ? FROM trials WHERE id = ?",
                    (note, by, utc_text(utc_now()), trial_id))
            return trial_by_id(conn, self.where, trial_id)
