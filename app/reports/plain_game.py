"""A game trial's result in the patient's words: the first line of the report's "How it
went" (seen in the window: a patient who hit all 8 targets for a score of 80 read a report
whose every line was about leading the movement and the shoulder's range, the game's score
only in the header's small grey print, "score 80, 8 hits, 0 misses (100 %), 12.0 s, 0.56
s to hit").

The numbers are the game's own figures (the trial's metrics, `GameFigures.to_metrics`: the
scorer the screen scored with), in the screen's words: the score as its "Score 80" showed
it, hits out of the targets or laps that finished, a lap's rule (inside the channel all the
way, and round the path) as the screen's "Clean lap!" counted it."""

from __future__ import annotations

import math
from collections.abc import Mapping

from app.reports.plain_language import PlainLine, seconds_text
from core.games.scoring import DISTRACTOR_POINTS, POINTS_PER_S_OUTSIDE

GAME_KEY = "game_score"
"""The line's key (PlainLine.key): the figure it leads with."""


def _count(metrics: Mapping[str, float], key: str) -> int:
    value = float(metrics.get(key, math.nan))
    return int(value) if math.isfinite(value) else 0


def score_words(score: float) -> str:
    """The score as the patient's screen wrote it ("Score 80": ui.views.patient_game)."""
    return f"{score:.0f}"


def game_result_line(game: str, metrics: Mapping[str, float]) -> PlainLine | None:
    """The game's result in one line (None when the trial is no game, or no target or lap
    finished: a trial stopped before the first has nothing to say)."""
    score = float(metrics.get("game_score", math.nan))
    hits, misses = _count(metrics, "game_hits"), _count(metrics, "game_misses")
    played = hits + misses
    if game not in ("reach", "path") or played == 0 or not math.isfinite(score):
        return None
    scored = f"your score was {score_words(score)}"
    if game == "reach":
        text = f"You hit {hits} of the {played} targets: {scored}."
        detail = "A target counts when your hand reaches it before its time runs out"
        to_hit = float(metrics.get("game_time_to_hit_s", math.nan))
        if hits and math.isfinite(to_hit):
            detail += f"; you reached them in {seconds_text(to_hit)} s on average"
        touches = _count(metrics, "game_touches")
        if touches:
            detail += (f". You touched a crossed-out circle {touches} "
                       f"time{'s' * (touches != 1)} ({DISTRACTOR_POINTS:.0f} points off each)")
        return PlainLine(GAME_KEY, text, detail + ".")
    laps = "lap" if played == 1 else "laps"
    text = f"You kept the ball in the channel all the way round in {hits} of {played} " \
           f"{laps}: {scored}."
    detail = "A lap counts when the ball stays inside the channel the whole lap and goes " \
             "round the path"
    outside_s = float(metrics.get("game_time_outside_s", math.nan))
    if math.isfinite(outside_s) and outside_s > 0.0:
        detail += (f"; the ball was outside for {seconds_text(outside_s)} s in all "
                   f"({POINTS_PER_S_OUTSIDE:.0f} points off a second)")
    return PlainLine(GAME_KEY, text, detail + ".")

