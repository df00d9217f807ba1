"""What each trial ran and what followed it, as flat columns for researchers: the
assistance mode, the levels in effect (from the trial's file: at the exercise's start, at
its end and each live change), the proposal made after it and what the therapist did with
it, and why it ended so. The same columns in `trials.csv` of an export (app.exports),
`rehab trials` and `rehab progress --csv` (app.cli).

Levels are 0–1 and times in s from the exercise's start (app.records.assistance); a value
not known is None (an empty cell): the levels of a trial registered before the registry
kept them (schema v5) or not finished, the proposal of a trial outside the registry.
"""

from __future__ import annotations

import json
from collections.abc import Mapping

from app.records.assistance import AssistanceInEffect
from app.records.registry.proposals import StoredProposal
from app.records.registry.trials import Trial
from app.records.store import RecordStore

OUTCOME_COLUMNS = (
    "assistance_mode", "assistance_level_built", "assistance_level_start",
    "assistance_level_end", "assistance_changes", "proposal_change",
    "proposal_assistance_level", "proposal_duration_s", "proposal_tolerance_rad",
    "proposal_decision", "proposal_reason", "end_reason",
)
"""The columns, in order. `assistance_changes` is JSON, [[time_s, level], …] ([] when the
level did not change); `proposal_decision` is pending, accepted, kept or changed
(app.records.registry.proposals)."""


def level_columns(assist: str, built: float | None,
                  ran: AssistanceInEffect | None) -> dict:
    """The mode and the levels: as built, and as they ran when known."""
    return {
        "assistance_mode": assist,
        "assistance_level_built": built,
        "assistance_level_start": None if ran is None else ran.at_start,
        "assistance_level_end": None if ran is None else ran.at_end,
        "assistance_changes": None if ran is None else json.dumps(
            [[t, level] for t, level in ran.changes]),
    }


def proposal_columns(stored: StoredProposal | None) -> dict:
    """The proposal made after the trial, and the decision on it (None: none made)."""
    values: Mapping = {} if stored is None else stored.proposal
    return {
        "proposal_change": values.get("change"),
        "proposal_assistance_level": values.get("assistance_level"),
        "proposal_duration_s": values.get("duration_s"),
        "proposal_tolerance_rad": values.get("tolerance_rad"),
        "proposal_decision": None if stored is None else stored.decision,
        "proposal_reason": values.get("reason"),
    }


def trial_outcome(trial: Trial, stored: StoredProposal | None) -> dict:
    """OUTCOME_COLUMNS of a registered trial, from the registry."""
    built = trial.parameters.get("assistance_level")
    return {**level_columns(trial.assist, None if built is None else float(built),
                            trial.assistance),
            **proposal_columns(stored), "end_reason": trial.end_reason}


def patient_outcomes(store: RecordStore, code: str) -> dict[int, dict]:
    """OUTCOME_COLUMNS of each of a patient's trials, by trial id."""
    proposals = {p.trial_id: p for p in store.proposals_for_patient(code)}
    return {t.id: trial_outcome(t, proposals.get(t.id))
            for t in store.trials_for_patient(code)}
