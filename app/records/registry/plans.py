"""The registry's session plans (schema v7): each patient's plans, and what each run of a
plan did.

* `plans`: a plan (core.plan.Plan as JSON) for a patient. Plans are never changed in
  place: a change for the day (`change_block`) saves a new row naming the one it
  changed (`based_on`), so every trial's plan is the plan it ran. The patient's plan
  for today is their latest (`current_plan`). `template` names the built-in template
  the first copy came from (app.plans.templates).
* `plan_runs`: one run of a plan (the therapist's first Start to its end): its status
  (`running` until it ends: complete, stopped, emergency_stop, faulted; a run a crashed
  console left running reads `interrupted` once `interrupt_runs` has seen it) and why.
* `plan_steps`: what the run did in order, step 1, 2, …: each trial (block and round,
  linked to the trial's row; its planned active time) and each rest (planned and taken,
  s). The movements and active time are the trial files' (app.plans.dose).

Every row is read back through Plan.from_dict: a plan the console cannot run is refused
in one line naming it, never loaded half.
"""

from __future__ import annotations

import datetime
import json
from dataclasses import dataclass

import sqlalchemy as sa

from app.errors import InvalidRecordError, RegistryError
from app.records.registry.database import Database
from app.records.registry.patients import patient_id
from app.records.registry.statements import execute
from app.records.registry.trials import trial_by_id
from app.records.registry.values import NAME_MAX_CHARS, checked_text, utc_now, utc_text
from core.errors import CoreError
from core.plan import Block, Plan

RUN_STATUSES = ("running", "complete", "stopped", "emergency_stop", "faulted", "interrupted")
RUN_ENDS = RUN_STATUSES[1:5]
"""How a run may end (`interrupted` is the registry's word for a run nobody ended)."""
STEP_KINDS = ("trial", "rest")


@dataclass(frozen=True, slots=True)
class StoredPlan:
    """A plan as the registry keeps it."""

    id: int
    patient_code: str
    plan: Plan
    template: str
    based_on: int | None
    created_at: datetime.datetime


@dataclass(frozen=True, slots=True)
class PlanStep:
    """One step of a run: a block's round (its trial) or the rest after a block."""

    step: int
    block: int
    """1-based, as the therapist reads it."""
    round: int
    kind: str
    trial_id: int | None
    planned_s: float
    """A trial: the round's planned active time; a rest: its planned length."""
    taken_s: float | None
    """A rest: how long it lasted (s, cut short by a Stop); None for a trial."""


@dataclass(frozen=True, slots=True)
class PlanRun:
    """A run of a plan and its steps."""

    id: int
    plan_id: int
    patient_code: str
    started_at: datetime.datetime
    ended_at: datetime.datetime | None
    status: str
    end_reason: str
    steps: tuple[PlanStep, ...]
    station: str | None = None
    """The station that ran it (app.records.registry.provenance); None before v10."""

    def trial_steps(self) -> tuple[PlanStep, ...]:
        return tuple(s for s in self.steps if s.kind == "trial")


class Plans(Database):
    """Saving a patient's plans and recording their runs. Comes before Proposals in the
    registry's bases: its `_trial_withdrawn` runs first and passes on."""

    # -- plans --------------------------------------------------------------------------
    def save_plan(self, code: str, plan: Plan, *, template: str = "",
                  based_on: int | None = None) -> StoredPlan:
        """Keep `plan` for patient `code` (a new row); `based_on`, the patient's plan it
        changes; `template`, the template it was copied from."""
        if not isinstance(plan, Plan):
            raise InvalidRecordError(f"plan: give a core.plan.Plan, not {type(plan).__name__}")
        template = checked_text("template", template, NAME_MAX_CHARS)
        text = json.dumps(plan.to_dict(), allow_nan=False, sort_keys=True)
        with self._write() as conn:
            patient = patient_id(conn, self.where, code)
            if based_on is not None:
                row = execute(conn, "SELECT patient_id, template FROM plans WHERE id = ?",
                                    (based_on,)).fetchone()
                if row is None or row[0] != patient:
                    raise InvalidRecordError(f"plan {based_on} is not a plan of patient {code}")
                template = template or row[1]
            cursor = execute(conn,
                "INSERT INTO plans (patient_id, name, plan, template, based_on, created_at) "
                "VALUES (?, ?, ?, ?, ?, ?) RETURNING id",
                (patient, plan.name, text, template, based_on, utc_text(utc_now())))
            return _plan_by_id(conn, self.where, cursor.scalar_one())

    def change_block(self, plan_id: int, index: int, block: Block) -> StoredPlan:
        """Today's change: the plan `plan_id` with block `index` (0-based) replaced, saved
        as a new plan of the same patient based on it."""
        stored = self.plan(plan_id)
        try:
            changed = stored.plan.with_block(index, block)
        except CoreError as exc:
            raise InvalidRecordError(f"plan {plan_id}: {exc}") from None
        return self.save_plan(stored.patient_code, changed, based_on=plan_id)

    def plan(self, plan_id: int) -> StoredPlan:
        with self._read() as conn:
            return _plan_by_id(conn, self.where, plan_id)

    def plans_for_patient(self, code: str) -> list[StoredPlan]:
        with self._read() as conn:
            pid = patient_id(conn, self.where, code)
            rows = execute(conn, _PLAN_SELECT + " WHERE pl.patient_id = ? ORDER BY pl.id",
                                 (pid,)).fetchall()
        return [_plan_from_row(r, self.where) for r in rows]

    def current_plan(self, code: str) -> StoredPlan | None:
        """The patient's latest plan (today's, once changed for today), None if none."""
        plans = self.plans_for_patient(code)
        return plans[-1] if plans else None

    # -- runs ---------------------------------------------------------------------------
    def begin_plan_run(self, plan_id: int) -> int:
        """A run of plan `plan_id` begins (status running); its id."""
        with self._write() as conn:
            _plan_by_id(conn, self.where, plan_id)
            cursor = execute(conn, "INSERT INTO plan_runs (plan_id, started_at, status, "
                                   "station) VALUES (?, ?, 'running', ?) RETURNING id",
                                   (plan_id, utc_text(utc_now()), self.station))
            return cursor.scalar_one()

    def record_plan_trial(self, run_id: int, block: int, round_: int, trial_id: int,
                          planned_s: float) -> PlanStep:
        """The run's next step: block `block`'s round `round_` (1-based) is trial
        `trial_id`, planned to exercise `planned_s` (also after the run's end: a trial the
        loop started as the run ended belongs to it)."""
        return self._step(run_id, block, round_, "trial", trial_id, planned_s, None)

    def record_plan_rest(self, run_id: int, block: int, planned_s: float,
                         taken_s: float) -> PlanStep:
        """The run's next step: the rest after block `block`, planned and taken (s)."""
        return self._step(run_id, block, 1, "rest", None, planned_s, taken_s)

    def _step(self, run_id, block, round_, kind, trial_id, planned_s, taken_s) -> PlanStep:
        for name, value in (("planned_s", planned_s), ("taken_s", taken_s)):
            if value is not None and (isinstance(value, bool) or not isinstance(
                    value, int | float) or not 0.0 <= value < 1e6):
                raise InvalidRecordError(f"{name} {value!r}: give seconds from 0")
        with self._write() as conn:
            run = _run_row(conn, self.where, run_id)
            if run[5] != "running" and kind != "trial":
                # a trial the loop started as the run ended (a Stop pressed while it was
                # starting) still belongs to it; nothing else comes after its end
                raise RegistryError(f"plan run {run_id} has ended ({run[5]}); it takes no "
                                    "more steps")
            plan = _plan_by_id(conn, self.where, run[1]).plan
            if not isinstance(block, int) or not 1 <= block <= len(plan.blocks):
                raise InvalidRecordError(f"block {block!r}: plan {run[1]} has blocks 1–"
                                         f"{len(plan.blocks)}")
            if trial_id is not None:
                trial_by_id(conn, self.where, trial_id)
            step = execute(conn, "SELECT coalesce(max(step), 0) + 1 FROM plan_steps WHERE "
                                 "run_id = ?", (run_id,)).fetchone()[0]
            execute(conn, "INSERT INTO plan_steps (run_id, step, block, round, kind, trial_id, "
                          "planned_s, taken_s) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                          (run_id, step, block, round_, kind, trial_id, float(planned_s),
                          None if taken_s is None else float(taken_s)))
        return PlanStep(step, block, round_, kind, trial_id, float(planned_s),
                        None if taken_s is None else float(taken_s))

    def end_plan_run(self, run_id: int, status: str, reason: str = "") -> PlanRun:
        """The run ended: `status` one of RUN_ENDS, `reason` why (a fault's words)."""
        if status not in RUN_ENDS:
            raise InvalidRecordError(f"plan run status {status!r}: give one of "
                                     f"{', '.join(RUN_ENDS)}")
        reason = checked_text("reason", reason, 2000)
        with self._write() as conn:
            run = _run_row(conn, self.where, run_id)
            if run[5] != "running":
                raise RegistryError(f"plan run {run_id} already ended ({run[5]})")
            execute(conn, "UPDATE plan_runs SET status = ?, end_reason = ?, ended_at = ? "
                          "WHERE id = ?", (status, reason, utc_text(utc_now()), run_id))
        return self.plan_run(run_id)

    def interrupt_runs(self) -> list[int]:
        """This station's runs still 'running' (its console crashed or was killed during
        a plan), marked interrupted; their ids. The console calls it at its start, when no
        run of its own can be going; another station's runs, which may be going, are left
        as they are (a run recorded before stations, with none, counts as this one's)."""
        with self._write() as conn:
            ids = [r[0] for r in execute(conn,
                "SELECT id FROM plan_runs WHERE status = 'running' "
                "AND (station = ? OR station IS NULL) ORDER BY id FOR UPDATE",
                (self.station,)).fetchall()]
            for run_id in ids:
                execute(conn, "UPDATE plan_runs SET status = 'interrupted', ended_at = ?, "
                              "end_reason = 'the console ended during the plan' "
                              "WHERE id = ?", (utc_text(utc_now()), run_id))
        return ids

    def plan_run(self, run_id: int) -> PlanRun:
        with self._read() as conn:
            return _run(conn, self.where, run_id)

    def plan_runs_for_patient(self, code: str) -> list[PlanRun]:
        with self._read() as conn:
            pid = patient_id(conn, self.where, code)
            ids = [r[0] for r in execute(conn,
                "SELECT r.id FROM plan_runs r JOIN plans pl ON pl.id = r.plan_id WHERE "
                "pl.patient_id = ? ORDER BY r.id", (pid,)).fetchall()]
            return [_run(conn, self.where, i) for i in ids]

    def plan_step_of_trial(self, trial_id: int) -> tuple[int, PlanStep] | None:
        """(run id, step) of the plan run trial `trial_id` belongs to, None if none."""
        with self._read() as conn:
            row = execute(conn, _STEP_SELECT + " WHERE trial_id = ?", (trial_id,)).fetchone()
        return None if row is None else (row[0], _step_from_row(row[1:]))

    def _trial_withdrawn(self, conn: sa.Connection, trial_id: int) -> None:
        """A withdrawn trial never ran: its step goes with it."""
        execute(conn, "DELETE FROM plan_steps WHERE trial_id = ?", (trial_id,))
        super()._trial_withdrawn(conn, trial_id)


_PLAN_SELECT = ("SELECT pl.id, p.code, pl.plan, pl.template, pl.based_on, pl.created_at "
                "FROM plans pl JOIN patients p ON p.id = pl.patient_id")
_STEP_SELECT = ("SELECT run_id, step, block, round, kind, trial_id, planned_s, taken_s "
                "FROM plan_steps")


def _plan_by_id(conn: sa.Connection, registry, plan_id: int) -> StoredPlan:
    row = execute(conn, _PLAN_SELECT + " WHERE pl.id = ?", (plan_id,)).fetchone()
    if row is None:
        raise InvalidRecordError(f"no plan {plan_id!r} in the registry {registry}; "
                                 "`rehab plan show CODE` lists a patient's plans")
    return _plan_from_row(row, registry)


def _plan_from_row(row: tuple, registry) -> StoredPlan:
    try:
        plan = Plan.from_dict(json.loads(row[2]))
    except (ValueError, CoreError) as exc:
        raise InvalidRecordError(f"plan {row[0]} in the registry {registry} cannot be run "
                                 f"by this console: {exc}") from None
    return StoredPlan(row[0], row[1], plan, row[3], row[4],
                      datetime.datetime.fromisoformat(row[5]))


def _run_row(conn: sa.Connection, registry, run_id: int) -> tuple:
    row = execute(conn, "SELECT r.id, r.plan_id, p.code, r.started_at, r.ended_at, r.status, "
                        "r.end_reason, r.station FROM plan_runs r "
                        "JOIN plans pl ON pl.id = r.plan_id "
                        "JOIN patients p ON p.id = pl.patient_id WHERE r.id = ?",
                        (run_id,)).fetchone()
    if row is None:
        raise InvalidRecordError(f"no plan run {run_id!r} in the registry {registry}")
    return row


def _run(conn: sa.Connection, registry, run_id: int) -> PlanRun:
    row = _run_row(conn, registry, run_id)
    steps = execute(conn, _STEP_SELECT + " WHERE run_id = ? ORDER BY step",
                          (run_id,)).fetchall()
    return PlanRun(row[0], row[1], row[2], datetime.datetime.fromisoformat(row[3]),
                   None if row[4] is None else datetime.datetime.fromisoformat(row[4]),
                   row[5], row[6], tuple(_step_from_row(s[1:]) for s in steps), row[7])


def _step_from_row(row: tuple) -> PlanStep:
    return PlanStep(row[0], row[1], row[2], row[3], row[4], row[5], row[6])
