"""The games (issue 30): a path game and a reaching game over the robot's exercises, and the
staircase that adapts their difficulty between rounds. Pure code: no Qt, no files.

* `layout`: what a game shows, from TrialParameters alone (`game_layout`): the reaching
  game's targets (disc, onset, window) and distractors, the path game's channel
  (`distance_to_path`, `channel_points`).
* `scoring`: the rules: `GameScorer(layout).feed(t, x, y, phase) -> GameState` live, and
  `.finish() -> GameFigures`; `score_game(layout, t, x, y, phase)` the same from whole arrays
  (one formula); `GameFigures.to_metrics()` the trial's 'game_*' metrics.

The game's fields live on core.trial.TrialParameters (game, target_radius_m,
channel_half_width_m, time_allowed_s, n_distractors); docs/data-format.md lists them.
"""

from core.games.layout import (
    Disc,
    GameLayout,
    Target,
    channel_points,
    distance_to_path,
    game_layout,
)
from core.games.scoring import GameFigures, GameScorer, GameState, Outcome, score_game

__all__ = [
    "Disc", "GameFigures", "GameLayout", "GameScorer", "GameState", "Outcome", "Target",
    "channel_points", "distance_to_path", "game_layout", "score_game",
]
