"""A game on the patient's screen, without Qt: the games' own scorer (core.games) fed the
hand's samples as the screen shows them, and what the patient is told after each target or
lap (knowledge of results, then its quality; encouragement on a hit).

The scorer is the one that scores the trial from its file (`core.games.score_game`): the
screen feeds it the samples of the `TrialView` it shows, in time order, each once; a view
shown from an earlier moment (a replay's slider moved back, another view) starts a new
scorer and feeds it again from the start, so the screen always says what the file will.

What is said (Act.Sens protocol, doi 10.1186/s40814-021-00948-3: knowledge of results on
success, a score, the time):
* reaching game: "Hit!" with the time the target took, or "Missed";
* path game: "Clean lap!" with its points, or the time the ball spent outside the channel
  (or "Keep moving" when the ball stayed in but did not go round);
each for `RESULT_SHOWN_S` after it happened (game time). Once the exercise is over (the
hold), the scorer is finished as the trial's figures are, so the last lap or target counts
on the screen as in the file.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

from core.games import GameLayout, GameScorer, GameState, Target
from core.games.scoring import LAP_POINTS
from device.loop.pipeline import PHASE_HOLD
from ui.views.trialview import TrialView

RESULT_SHOWN_S = 2.0


@dataclass(frozen=True, slots=True)
class GameFrame:
    """The game at one moment: its state, the target to hit (reaching), the target just
    hit, and the words for the last outcome while they are shown."""

    state: GameState
    open_target: Target | None
    hit_target: Target | None
    result: str
    success: bool
    """The result shown is a hit (or a clean lap): the screen encourages."""

    targets: int = 0
    """The reaching game's targets in the trial (0 in the path game)."""
    targets_shown: int = 0
    """Of them, those lit so far (its onset passed): the one to hit is the last."""

    @property
    def score_text(self) -> str:
        return f"Score {self.state.score:.0f}" if self.state.started else ""


def result_words(layout: GameLayout, state: GameState) -> tuple[str, bool]:
    """The words for the last finished target or lap while it is recent, and whether it
    was a success."""
    last = state.last
    if last is None or not state.started or state.t_s - last.at_s >= RESULT_SHOWN_S:
        return "", False
    if layout.game == "reach":
        if last.hit:
            return f"Hit! {last.time_s:.1f} s", True
        return "Missed", False
    if last.hit:
        return f"Clean lap! +{LAP_POINTS:.0f}", True
    if last.time_s > 0.0:
        return f"{last.time_s:.1f} s outside", False
    return "Keep moving round", False


class GameFeed:
    """The scorer of one game, fed from the view the screen shows."""

    def __init__(self, layout: GameLayout) -> None:
        self.layout = layout
        self._view_id: int | None = None
        self._last_t = -math.inf
        self._scorer = GameScorer(layout)
        self._state = self._scorer.state
        self._onsets = [target.onset_s for target in layout.targets]

    def at(self, view: TrialView, start_s: float | None = None) -> GameFrame:
        """The game at the view's current sample (its newest live, its cursor in replay);
        `start_s` the exercise's first tick's time when known (the game's clock starts
        there, as the file's scoring starts it at the file's first exercise sample)."""
        i = view.current_index
        if i >= 0:
            time = view.time
            t = float(time[i])
            if id(view) != self._view_id or t < self._last_t:
                self._view_id = id(view)
                self._last_t = -math.inf
                self._scorer = GameScorer(self.layout, start_s)
                self._state = self._scorer.state
            if t > self._last_t:
                first = int(np.searchsorted(time[:i + 1], self._last_t, side="right"))
                position = view.column("position")
                self._state = self._scorer.feed(time[first:i + 1], position[0, first:i + 1],
                                                position[1, first:i + 1],
                                                view.column("phase")[0, first:i + 1])
                self._last_t = t
                if int(view.column("phase")[0, i]) == PHASE_HOLD:
                    # the exercise is over: the windows it covered are closed, as the
                    # trial's figures close them (core.games.scoring, finish)
                    self._scorer.finish()
                    self._state = self._scorer.state
        return self._frame(self._state)

    def _frame(self, state: GameState) -> GameFrame:
        targets = self.layout.targets
        open_target = targets[state.current] if self.layout.game == "reach" \
            and state.current >= 0 else None
        words, success = result_words(self.layout, state)
        hit = None
        if success and self.layout.game == "reach":
            hit = targets[state.last.index]
        # the layout's targets come in order of onset
        shown = bisect.bisect_right(self._onsets, state.t_s) if state.started else 0
        return GameFrame(state, open_target, hit, words, success, len(targets), shown)
