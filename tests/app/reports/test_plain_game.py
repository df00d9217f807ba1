"""A game trial's report tells the patient the game's result first, in the numbers the
screen showed (seen in the window: 8 targets hit for a score of 80, and a report whose
patient's part never said so; app.reports.plain_game)."""

from __future__ import annotations

import math
import re

import pytest
from hypothesis import given, strategies as st

from app.games.figures import game_figures
from app.reports.content import build_report
from app.reports.plain_game import GAME_KEY, game_result_line
from app.trials.headless import simulate_to_file
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT

REACH = THESIS_SUBJECT.replace(shape="targets", game="reach", radius_m=0.08, n_targets=6,
                               duration_s=8.0, repetitions=1, time_allowed_s=0.8,
                               target_radius_m=0.015, n_distractors=2, assist="as-needed")
PATH = THESIS_SUBJECT.replace(game="path", repetitions=2, duration_s=4.0,
                              channel_half_width_m=0.015, assist="transparent")


def _numbers(text: str) -> list[int]:
    return [int(n) for n in re.findall(r"-?\d+", text)]


@pytest.mark.parametrize("parameters", [REACH, PATH], ids=["reach", "path"])
def test_the_game_s_result_leads_the_patient_s_lines(parameters, tmp_path):
    path = tmp_path / "game.h5"
    simulate_to_file(parameters, path, patient="weak", seed=4)
    trial = read_trial(path)
    figures = game_figures(trial.channels, trial.parameters)
    content = build_report(trial)
    first = content.plain[0]
    assert first.key == GAME_KEY
    # the hits, out of the targets or laps played, then the score as the screen wrote it
    assert _numbers(first.text) == [figures.hits, figures.hits + figures.misses,
                                    round(figures.score)]
    assert f"{figures.score:.0f}." in first.text


@given(game=st.sampled_from(["reach", "path"]), hits=st.integers(0, 40),
       misses=st.integers(0, 40), score=st.floats(-500.0, 500.0),
       touches=st.integers(0, 9), outside_s=st.floats(0.0, 60.0))
def test_the_line_says_the_figures_it_is_given(game, hits, misses, score, touches,
                                               outside_s):
    metrics = {"game_score": score, "game_hits": float(hits), "game_misses": float(misses),
               "game_time_to_hit_s": 0.5, "game_touches": float(touches),
               "game_time_outside_s": outside_s}
    line = game_result_line(game, metrics)
    if hits + misses == 0:
        assert line is None  # nothing finished: nothing to say
        return
    assert line is not None
    assert _numbers(line.text) == [hits, hits + misses, int(f"{score:.0f}")]
    if game == "reach":
        assert ("crossed-out" in line.detail) == (touches > 0)
    else:
        assert ("outside for" in line.detail) == (outside_s > 0.0)


def test_no_game_no_line():
    assert game_result_line("", {"game_score": 10.0, "game_hits": 1.0}) is None
    assert game_result_line("reach", {"game_score": math.nan, "game_hits": 1.0,
                                      "game_misses": 0.0}) is None


@pytest.mark.parametrize("parameters", [REACH, PATH], ids=["reach", "path"])
def test_a_game_s_report_speaks_of_no_ring_the_game_did_not_show(parameters, tmp_path):
    """A game shows its targets or its channel, not the moving ring the position error is
    measured from: the patient's lines say nothing of a ring; the therapist's table keeps
    the figure."""
    path = tmp_path / "game.h5"
    simulate_to_file(parameters, path, patient="weak", seed=4)
    content = build_report(read_trial(path))
    said = " ".join(f"{line.text} {line.detail}" for line in content.plain)
    assert not re.search(r"\bring\b", said), said
    assert {"rmse_x_m", "rmse_y_m"} <= {row.key for row in content.table}
