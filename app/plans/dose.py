"""The dose a plan delivered, from the record: movements and active time from each
trial's file, rests as the registry kept them, per block and for the run; beside what the
plan prescribed.

The movements are counted on the record of where the hand was taken
(core.plan.movements_in_path). In the guiding modes (thesis, as-needed) that is the
reference, which the robot holds the hand to (the as-needed mode's reference follows the
hand itself): the hand's own samples would miss the laps of a weak or passive arm that
cuts the D's corner at a fast pace (a 2 s lap: 1 of 2 laps by the hand, 2 by the
reference), although the robot took it round. In the transparent mode nothing moves the
hand and the reference runs on the clock alone, so the hand's measured position is
counted, through the exercise and the hold after it (a hand that lags the clock reaches
the last movement's end after the exercise's last tick): a passive virtual patient makes
0 of 32 centre-out movements there, where the reference would say 32. The hand's last
movement ends once it is at its end within the turn's margin and the reference has
arrived there (core.plan.movements_in_path): a hand does not settle within the
reference's 2 mm.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from app.errors import AppError
from app.records.trialplace import file_to_read
from core.plan import Plan, movements_in_path
from core.trial import TrialParameters
from device.loop.pipeline import PHASE_EXERCISE, PHASE_HOLD

CHANNELS = ("phase", "position", "position_desired")


@dataclass(frozen=True, slots=True)
class TrialDose:
    """What one trial's file says it did."""

    movements: int
    active_s: float
    status: str


def trial_dose(path, parameters: TrialParameters | None = None) -> TrialDose:
    """The movements and active time in the trial file at `path` (its own parameters
    unless given); TrialFileError (one line naming the file) when it cannot be read."""
    from app.trials.reader import read_trial

    data = read_trial(path, CHANNELS)
    params = parameters or data.parameters
    if params is None:
        raise AppError(f"trial file {path}: has no parameters; its movements cannot be "
                       "counted")
    phase = np.asarray(data.channels["phase"])
    exercise = phase == PHASE_EXERCISE
    if params.assist == "transparent":
        counted = exercise | (phase == PHASE_HOLD)
        taken = np.asarray(data.channels["position"])[counted]
        reference = np.asarray(data.channels["position_desired"])[counted]
    else:
        taken = np.asarray(data.channels["position_desired"])[exercise]
        reference = None
    return TrialDose(movements_in_path(params, taken, reference),
                     float(np.count_nonzero(exercise)) * data.sample_period_s, data.status)


@dataclass
class BlockDose:
    """One block: planned and done."""

    block: int
    name: str
    planned_movements: int
    planned_active_s: float
    """The laps times the pace, in all rounds: the exercise on the clock."""
    planned_rest_s: float
    movements: int = 0
    active_s: float = 0.0
    """The exercise phase as the trials' files recorded it. In the as-needed mode it runs
    on past the clock by up to the guidance's delay (0.3 s a trial) while the reference
    catches the hand up at the path's end, so a block done in full shows a little more than
    planned: shown beside the plan (`active_words`), never as "0:51 of 0:50", which read as
    an overrun."""
    rest_s: float = 0.0
    trials: list[int] = field(default_factory=list)


@dataclass
class RunDose:
    """A run of a plan: its blocks' doses and the totals."""

    run_id: int
    status: str
    blocks: list[BlockDose]
    notes: list[str] = field(default_factory=list)

    @property
    def movements(self) -> int:
        return sum(b.movements for b in self.blocks)

    @property
    def active_s(self) -> float:
        return sum(b.active_s for b in self.blocks)

    @property
    def rest_s(self) -> float:
        return sum(b.rest_s for b in self.blocks)

    @property
    def planned_movements(self) -> int:
        return sum(b.planned_movements for b in self.blocks)

    def table(self) -> list[str]:
        """Lines for a terminal or a report: one per block, then the run's total; the
        times done with the planned beside them in brackets (m:ss)."""
        lines = ["block  name                       movements     active (planned)  "
                 "rest (planned)"]
        rows = [(f"{b.block:>5}", b.name, b.movements, b.planned_movements, b.active_s,
                 b.planned_active_s, b.rest_s, b.planned_rest_s) for b in self.blocks]
        rows.append(("total", "", self.movements, self.planned_movements, self.active_s,
                     self.planned_active_s, self.rest_s, self.planned_rest_s))
        for where, name, moved, planned, active, active_plan, rest, rest_plan in rows:
            lines.append(f"{where}  {name[:25]:<25}  {moved:>4} of {planned:<5}  "
                         f"{_beside(active, active_plan):<16}  {_beside(rest, rest_plan)}")
        return lines

    def summary(self) -> str:
        """The run's dose in one line: '40 of 40 movements, 0:51 active (0:50 planned),
        1:00 of rest' (the Progress tab's)."""
        return (f"{self.movements} of {self.planned_movements} movements, "
                f"{active_words(self.active_s, self.planned_active_s)}, "
                f"{clock(self.rest_s)} of rest")

    @property
    def planned_active_s(self) -> float:
        return sum(b.planned_active_s for b in self.blocks)

    @property
    def planned_rest_s(self) -> float:
        return sum(b.planned_rest_s for b in self.blocks)


def clock(seconds: float) -> str:
    """'m:ss', rounded to the second."""
    whole = round(seconds)
    return f"{whole // 60}:{whole % 60:02d}"


def _beside(done_s: float, planned_s: float) -> str:
    return f"{clock(done_s):>5} ({clock(planned_s)})"


def active_words(active_s: float, planned_s: float) -> str:
    """The exercise time done beside the planned, each for what it is: '0:51 active (0:50
    planned)' (see BlockDose.active_s)."""
    return f"{clock(active_s)} active ({clock(planned_s)} planned)"


def run_dose(registry, run_id: int) -> RunDose:
    """The dose of plan run `run_id`: each trial's file read for its movements and active
    time, each rest as the registry kept it."""
    run = registry.plan_run(run_id)
    plan: Plan = registry.plan(run.plan_id).plan
    patient = registry.patient(run.patient_code)
    base = TrialParameters().replace(**patient.trial_overrides())
    blocks = [BlockDose(k + 1, b.name or b.shape, b.planned_movements(base.n_targets),
                        b.planned_active_s(), b.rest_s if k < len(plan.blocks) - 1 else 0.0)
              for k, b in enumerate(plan.blocks)]
    dose = RunDose(run.id, run.status, blocks)
    for step in run.steps:
        block = blocks[step.block - 1]
        if step.kind == "rest":
            block.rest_s += step.taken_s or 0.0
            continue
        block.trials.append(step.trial_id)
        trial = registry.trial(step.trial_id)
        try:
            # here, else the trial store's copy (another station's run), on its signature:
            # a dose counts over every trial of the latest runs
            done = trial_dose(file_to_read(registry, trial, checked=False)[0])
        except AppError as exc:
            dose.notes.append(f"trial {trial.id} counts nothing: {exc}")
            continue
        block.movements += done.movements
        block.active_s += done.active_s
    return dose


def patient_doses(registry, code: str, last: int = 20) -> list[tuple[str, RunDose]]:
    """The patient's latest `last` plan runs, oldest first, each with its heading (when,
    the plan, the run, how it ended) and its dose per block: what the progress report's
    dose page shows (app.reports.progress_pdf)."""
    runs = getattr(registry, "plan_runs_for_patient", None)
    if runs is None:
        return []  # a store without plans
    doses = []
    for run in runs(code)[-last:]:
        plan = registry.plan(run.plan_id).plan
        doses.append((f"{run.started_at.astimezone():%d %b %Y %H:%M}  {plan.name} (plan "
                      f"{run.plan_id}, run {run.id}): {run.status.replace('_', ' ')}",
                      run_dose(registry, run.id)))
    return doses


def dose_lines(registry, code: str, last: int = 5) -> list[str]:
    """The dose of the patient's latest `last` plan runs, one line each, newest first:
    what the Progress tab shows (the files read for the movements and active time)."""
    runs = getattr(registry, "plan_runs_for_patient", None)
    if runs is None:
        return []  # a store without plans
    lines = []
    for run in reversed(runs(code)[-last:]):
        dose = run_dose(registry, run.id)
        plan = registry.plan(run.plan_id).plan
        lines.append(f"{run.started_at.astimezone():%d %b %Y %H:%M} {plan.name} (run "
                     f"{run.id}): {run.status.replace('_', ' ')}, {dose.summary()}"
                     + (f"; {len(dose.notes)} trial(s) unreadable" if dose.notes else ""))
    return lines


def trial_plan_lines(registry, trial_id: int) -> list[tuple[str, str]]:
    """(label, value) for a trial's report when it ran in a plan: the plan, its block and
    round, and the run's dose so far; [] for a trial outside a plan."""
    find = getattr(registry, "plan_step_of_trial", None)
    found = find(trial_id) if find is not None else None
    if found is None:
        return []
    run_id, step = found
    run = registry.plan_run(run_id)
    plan = registry.plan(run.plan_id).plan
    block = plan.blocks[step.block - 1]
    rounds = f", round {step.round} of {block.rounds}" if block.rounds > 1 else ""
    dose = run_dose(registry, run_id)
    return [("Plan", f"{plan.name} (run {run_id}), block {step.block} of "
                     f"{len(plan.blocks)}: {block.name or block.shape}{rounds}"),
            ("Plan's dose", f"{dose.summary()} ({run.status.replace('_', ' ')})")]
