"""The games' names for people, written once: the report's header, a series' label in the
Progress tab, the Parameters tab's words and a game trial's one line (app.games.figures)
all name a game so. Here, not in app.reports.plain_language, because app.games.figures is
imported by app.trials.analysis, which app.reports imports: a name there would close an
import cycle."""

from __future__ import annotations

GAME_TITLES = {"path": "Path game", "reach": "Reaching game"}
"""The games' names (core.trial.GAMES) where a series, a report or a line names a trial's
game."""


def game_title(game: str) -> str:
    """A game's name ('Reaching game'), or its code when it has none here (a file from a
    newer version)."""
    return GAME_TITLES.get(game, game)
