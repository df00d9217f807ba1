"""A game trial's figures from its recorded channels: the after-trial side of the games' one
formula (core.games.scoring)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np

from app.games.names import game_title
from core.blockwise import spans
from core.games import GameFigures, GameScorer, game_layout, score_game
from core.games.staircase import Staircase
from core.trial import TrialParameters

CHANNELS_NEEDED = ("time", "phase", "position")
"""The recorded channels a game's figures read."""


def game_figures(channels: Mapping[str, np.ndarray],
                 parameters: TrialParameters) -> GameFigures | None:
    """The figures of the trial's game (None when it is not a game): the scorer fed the
    recorded hand positions of the exercise phase, as the live screen fed it."""
    if not parameters.game:
        return None
    position = np.asarray(channels["position"])
    return score_game(game_layout(parameters), channels["time"], position[:, 0],
                      position[:, 1], channels["phase"])


def game_figures_stored(read: Callable[[str, int, int], np.ndarray], n_ticks: int,
                        parameters: TrialParameters, block: int) -> GameFigures | None:
    """`game_figures` of a trial read a block of samples at a time (a trial too long to
    hold): the same scorer fed block by block, so the same figures to the bit."""
    if not parameters.game:
        return None
    scorer = GameScorer(game_layout(parameters))
    for a, b in spans(n_ticks, block):
        position = np.asarray(read("position", a, b))
        scorer.feed(read("time", a, b), position[:, 0], position[:, 1], read("phase", a, b))
    return scorer.finish()


def game_line(parameters: Mapping, metrics: Mapping) -> str:
    """A game trial's figures in one line for people ('' when the trial is not a game or has
    no game figures): 'Reaching game: score 60, 7 hits, 1 miss (88 %), 8.0 s, 0.42 s to hit'."""
    game = parameters.get("game", "")
    if not game or "game_hits" not in metrics:
        return ""

    def whole(name: str) -> int:
        value = metrics.get(name, math.nan)
        return int(value) if math.isfinite(value) else 0

    hits, misses = whole("game_hits"), whole("game_misses")
    success = metrics.get("game_success", math.nan)
    rate = f" ({100.0 * success:.0f} %)" if math.isfinite(success) else ""
    text = (f"{game_title(game)}: score {metrics.get('game_score', math.nan):.0f}, {hits} "
            f"hit{'s' * (hits != 1)}, {misses} miss{'es' * (misses != 1)}{rate}, "
            f"{metrics.get('game_time_s', math.nan):.1f} s")
    if game == "reach":
        to_hit = metrics.get("game_time_to_hit_s", math.nan)
        if math.isfinite(to_hit):
            text += f", {to_hit:.2f} s to hit"
        touches = whole("game_touches")
        if touches:
            text += f", {touches} distractor{'s' * (touches != 1)} touched"
    else:
        text += f", {metrics.get('game_time_outside_s', math.nan):.1f} s outside the channel"
    return text


def staircase_text(staircase_json: str) -> str:
    """The staircase that set a round's difficulty, for the therapist: 'rung 5 of 16
    (help 60 %, time allowed 1.20 s, target radius 2.4 cm); round 4: 6 hits, 2 misses …'."""
    state = Staircase.from_json(staircase_json)
    shown = []
    for field, value in state.values().items():
        label, scale, unit, digits = _DIAL_WORDS[field]
        shown.append(f"{label} {value * scale:.{digits}f}{unit}")
    lock = ", locked" if state.locked else ""
    return f"rung {state.rung} of {state.top}{lock} ({', '.join(shown)}); {state.why}"


_DIAL_WORDS = {
    "assistance_level": ("help", 100.0, " %", 0),
    "time_allowed_s": ("time allowed", 1.0, " s", 2),
    "target_radius_m": ("target radius", 100.0, " cm", 1),
    "channel_half_width_m": ("channel half-width", 100.0, " cm", 1),
    "duration_s": ("one lap in", 1.0, " s", 1),
    "radius_m": ("distance", 100.0, " cm", 1),
}
