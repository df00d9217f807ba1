"""A session plan on the patient's screen, without Qt: which block, how far through the
session's movements, and the rest's countdown (issue 30, the plan's state:
app.plans.runner.PlanState, read from the runner as the window repaints).

During a block the screen stays the trial's (the path, the hand, Go, the round, the time
left) with the block's number in the top band's first place and a bar of the session's
movements done under it. During a rest the table gives way to "Rest" and its countdown in
the largest type; paused, "Pause"; at the end, the session's outcome in the patient's words.
The counts are the plan's own (the trials' files), never recomputed here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from app.plans.runner import ENDED, IDLE, PAUSED, RESTING, PlanState
from ui.views.patient_screen import clock

PAUSE_WORDS = "Pause"
REST_WORDS = "Rest"
ENDED_WORDS = {"complete": "Session complete. Well done!", "stopped": "Stopped",
               "emergency_stop": "Stopped", "faulted": "Stopped"}


@dataclass(frozen=True, slots=True)
class PlanOverlay:
    """What the plan adds to the screen. `centre` and `countdown` replace the table when
    set (a rest, a pause, the end)."""

    block_text: str
    progress: float
    """Movements done over planned, 0–1 (NaN when nothing is planned)."""
    centre: str = ""
    countdown: str = ""
    message: str = ""

    @property
    def covers_table(self) -> bool:
        return bool(self.centre)


def overlay(state: PlanState | None) -> PlanOverlay | None:
    """The plan's part of the screen, or None when no plan runs (or it has not started)."""
    if state is None or state.phase == IDLE or state.block <= 0:
        return None
    block = f"Block {state.block} of {state.n_blocks}"
    progress = (state.movements_done / state.movements_planned
                if state.movements_planned > 0 else math.nan)
    if state.phase == RESTING:
        more = state.block < state.n_blocks
        return PlanOverlay(block, progress, REST_WORDS, clock(state.rest_left_s),
                           f"Next: block {state.block + 1}" if more else "")
    if state.phase == PAUSED:
        return PlanOverlay(block, progress, PAUSE_WORDS, "", "Please wait")
    if state.phase == ENDED:
        return PlanOverlay(block, progress, ENDED_WORDS.get(state.outcome, "Stopped"), "",
                           f"{state.movements_done} movements" if state.outcome ==
                           "complete" else "")
    return PlanOverlay(block, progress)
