"""A game trial end to end: its figures measured from its file when it is finished, stored in
the file's metrics and the registry's, shown by `rehab trials`, the report and the export, and
the same as the live scorer's fed the file's samples in the window's batches."""

import csv
import math

import numpy as np
import pytest

from app.games.figures import game_figures, game_figures_stored, game_line
from app.games.names import game_title
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.build import content_for_registry_trial
from app.trials.headless import simulate
from app.trials.reader import read_trial
from core.games import GameScorer, game_layout
from core.trial import TrialParameters
from tests.app.cli.running import run

GAME = ["--game", "reach", "--shape", "targets", "--duration", "8", "--repetitions", "1",
        "--time-allowed", "0.8", "--target-radius", "0.015", "--distractors", "2",
        "--patient", "weak", "--seed", "4"]
BATCH = 8  # ticks in one 16 ms batch of the window's timer


def test_a_game_trial_carries_its_figures_everywhere(data, patient, capsys, tmp_path):
    code, out, err = run(["run", "--code", patient, *GAME], capsys)
    assert code == 0, err
    assert "Reaching game: score" in out
    registry = Registry(DataDir(data))
    (trial,) = registry.trials_for_patient(patient)
    stored = trial.metrics
    for name in ("game_score", "game_hits", "game_misses", "game_success", "game_time_s",
                 "game_time_to_hit_s", "game_touches"):
        assert name in stored, name
    assert stored["game_hits"] + stored["game_misses"] == 8
    assert stored["game_time_s"] == pytest.approx(8.0)

    # the file says the same, and its samples give the same figures again, whole or in the
    # live screen's 16 ms batches (the one formula)
    data_file = read_trial(registry.trial_path(trial))
    assert {k: v for k, v in data_file.metrics.items() if k.startswith("game_")} == \
        pytest.approx({k: v for k, v in stored.items() if k.startswith("game_")}, nan_ok=True)
    again = game_figures(data_file.channels, data_file.parameters)
    assert again.to_metrics() == pytest.approx(
        {k: v for k, v in stored.items() if k.startswith("game_")}, nan_ok=True)
    scorer = GameScorer(game_layout(data_file.parameters))
    ch = data_file.channels
    for a in range(0, len(ch["time"]), BATCH):
        scorer.feed(ch["time"][a:a + BATCH], ch["position"][a:a + BATCH, 0],
                    ch["position"][a:a + BATCH, 1], ch["phase"][a:a + BATCH])
    assert scorer.finish().to_metrics() == pytest.approx(again.to_metrics(), nan_ok=True)

    code, out, _ = run(["trials", patient], capsys)
    assert code == 0
    assert game_line(trial.parameters, stored) in out
    header = content_for_registry_trial(registry, trial.id).header
    assert [h.value for h in header if h.label == "Game"] == [game_line(trial.parameters,
                                                                        stored)]

    code, out, err = run(["export", "--patient", patient, "--format", "csv", "--output",
                          str(tmp_path / "export")], capsys)
    assert code == 0, err
    (metrics_file,) = (tmp_path / "export").rglob("*_metrics.csv")
    with metrics_file.open(newline="") as f:
        rows = {r[0]: r[1] for r in csv.reader(f)}
    for name in ("game_score", "game_hits", "game_misses", "game_time_s"):
        assert float(rows[name]) == pytest.approx(stored[name])


def test_a_game_line_names_its_game_as_the_report_and_the_progress_do():
    """The line starts with the game's name written once (app.games.names), capitalised as
    the report's header and the Progress tab's series say it, not its code ("reach game")."""
    figures = {"game_score": 30.0, "game_hits": 3.0, "game_misses": 1.0, "game_success": 0.75,
               "game_time_s": 8.0, "game_time_to_hit_s": 0.5, "game_touches": 0.0,
               "game_time_outside_s": 1.5}
    for game, title in (("reach", "Reaching game"), ("path", "Path game")):
        assert game_title(game) == title
        assert game_line({"game": game}, figures).startswith(f"{title}: score 30, 3 hits")


def test_an_exercise_without_a_game_has_no_game_figures(data, patient, capsys):
    code, out, _ = run(["run", "--code", patient, "--repetitions", "1", "--duration", "4"],
                       capsys)
    assert code == 0
    assert "game:" not in out
    registry = Registry(DataDir(data))
    (trial,) = registry.trials_for_patient(patient)
    assert not [k for k in trial.metrics if k.startswith("game_")]
    assert game_line(trial.parameters, trial.metrics) == ""


def test_the_path_game_on_the_simulator_scores_laps():
    p = TrialParameters(game="path", duration_s=4.0, repetitions=2, assist="as-needed",
                        channel_half_width_m=0.02)
    trial = simulate(p, patient="healthy", seed=2)
    figures = game_figures(trial.records, p)
    assert figures.hits + figures.misses == 2
    assert figures.time_s == pytest.approx(8.0)
    # the healthy patient on full help stays inside a 2 cm channel: every lap counts
    assert figures.hits == 2
    assert figures.points_lost == 0.0
    exercise = trial.records["phase"] == 2
    assert np.isfinite(trial.records["position"][exercise]).all()
    assert math.isnan(figures.mean_time_to_hit_s)


def test_the_path_game_s_first_round_on_a_small_d_is_won_by_effort_and_then_challenges():
    """On the Games template's path block (two 6 s laps of the D, transparent) on a 6 cm
    D, the first channel (4 cm either side) held the whole inside of the D: a weak arm won
    its first three rounds. The first channel now fits the D: the healthy and the weak
    virtual patients win round 1, and the weak one loses a round within four."""
    from app.games.virtual import play_rounds

    base = TrialParameters(game="path", shape="d", radius_m=0.06, duration_s=6.0,
                           repetitions=2, assist="transparent")
    (healthy,) = play_rounds(base, "healthy", 1, seed=100)
    assert (healthy.figures.hits, healthy.figures.misses) == (2, 0)
    weak = play_rounds(base, "weak", 4, seed=100)
    assert (weak[0].figures.hits, weak[0].figures.misses) == (2, 0)
    assert any(r.figures.misses for r in weak[1:])


@pytest.mark.parametrize(("args", "needle"), [
    (["--game", "reach"], "--shape (shape) = 'd' is not allowed"),
    (["--game", "reach", "--shape", "targets", "--time-allowed", "2"],
     "--time-allowed (time_allowed_s) = 2"),
    (["--game", "path", "--channel-width", "0.5"], "--channel-width (channel_half_width_m) = 0.5"),
    (["--game", "reach", "--shape", "reach", "--distractors", "3", "--duration", "2"],
     "--distractors (n_distractors) = 3"),
    (["--neglect-side", "left"], "--neglect-side (neglect_side) = 'left'"),
    (["--game", "pong"], "invalid choice"),
])
def test_a_bad_game_on_the_command_line_is_one_line(data, capsys, args, needle):
    code, _, err = run(["run", "--repetitions", "1", *args], capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert needle in lines[0]


def test_a_long_trial_read_a_block_at_a_time_gives_the_same_figures():
    p = TrialParameters(game="reach", shape="targets", duration_s=8.0, repetitions=1,
                        time_allowed_s=0.9, assist="as-needed")
    records = simulate(p, patient="weak", seed=5).records

    def read(name, a, b):
        return records[name][a:b]

    whole = game_figures(records, p)
    for block in (1, 7, 500, 10**6):
        assert game_figures_stored(read, len(records), p, block).to_metrics() == \
            pytest.approx(whole.to_metrics(), nan_ok=True)
    assert game_figures_stored(read, len(records), TrialParameters(), 500) is None
