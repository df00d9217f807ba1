"""The runner: carries a session plan out block by block after the therapist's first Start.
Qt-free and clock-free: a state machine told what happened (the loop's answers, the
trial's end as its file says, the therapist's Pause, Resume, Stop and E-STOP, a fault,
the time) that asks its `Console` to act (build a round's trial, start it, stop it) and
to record what the run did (each trial linked to its block and round, each rest as
taken, how the run ended).

A block runs `rounds` trials; a round's trial is built from the patient's setup and the
block (core.plan.Block.parameters), started once built, and counted when its file is
finished (movements and active time from the file: app.plans.dose). Then the next
round, or the rest after the block (timed by `tick(now)`), or the plan's end. Between
rounds a game's difficulty is set by `next_round` (the games helper's staircase once it
exists; until then a round runs as its block says).

The robot is made safe by the loop, never by the runner: Stop asks the loop to stop the
trial and ends the run at once; an E-STOP or a fault ends it at once (the loop has
already zeroed the torque). Whatever ends a run, nothing is built or started after it.

Pause: in a rest the countdown stops; in a trial the trial is stopped (the loop cannot
hold a trial half-way) and, on Resume, the round runs again for the laps it had left;
while a trial is being built, started or saved, the pause takes effect when it can.
The robot gone between trials (the therapist's Disconnect in a rest): the plan pauses as
Pause does, saying why and recording it (`robot_gone`), and Resume goes on once it is
connected again; it ended 'faulted' at the next round, whose Start the loop refused.
After a block's trial the console's proposal (app.trials.progression) applies to the
next block of the same exercise (core.plan.Block.exercise), not to the plan kept in the
registry: each trial's row records what it ran and whether the proposal was taken.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

from app.plans.plan_state import (
    BUILDING,
    ENDED,
    IDLE,
    PAUSED,
    RESTING,
    RUNNING,
    SAVING,
    STARTING,
    PlanState,
)
from core.plan import Block, Plan, movements_per_lap
from core.trial import TrialParameters


class Console(Protocol):
    """What the runner asks of the console (the window's buttons, or the command line's
    device link): each call returns at once; the answer comes back as an event."""

    def build(self, parameters: TrialParameters) -> None: ...
    def start(self, block: int, round_: int) -> None: ...
    def stop(self) -> None: ...
    def record_trial(self, block: int, round_: int, trial_id: int, planned_s: float) -> None:
        ...
    def record_rest(self, block: int, planned_s: float, taken_s: float) -> None: ...
    def record_event(self, block: int, words: str) -> None: ...
    def end(self, status: str, reason: str) -> None: ...


NextRound = Callable[[TrialParameters, tuple[dict, ...]], TrialParameters]
"""A game block's next round: (the round's parameters as the block gives them, the
figures of the block's rounds so far) -> the parameters to run. The seam for the games
helper's staircase (app.games); `same_round` until then."""


def same_round(parameters: TrialParameters, rounds_so_far: tuple[dict, ...]) -> TrialParameters:
    return parameters


@dataclass
class BlockCount:
    """What one block did so far (from its trials' files and the rests' clock)."""

    trials: list[int] = field(default_factory=list)
    movements: int = 0
    active_s: float = 0.0
    rest_s: float = 0.0


class PlanRunner:
    """One run of `plan` for a patient whose setup is `base` (body, shoulder, centre,
    controller: the form's trial). See the module's docstring."""

    def __init__(self, plan: Plan, base: TrialParameters, console: Console, *,
                 next_round: NextRound = same_round) -> None:
        self.plan = plan
        self.base = base
        self.console = console
        self.next_round = next_round
        self.blocks: list[Block] = list(plan.blocks)
        """The blocks as they run: a proposal taken changes a later block of the same
        exercise here, never the plan."""
        self.phase = IDLE
        self.index = 0  # the block (0-based)
        self.round = 1
        self.laps_left = 0
        self.laps_done = 0  # of this round, in trials a pause stopped
        self.counts = [BlockCount() for _ in plan.blocks]
        self.round_figures: list[dict] = []
        self.outcome = ""
        self.reason = ""
        self.trial_id: int | None = None
        self._pause_wanted = False
        self._stopping_for_pause = False
        self._resting_since = 0.0
        self._rest_left = 0.0
        self._paused_in_rest = False
        self._parameters: TrialParameters | None = None
        self._start_pending = False
        self.held = ""  # why the console paused the plan (PlanState.held)
        self.starts = 0  # trials asked to start (the invariants count them)

    # ------------------------------------------------------------------ the therapist
    def start(self, now: float) -> None:
        """The therapist's first Start: the first block's first round is built."""
        if self.phase != IDLE:
            raise RuntimeError(f"the plan is {self.phase}; Start runs a plan once")
        self._round(now, first=True)

    def pause(self, now: float) -> None:
        if self.phase == RESTING:
            self._rest_left = self._rest_remaining(now)
            self._paused_in_rest = True
            self.phase = PAUSED
        elif self.phase == RUNNING:
            self._pause_wanted = self._stopping_for_pause = True
            self.console.stop()
        elif self.phase in (BUILDING, STARTING, SAVING):
            self._pause_wanted = True

    def resume(self, now: float) -> None:
        if self.held:
            self.console.record_event(self.index + 1, "resumed")
            self.held = ""
        if self.phase != PAUSED:
            self._pause_wanted = False if self.phase in (BUILDING, STARTING, SAVING) \
                else self._pause_wanted
            return
        if self._paused_in_rest:
            self._paused_in_rest = False
            self.phase = RESTING
            self._resting_since = now - (self.blocks[self.index].rest_s - self._rest_left)
            self.tick(now)
        else:
            self._build(now)

    def stop(self, now: float) -> None:
        """The therapist's Stop: the running trial is stopped by the loop and the plan
        ends at once."""
        if self.phase in (RUNNING, STARTING):
            self.console.stop()
        self._end(now, "stopped", "stopped by the therapist")

    def robot_gone(self, now: float, why: str) -> None:
        """The robot can take no round now (the therapist disconnected it between trials):
        the plan pauses as Pause does, `why` says so and what to do, and the run's record
        says it with its time (Console.record_event); Resume goes on (the console resumes
        only once the robot is back). Before, the plan went on to the next round, whose
        Start the loop refused, and ended 'faulted' although nothing had failed."""
        if self.phase in (IDLE, ENDED) or self.held:
            return
        self.held = why
        self.console.record_event(self.index + 1, f"paused: {why}")
        self.pause(now)

    def emergency_stop(self, now: float, message: str = "emergency stop") -> None:
        """E-STOP: the loop zeroed the torque already; the plan ends at once."""
        self._end(now, "emergency_stop", message)

    def fault(self, now: float, message: str) -> None:
        """A fault (the loop's, the recorder's, a lost link): the plan ends at once."""
        self._end(now, "faulted", message)

    # ------------------------------------------------------------------ the console
    def built(self, now: float, ok: bool, message: str = "") -> None:
        if self.phase != BUILDING:
            return
        if not ok:
            self._end(now, "faulted", f"block {self.index + 1} could not be built: {message}")
            return
        if self._pause_wanted:
            self._pause_wanted = False
            self.phase = PAUSED
            return
        self.phase = STARTING
        self._start_pending = True
        self.starts += 1
        self.console.start(self.index + 1, self.round)

    def started(self, now: float, trial_id: int) -> None:
        """The loop started the round's trial (registered as `trial_id`). A start already
        asked when the plan ended (a Stop pressed as the loop was starting it) is a trial
        too: linked to its block, counted, and stopped at once."""
        if not self._start_pending:
            return
        self._start_pending = False
        if self.phase == ENDED:
            self.counts[self.index].trials.append(trial_id)
            self.console.record_trial(self.index + 1, self.round, trial_id,
                                      self.laps_left * self.blocks[self.index].duration_s)
            self.console.stop()
            return
        self.trial_id = trial_id
        self.counts[self.index].trials.append(trial_id)
        self.console.record_trial(self.index + 1, self.round, trial_id,
                                  self.laps_left * self.blocks[self.index].duration_s)
        self.phase = RUNNING
        if self._pause_wanted:
            self._stopping_for_pause = True
            self.console.stop()

    def refused(self, now: float, message: str) -> None:
        """The round's trial could not start."""
        self._start_pending = False
        if self.phase == STARTING and self.held:  # refused as the robot went: held, the
            self._pause_wanted = False             # round built again on Resume
            self.phase = PAUSED
            return
        if self.phase == STARTING:
            self._end(now, "faulted", f"block {self.index + 1}'s trial did not start: "
                                      f"{message}")

    def trial_ended(self, now: float) -> None:
        """The loop ended the trial (its end, a Stop); its file is being finished."""
        if self.phase == RUNNING:
            self.phase = SAVING

    def finished(self, now: float, trial_id: int, status: str, movements: int,
                 active_s: float, figures: dict | None = None, proposal=None) -> None:
        """The trial's file is finished and registered: its `status`, the `movements`
        and `active_s` its file holds (app.plans.dose), its figures and the console's
        proposal after it (or None)."""
        block = self._block_of(trial_id)
        if block is None:
            return
        count = self.counts[block]
        count.movements += int(movements)
        count.active_s += float(active_s)
        current = trial_id == self.trial_id
        if current:
            self.trial_id = None
        if self.phase == ENDED or not current:
            return
        if status not in ("complete", "stopped_early"):
            self._end(now, "faulted", f"block {block + 1}'s trial ended {status}")
            return
        if status == "stopped_early" and not self._stopping_for_pause:
            self._end(now, "stopped", "the trial was stopped")
            return
        self._stopping_for_pause = False
        if status == "complete":
            laps = self.laps_left  # the loop completes a trial only after all its laps
        else:
            per_lap = movements_per_lap(self.blocks[block].shape, self._targets(block))
            laps = min(self.laps_left, int(movements) // per_lap)
        self.laps_done += laps
        self.laps_left -= laps
        if figures is not None:
            self.round_figures.append(dict(figures))
        if proposal is not None:
            self._take_proposal(block, proposal)
        if self._pause_wanted and self.laps_left > 0:
            self._pause_wanted = False
            self.phase = PAUSED
            return
        self._next(now)

    def tick(self, now: float) -> None:
        """Time passes: a rest ends when its time is up."""
        if self.phase == RESTING and self._rest_remaining(now) <= 0.0:
            self._rest_done(now, self.blocks[self.index].rest_s)
            self.index += 1
            self.round_figures = []
            self._round(now, first=True)

    # ------------------------------------------------------------------ the plan's state
    def state(self, now: float) -> PlanState:
        block = self.blocks[min(self.index, len(self.blocks) - 1)]
        rest_left = 0.0
        if self.phase == RESTING:
            rest_left = self._rest_remaining(now)
        elif self.phase == PAUSED and self._paused_in_rest:
            rest_left = self._rest_left
        done = sum(c.movements for c in self.counts)
        # a rest comes between two blocks: the one after it is what the patient waits for
        resting = self.phase == RESTING or (self.phase == PAUSED and self._paused_in_rest)
        upcoming = self.blocks[self.index + 1] if resting else None
        return PlanState(
            self.phase, 0 if self.phase == IDLE else self.index + 1, len(self.blocks),
            block.name, self.round, block.rounds, self.laps_left if self.phase != IDLE
            else block.laps, self.laps_done, done, self.planned_movements(), rest_left,
            self._time_left(now, rest_left), self.outcome, self.reason,
            self.held if self.phase == PAUSED else "", *self._shares(),
            self._pause_wanted and self.phase in (BUILDING, STARTING, RUNNING, SAVING),
            upcoming.parameters(self.base) if upcoming is not None else None,
            upcoming.rounds if upcoming is not None else 0)

    def _shares(self) -> tuple[float, float]:
        """(done_share, lap_share) of PlanState: laps, not the movements the files count,
        so that the share reaches 1 at a complete end whatever the hand did (the
        transparent mode counts only where the hand went) and a lap's share is known
        before its trial's file is."""
        weights = [b.planned_active_s() for b in self.plan.blocks]
        total = sum(weights)
        if total <= 0.0:
            return math.nan, 0.0
        if self.phase == ENDED and self.outcome == "complete":
            return 1.0, 0.0
        k = min(self.index, len(self.blocks) - 1)
        block = self.blocks[k]
        laps = block.rounds * block.laps
        done = 0 if self.phase == IDLE else (self.round - 1) * block.laps + self.laps_done
        lap = weights[k] / laps / total
        return (sum(weights[:k]) / total + min(done, laps) * lap, lap)

    def planned_movements(self) -> int:
        return sum(b.planned_movements(self._targets(k)) for k, b in enumerate(self.blocks))

    def _targets(self, block: int) -> int:
        """The targets block `block`'s rounds run with: its own trial's, never the form's
        (a task's in the form, the position sense's 4, goes back to an exercise's 8 in a
        round: core.assessment.protocol.without_task; "18 of 10 movements")."""
        return self.blocks[block].parameters(self.base).n_targets

    # ------------------------------------------------------------------ inside
    def _round(self, now: float, first: bool) -> None:
        block = self.blocks[self.index]
        if first:
            self.round = 1
        self.laps_left = block.laps
        self.laps_done = 0
        self._build(now)

    def _build(self, now: float) -> None:
        block = self.blocks[self.index]
        params = block.parameters(self.base).replace(repetitions=self.laps_left)
        if block.game:
            params = self.next_round(params, tuple(self.round_figures))
        self._parameters = params
        self.phase = BUILDING
        self.console.build(params)

    def _next(self, now: float) -> None:
        block = self.blocks[self.index]
        if self.laps_left > 0:
            self._build(now)  # a round a pause cut short: the laps it had left
            return
        if self.round < block.rounds:
            self.round += 1
            self._round(now, first=False)
            return
        if self.index == len(self.blocks) - 1:
            self._end(now, "complete", "")
            return
        if block.rest_s <= 0.0:
            self.index += 1
            self.round_figures = []
            self._round(now, first=True)
            return
        self.phase = RESTING
        self._resting_since = now
        if self._pause_wanted:
            self._pause_wanted = False
            self._rest_left = block.rest_s
            self._paused_in_rest = True
            self.phase = PAUSED

    def _rest_remaining(self, now: float) -> float:
        return max(0.0, self.blocks[self.index].rest_s - (now - self._resting_since))

    def _rest_done(self, now: float, taken_s: float) -> None:
        block = self.blocks[self.index]
        self.counts[self.index].rest_s += taken_s
        self.console.record_rest(self.index + 1, block.rest_s, taken_s)

    def _end(self, now: float, outcome: str, reason: str) -> None:
        if self.phase == ENDED:
            return
        if self.phase == RESTING or (self.phase == PAUSED and self._paused_in_rest):
            rest = self.blocks[self.index].rest_s
            left = self._rest_remaining(now) if self.phase == RESTING else self._rest_left
            self._rest_done(now, rest - left)
        self.phase = ENDED
        self.held = ""  # nothing to resume
        self.outcome, self.reason = outcome, reason
        self.console.end(outcome, reason)

    def _block_of(self, trial_id: int) -> int | None:
        for k, count in enumerate(self.counts):
            if trial_id in count.trials:
                return k
        return None

    def _take_proposal(self, block: int, proposal) -> None:
        """The proposal after block `block`'s trial, for the next block of the same
        exercise (its level, pace and tolerance: what a proposal sets)."""
        done = self.blocks[block]
        for k in range(block + 1, len(self.blocks)):
            if self.blocks[k].exercise() == done.exercise():
                later = self.blocks[k]
                proposed = proposal.applied_to(later.parameters(self.base))
                self.blocks[k] = later.replace(
                    assistance_level=proposed.assistance_level,
                    duration_s=proposed.duration_s, tolerance_rad=proposed.tolerance_rad)
                return

    def _time_left(self, now: float, rest_left: float) -> float:
        if self.phase == ENDED:
            return 0.0
        if self.phase == IDLE:
            return self.plan.planned_active_s() + self.plan.planned_rest_s()
        k = self.index
        block = self.blocks[k]
        left = 0.0
        if self.phase not in (RESTING,) and not (self.phase == PAUSED and
                                                 self._paused_in_rest):
            left += self.laps_left * block.duration_s
            left += (block.rounds - self.round) * block.laps * block.duration_s
            left += block.rest_s if k < len(self.blocks) - 1 else 0.0
        else:
            left += rest_left
        for j in range(k + 1, len(self.blocks)):
            left += self.blocks[j].planned_active_s()
            left += self.blocks[j].rest_s if j < len(self.blocks) - 1 else 0.0
        return left
