"""The records' interface: what the rest of app and ui ask of the clinic's records.

`RecordStore` lists the calls app (trials, reports, exports, the command line)
and ui (the window and its tabs) make, and nothing else, so that another store
can take the place of the one SQLite registry of a data folder
(`app.records.registry.Registry`, which implements it): for example one
registry shared by several robot stations in a PostgreSQL database. Such a
store keeps the registry's contract: the same records (`Patient`, `Session`,
`Trial`, …), the same exceptions (app.errors), numbering that two consoles
cannot both take, and trial files under its `data_dir`.

The registry's other calls (changing a patient or session, opening a session by
hand, backup and integrity checks, the schema version) are for maintenance and tests,
and stay the registry's own. Recomputed metrics (`update_metrics`) are the interface's:
an assessment's figures join its trial's metrics (app.assessments.runner); so is the
checksum of a file the console wrote into after its trial (`record_rewritten`,
app.trials.rewrite), and a trial's figures re-computed from its file with their note
(`record_reanalysis`, app.trials.reanalyse).

Code that receives a store types it `RecordStore`; code that opens one (the
command line, the window's start-up) makes a `Registry`.
"""

from __future__ import annotations

import datetime
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Protocol, runtime_checkable

from app.records.assistance import AssistanceInEffect
from app.records.datadir import DataDir
from app.records.registry.clinical import Correction, Note, ScaleEntry, TrialMark
from app.records.registry.patients import Patient
from app.records.registry.plans import PlanRun, PlanStep, StoredPlan
from app.records.registry.proposals import StoredProposal
from app.records.registry.queries import TrialSummary
from app.records.registry.sessions import Session
from app.records.registry.trials import BegunTrial, Registration, Trial
from core.plan import Block, Plan
from core.trial import TrialParameters


@runtime_checkable
class RecordStore(Protocol):
    """Patients, sessions and trials, as `app.records.registry.Registry` keeps them
    (its methods' docstrings say what each call does)."""

    @property
    def data_dir(self) -> DataDir:
        """The data folder the trial files and reports live in."""
        ...

    @property
    def station(self) -> str | None:
        """This console's station id, which its trials record (Trial.station)."""
        ...

    def location(self) -> str: ...

    # -- patients ------------------------------------------------------------------
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
        sex: str | None = None,
        handedness: str | None = None,
    ) -> Patient: ...

    def patient(self, code: str) -> Patient: ...

    def patients(self) -> list[Patient]: ...

    def find_patients(self, first_name: str, last_name: str) -> list[Patient]: ...

    def search_patients(self, text: str, limit: int | None = 50) -> list[Patient]: ...

    # -- sessions and numbering ----------------------------------------------------
    def sessions(self, code: str) -> list[Session]: ...

    def suggest_registration(self, code: str,
                             today: datetime.date | None = None) -> Registration: ...

    def next_trial_number(self, code: str, session_number: int) -> int: ...

    # -- trials --------------------------------------------------------------------
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
    ) -> BegunTrial: ...

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
    ) -> Trial: ...

    def update_metrics(self, trial_id: int, metrics: Mapping[str, float], *,
                       replace: bool = False) -> Trial: ...

    def record_rewritten(self, trial_id: int, checksum: str) -> Trial: ...

    def record_reanalysis(self, trial_id: int, before: Mapping[str, float],
                          metrics: Mapping[str, float], note: str, *, by: str) -> Trial: ...

    def verify_trial_file(self, trial: Trial | int) -> str | None: ...

    def trial(self, trial_id: int) -> Trial: ...

    def trials(self, code: str, session_number: int) -> list[Trial]: ...

    def trials_for_patient(self, code: str) -> list[Trial]: ...

    def unfinished_trials(self) -> list[Trial]: ...

    def interrupt_runs(self) -> list[int]: ...

    def trial_path(self, trial: Trial | int) -> Path: ...

    # -- across trials -------------------------------------------------------------
    def record_stored(self, trial_id: int, store: str) -> Trial: ...

    def trials_to_store(self, station: str | None = None) -> list[Trial]: ...

    def trial_summaries(self, code: str, *, include_invalid: bool = False
                        ) -> list[TrialSummary]: ...

    def withdraw_trial(self, trial_id: int, why: str) -> None: ...

    # -- what the therapist records (schema v8, app.records.registry.clinical) ----------
    def record_scale(self, code: str, session_number: int, scale: str, *, rater: str,
                     total: int | None = None, parts: dict | None = None,
                     items: dict | None = None, grades: dict | None = None) -> ScaleEntry: ...

    def scale_entries(self, code: str, session_number: int | None = None
                      ) -> list[ScaleEntry]: ...

    def session_scales(self, code: str) -> dict[int, dict[str, ScaleEntry]]: ...

    def study_scales(self) -> dict[str, dict[int, dict[str, ScaleEntry]]]: ...

    def add_note(self, code: str, session_number: int, text: str, *, author: str,
                 trial_id: int | None = None) -> Note: ...

    def notes(self, code: str, session_number: int | None = None) -> list[Note]: ...

    def mark_trial(self, trial_id: int, *, valid: bool, reason: str, by: str
                   ) -> TrialMark: ...

    def trial_marks(self, trial_id: int) -> list[TrialMark]: ...

    def invalid_trials(self, code: str | None = None) -> dict[int, TrialMark]: ...

    def correct_patient(self, code: str, field: str, value: object, *, reason: str,
                        by: str) -> Patient: ...

    def corrections(self, code: str) -> list[Correction]: ...

    def session(self, code: str, number: int) -> Session: ...

    # -- session plans (app.plans, ui.window.plan; schema v7) ------------------------
    def save_plan(self, code: str, plan: Plan, *, template: str = "",
                  based_on: int | None = None) -> StoredPlan: ...

    def change_block(self, plan_id: int, index: int, block: Block) -> StoredPlan: ...

    def plan(self, plan_id: int) -> StoredPlan: ...

    def plans_for_patient(self, code: str) -> list[StoredPlan]: ...

    def current_plan(self, code: str) -> StoredPlan | None: ...

    def begin_plan_run(self, plan_id: int) -> int: ...

    def record_plan_trial(self, run_id: int, block: int, round_: int, trial_id: int,
                          planned_s: float) -> PlanStep: ...

    def record_plan_rest(self, run_id: int, block: int, planned_s: float,
                         taken_s: float) -> PlanStep: ...

    def end_plan_run(self, run_id: int, status: str, reason: str = "") -> PlanRun: ...

    def plan_run(self, run_id: int) -> PlanRun: ...

    def plan_runs_for_patient(self, code: str) -> list[PlanRun]: ...

    def plan_step_of_trial(self, trial_id: int) -> tuple[int, PlanStep] | None: ...

    # -- progression (app.trials.progression) --------------------------------------
    def record_proposal(self, trial_id: int, proposal: dict) -> StoredProposal: ...

    def proposal(self, trial_id: int) -> StoredProposal | None: ...

    def proposals_for_patient(self, code: str) -> list[StoredProposal]: ...

    def pending_proposal(self, code: str) -> StoredProposal | None: ...

    def previous_trial(
        self,
        trial_id: int,
        *,
        earlier_session: bool = False,
        same_parameters: bool = False,
        same_shape: bool = False,
        statuses: Iterable[str] = ("complete",),
        include_invalid: bool = False,
    ) -> Trial | None: ...


@runtime_checkable
class StationStore(RecordStore, Protocol):
    """A RecordStore that goes on recording when its shared registry cannot be reached
    (app.records.station.StationRegistry): what the window asks of it besides, and only of
    a store that has it (ui.window.station)."""

    offline_reason: str
    """Why it records on its own ('' while it reaches the server)."""
    sync_problem: str
    """Why its offline records were not sent ('' when nothing stands in the way)."""
    offline_cause: str
    """What keeps it on its own: app.records.station's UNREACHABLE, LOGIN_REFUSED or
    SYNC_REFUSED ('' while it reaches the server)."""
    synced: list
    """What each sync sent (app.records.station.sync.Synced, its `trials` counted), in
    order: one as it opened sent what an earlier session recorded offline."""

    @property
    def offline(self) -> bool: ...

    def try_sync(self) -> object | None: ...

    def keep_current(self) -> None: ...

    def close(self) -> None: ...

