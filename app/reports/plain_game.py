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

from app.games.names import game_title
from app.reports.plain_language import PlainLine, seconds_text
from app.units import CM_PER_M
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


def game_cautions(before: Mapping, after: Mapping) -> tuple[str, ...]:
    """Why a game trial's figures do not compare with an earlier trial's for reasons other
    than the patient (TrialParameters field names and SI values, as
    plain_language.parameter_cautions takes them): one trial a game and the other not, or
    another game (the screen showed other things to do: a game shows no moving ring), or
    the same game at another difficulty (the staircase's dials between rounds,
    core.games.staircase; its help and pace are the help's and the pace's cautions). Seen in
    the window: a reaching game's third round, given 1.2 s a target where the second had
    1.5 s, was called "worse" for leading the movement 89 % of the time, not 93 %."""
    game, game_before = after.get("game") or "", before.get("game") or ""
    if game != game_before:
        now, then = (f"the {game_title(g).lower()}" if g else "the exercise without a game"
                     for g in (game, game_before))
        return (f"This trial was {now} (before, {then}), so the figures do not compare "
                "directly.",)
    if not game:
        return ()
    cautions = []
    for key, (smaller, larger, shown, said) in _DIALS.get(game, {}).items():
        a, b = before.get(key), after.get(key)
        if a is None or b is None or math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12):
            continue
        words = smaller if b < a else larger
        cautions.append(f"The game {words} ({said.format(shown(b))}; before, {shown(a)}), "
                        "so the figures do not compare directly.")
    return tuple(cautions)


def _cm(value_m: float) -> str:
    return f"{value_m * CM_PER_M:.1f} cm"


_DIALS = {
    "reach": {
        "time_allowed_s": ("gave less time to reach a target", "gave more time to reach a "
                           "target", lambda s: f"{s:.2f} s", "{}"),
        "target_radius_m": ("had smaller targets", "had larger targets", _cm, "radius {}"),
        "n_distractors": ("had fewer crossed-out circles", "had more crossed-out circles",
                          lambda n: f"{n:.0f}", "{}"),
    },
    "path": {
        "channel_half_width_m": ("had a narrower channel", "had a wider channel", _cm,
                                 "{} either side of the path"),
    },
}
"""A game's difficulty dials whose change is not said elsewhere: (words when smaller,
words when larger, the value as shown, the words round this trial's value)."""
