"""A session plan on the patient's screen, without Qt: which block, how far through the
session's exercise, and the rest's countdown (issue 30, the plan's state:
app.plans.plan_state.PlanState, read from the runner as the window repaints).

During a block the screen stays the trial's (the path, the hand, Go, the lap, the time left
in the top band, as in a trial alone), the block said with its first trial's "Get ready"
("Block 2 of 3. Get ready"; a block of several rounds says the round with the next: "Round
2 of 3. Get ready"), and a bar of the session's exercise done under the band, which moves
as the running trial's time passes (a two-minute block's bar does not stand still) and
never back (`PlanOverlay.at_least`). During a rest the table gives way to "Rest" and its
countdown in the largest type, and what comes next in the patient's words (`next_words`);
paused, "Pause" (from the press: the trial it stops is no
"Stopped" for the patient); at the end, the session's outcome in the patient's words. The
counts are the plan's own (the trials' files, the runner's laps), never recomputed here;
the running trial's laps passed come from the screen's own clock (`laps_passed`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

from app.games.names import game_title
from app.plans.plan_state import ENDED, IDLE, PAUSED, RESTING, RUNNING, SAVING, PlanState
from app.reports.plain_language import SHAPE_NAMES
from core.games import game_layout
from core.trial import TrialParameters
from ui.views.patient_screen import PatientFrame, clock

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
    """The session's exercise done, 0–1 (PlanState.done_share with the running trial's
    laps passed; NaN when nothing is planned)."""
    centre: str = ""
    countdown: str = ""
    message: str = ""
    laps_before: int = 0
    """Laps of this round its earlier trials ran, a pause having cut them (PlanState.
    laps_done): the trial run after the pause counts its laps on from them."""
    ready_text: str = ""
    """Where the trial stands in the plan, said with its "Get ready": the block at its
    first round ("Block 2 of 3"), the round at the next ("Round 2 of 3"). Not in the top
    band: beside the lap and the time left the three came to 18 mm, not 20, full screen
    on 22 inches (the lap's round, there too, to 16)."""

    @property
    def covers_table(self) -> bool:
        return bool(self.centre)

    def at_least(self, shown: float) -> PlanOverlay:
        """The same with the bar never below what it showed (`shown`): a trial paused
        half-way counts the laps its file holds, fewer than the clock had passed."""
        if not shown > self.progress:  # NaN either side: as it is
            return self
        return dataclasses.replace(self, progress=shown)


def laps_passed(frame: PatientFrame, lap_s: float) -> float:
    """Laps of the running trial its clock has passed (fractions too): the repetitions
    less the time left over the pace; 0 before its exercise or without a clock."""
    if frame.time_left_s is None or lap_s <= 0.0 or frame.repetition <= 0:
        return 0.0
    return min(float(frame.repetitions),
               max(0.0, frame.repetitions - frame.time_left_s / lap_s))


def overlay(state: PlanState | None, laps: float = 0.0) -> PlanOverlay | None:
    """The plan's part of the screen, or None when no plan runs (or it has not started).
    `laps`: the running trial's laps passed (`laps_passed`), counted while the plan says a
    trial runs or is being saved (its file not yet counted), never more than it runs."""
    if state is None or state.phase == IDLE or state.block <= 0:
        return None
    block = f"Block {state.block} of {state.n_blocks}"
    # said with "Get ready": a new block, or the next of its trials (a game's rounds) in
    # the status line's words
    ready = f"Round {state.round} of {state.rounds}" if state.round > 1 else block
    progress = state.done_share
    if state.phase in (RUNNING, SAVING) and math.isfinite(progress):
        progress = min(1.0, progress + state.lap_share * min(max(laps, 0.0),
                                                             state.laps_planned))
    if state.phase == RESTING:
        more = state.block < state.n_blocks
        return PlanOverlay(block, progress, REST_WORDS, clock(state.rest_left_s),
                           next_words(state.next_trial, state.next_rounds) if more else "")
    if state.phase == PAUSED or state.pausing:
        return PlanOverlay(block, progress, PAUSE_WORDS, "", "Please wait")
    if state.phase == ENDED:
        return PlanOverlay(block, progress, ENDED_WORDS.get(state.outcome, "Stopped"), "",
                           f"{state.movements_done} movements" if state.outcome ==
                           "complete" else "")
    return PlanOverlay(block, progress, laps_before=state.laps_done, ready_text=ready)


def next_words(trial: TrialParameters | None, rounds: int) -> str:
    """What comes after a rest, in the patient's words: the game by its name, or the
    exercise by the name the patient's report gives it, and how much of it, counted as
    the screen will count it (a reaching game of one lap by its targets, anything else
    by its laps: PatientFrame.repetition_text): "Next: Reaching game, 3 rounds of 8
    targets", "Next: D shape, 5 laps". The rest's length is the countdown above it. It
    said "Next: block 3", which tells a patient nothing."""
    if trial is None:
        return ""
    name = game_title(trial.game) if trial.game else SHAPE_NAMES.get(trial.shape, trial.shape)
    count, unit = trial.repetitions, "lap"
    if trial.game == "reach" and trial.repetitions == 1:
        count, unit = _targets(trial), "target"
    amount = f"{count} {unit}{'s' * (count != 1)}"
    if rounds > 1:
        amount = f"{rounds} rounds of {amount}"
    return f"Next: {name[:1].upper()}{name[1:]}, {amount}"


@functools.lru_cache(maxsize=4)
def _targets(trial: TrialParameters) -> int:
    """The reaching game's targets in one round (its layout's: core.games.game_layout),
    worked out once per trial, not at each of the rest's 60 frames a second."""
    return len(game_layout(trial).targets)
