"""A session plan's state as the patient's screen and the window's status line read it
(PlanRunner.state in app.plans.runner): the runner's phases and the one line the therapist
sees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from core.trial import TrialParameters

IDLE, BUILDING, STARTING, RUNNING, SAVING, RESTING, PAUSED, ENDED = (
    "idle", "building", "starting", "running", "saving", "resting", "paused", "ended")
ENDS = ("complete", "stopped", "emergency_stop", "faulted")


@dataclass(frozen=True, slots=True)
class PlanState:
    """The plan's state as the patient's screen and the window's status line read it.
    Counts are whole movements and laps the trials' files hold; times in s."""

    phase: str
    """idle, building, starting, running, saving, resting, paused or ended."""
    block: int
    """1-based; 0 before the first Start."""
    n_blocks: int
    block_name: str
    round: int
    rounds: int
    laps_planned: int
    """Laps the round's trial runs (fewer after a pause: what it had left)."""
    laps_done: int
    """Laps of this round done in its earlier, paused trials."""
    movements_done: int
    """In the whole plan so far."""
    movements_planned: int
    rest_left_s: float
    """The rest's countdown (0 outside a rest)."""
    time_left_s: float
    """Planned exercise and rests still to come (the running round counted whole)."""
    outcome: str
    """How the run ended ('' until it does): complete, stopped, emergency_stop, faulted."""
    reason: str
    held: str = ""
    """Why the plan is paused when the console paused it (the robot disconnected: what to
    do, in words), '' when the therapist did or it is not paused."""
    done_share: float = math.nan
    """The plan's exercise done, 0–1: the blocks before this one whole and this block's
    laps done in finished trials, each block weighted by its planned exercise time (as the
    plan has it: a proposal's pace does not move what is done); 1 once complete, NaN
    with nothing planned. The patient's screen adds the running trial's laps to it."""
    lap_share: float = 0.0
    """One lap of this block as a share of the plan's exercise (its planned time over its
    laps in all rounds)."""
    pausing: bool = False
    """Pause was pressed and the plan pauses once the round in hand allows (the trial
    stopped and its file finished, the round built): the patient's screen says "Pause"
    from the press, not the stopped trial's "Stopped"."""
    next_trial: TrialParameters | None = None
    """During a rest (paused in it too): the next block's trial as its first round runs
    it (the block's exercise, game and laps on the patient's setup, a proposal taken
    included), for the patient's screen to say what comes next; None otherwise."""
    next_rounds: int = 0
    """The next block's rounds (0 with no `next_trial`)."""

    def line(self) -> str:
        """One line for the therapist's status line."""
        if self.phase == IDLE:
            return (f"Plan ready: {self.n_blocks} blocks, {self.movements_planned} "
                    f"movements. Start runs it.")
        where = f"Block {self.block} of {self.n_blocks}"
        if self.rounds > 1:
            where += f", round {self.round} of {self.rounds}"
        if self.phase == ENDED:
            words = {"complete": "Plan complete", "stopped": "Plan stopped",
                     "emergency_stop": "Plan ended by the emergency stop",
                     "faulted": "Plan ended by a fault"}[self.outcome]
            tail = f": {self.reason}" if self.reason and self.outcome != "complete" else ""
            return (f"{words} ({where}; {self.movements_done} of {self.movements_planned} "
                    f"movements){tail}")
        if self.phase == RESTING:
            return f"Rest {clock(self.rest_left_s)} after {where.lower()}; " \
                   f"{self.movements_done} of {self.movements_planned} movements"
        if self.phase == PAUSED:
            if self.held:
                return f"Plan paused at {where.lower()}: {self.held}"
            return f"Plan paused at {where.lower()}; Resume goes on"
        laps = "1 lap" if self.laps_planned == 1 else f"{self.laps_planned} laps"
        return (f"{where}: {self.block_name or 'exercise'}, {laps}; "
                f"{self.movements_done} of {self.movements_planned} movements; about "
                f"{clock(self.time_left_s)} left")


def clock(seconds: float) -> str:
    whole = max(0, math.ceil(seconds - 1e-9))
    return f"{whole // 60}:{whole % 60:02d}"
