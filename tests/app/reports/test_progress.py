"""A patient's progress as a table and as plot-ready series, one series per exercise."""

from __future__ import annotations

import datetime
import math

import numpy as np
import pytest

from app.errors import PatientNotFound
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.progress import (
    FILE_MISSING,
    FILE_OK,
    FILE_UNCHECKED,
    FILE_UNREADABLE,
    HDF5_SIGNATURE,
    TABLE_COLUMNS,
    Exercise,
    progress,
)
from core.trial import TrialParameters

UTC = datetime.UTC
T0 = datetime.datetime(2024, 3, 4, 10, 0, tzinfo=UTC)
EASY = TrialParameters(radius_m=0.08, duration_s=6.0)
HARD = TrialParameters(radius_m=0.12, duration_s=4.0, assistance_level=0.5)


@pytest.fixture
def history(tmp_path):
    """Six trials over two sessions: harder exercise in session 2, one metric added
    later, one trial faulted, one file missing and one file damaged."""
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Pat", "Progress").code
    plan = [  # session, params, status, rmse, file
        (1, EASY, "complete", 0.020, "ok"),
        (1, EASY, "complete", 0.018, "missing"),
        (1, HARD, "complete", 0.030, "ok"),
        (2, HARD, "faulted", 0.040, "damaged"),
        (2, HARD, "complete", 0.026, "ok"),
        (2, EASY, "complete", 0.015, "ok"),
    ]
    for i, (session, params, status, rmse, file) in enumerate(plan):
        started = T0 + datetime.timedelta(days=7 * (session - 1), minutes=5 * i)
        begun = registry.begin_trial(code, params, backend="simulator", session_number=session,
                                     started_at=started)
        metrics = {"rmse_x_m": rmse, "sparc": math.nan if status == "faulted" else -2.0 + i}
        if session == 2:
            metrics["ldlj"] = -6.0 - i  # a metric introduced in a later version
        registry.finish_trial(begun.trial_id, status, metrics,
                              ended_at=started + datetime.timedelta(seconds=30))
        if file == "ok":
            begun.path.write_bytes(HDF5_SIGNATURE + bytes(100))
        elif file == "damaged":
            begun.path.write_bytes(b"half a file")
    return registry, code


def test_rows_are_in_order_with_parameters_status_and_file_state(history):
    registry, code = history
    result = progress(registry, code)
    assert len(result) == 6
    assert result.session.tolist() == [1, 1, 1, 2, 2, 2]
    assert result.trial.tolist() == [1, 2, 3, 1, 2, 3]
    assert [r.file_state for r in result.rows] == [
        FILE_OK, FILE_MISSING, FILE_OK, FILE_UNREADABLE, FILE_OK, FILE_OK]
    assert result.file_ok.tolist() == [True, False, True, False, True, True]
    assert [r.trial.status for r in result.rows][3] == "faulted"
    assert result.metric_names == ("rmse_x_m", "sparc", "ldlj")
    # A missing or damaged file does not hide the registry's metrics.
    assert result.values["rmse_x_m"][1] == 0.018
    assert result.values["rmse_x_m"][3] == 0.040
    assert np.isnan(result.values["ldlj"][:3]).all()
    assert result.values["ldlj"][3:].tolist() == [-9.0, -10.0, -11.0]
    assert result.time_s[0] == T0.timestamp()
    assert np.all(np.diff(result.time_s) > 0)


def test_exercises_mark_every_trial_and_group_the_series(history):
    registry, code = history
    result = progress(registry, code)
    easy = Exercise("thesis", "d", 0.08, "smc")
    hard = Exercise("thesis", "d", 0.12, "smc")
    assert result.exercises == (easy, hard)
    assert result.exercise_index.tolist() == [0, 0, 1, 1, 1, 0]
    assert easy.label() == "Thesis mode · D shape, r 8.0 cm · SMC"
    # the pace and the help travel with each trial, not with the series
    assert result.duration_s.tolist() == [6.0, 6.0, 4.0, 4.0, 4.0, 6.0]
    assert [levels.at_start for levels in result.levels] == [1.0, 1.0, 0.5, 0.5, 0.5, 1.0]
    assert not result.levels_recorded.any()  # finished by hand, without the file's levels

    by_exercise = {s.exercise: s for s in result.series("rmse_x_m")}
    assert by_exercise[easy].trial_index.tolist() == [0, 1, 5]
    assert by_exercise[easy].position.tolist() == [1, 2, 3]
    assert by_exercise[easy].values.tolist() == [0.020, 0.018, 0.015]
    assert by_exercise[hard].trial_index.tolist() == [2, 3, 4]
    assert by_exercise[hard].session.tolist() == [1, 2, 2]
    assert by_exercise[hard].file_ok.tolist() == [True, False, True]
    assert by_exercise[hard].complete.tolist() == [True, False, True]

    sparc = {s.exercise: s for s in result.series("sparc")}
    assert sparc[hard].trial_index.tolist() == [2, 4]  # the faulted trial's NaN is dropped
    assert sparc[hard].position.tolist() == [1, 3]  # its place in the series is kept
    with_nan = {s.exercise: s for s in result.series("sparc", finite_only=False)}
    assert with_nan[hard].trial_index.tolist() == [2, 3, 4]
    ldlj = result.series("ldlj")
    assert [(s.exercise, s.trial_index.tolist()) for s in ldlj] == [
        (easy, [5]), (hard, [3, 4])]
    with pytest.raises(KeyError, match=r"no trial of patient .* 'rom_elbow_rad'.*rmse_x_m"):
        result.series("rom_elbow_rad")


def test_equal_exercises_reached_through_unit_conversions_are_one_exercise(tmp_path):
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient().code
    for radius in (0.1, 0.30000000000000004 / 3):
        begun = registry.begin_trial(code, TrialParameters(radius_m=radius),
                                     backend="simulator", started_at=T0)
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.01})
    begun = registry.begin_trial(code, TrialParameters(radius_m=0.1001), backend="simulator",
                                 started_at=T0)
    registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.01})
    assert progress(registry, code).exercise_index.tolist() == [0, 0, 1]


def test_table_has_one_row_per_trial_and_one_column_per_metric(history):
    registry, code = history
    header, rows = progress(registry, code).table()
    assert header == (*TABLE_COLUMNS, "rmse_x_m", "sparc", "ldlj")
    assert len(set(header)) == len(header)
    assert "radius_m" in header
    assert "set_duration_s" in header
    assert len(rows) == 6
    assert all(len(r) == len(header) for r in rows)
    row = dict(zip(header, rows[1], strict=True))
    assert (row["session"], row["trial"], row["status"], row["file_state"]) == (
        1, 2, "complete", FILE_MISSING)
    assert (row["exercise"], row["shape"], row["radius_m"], row["set_duration_s"]) == (
        1, "d", 0.08, 6.0)
    assert row["date"] == "2024-03-04"
    assert row["started_at"].startswith("2024-03-04T10:05")
    assert row["rmse_x_m"] == 0.018
    assert math.isnan(row["ldlj"])


def test_arrays_are_read_only_and_the_file_check_can_be_skipped(history):
    registry, code = history
    result = progress(registry, code, check_files=False)
    assert {r.file_state for r in result.rows} == {FILE_UNCHECKED}
    assert result.file_ok.all()
    with pytest.raises(ValueError, match="read-only"):
        result.values["rmse_x_m"][0] = 0.0
    with pytest.raises(ValueError, match="read-only"):
        result.series("rmse_x_m")[0].values[0] = 0.0


def test_a_patient_without_trials_and_an_unknown_patient(tmp_path):
    registry = Registry(DataDir(tmp_path))
    code = registry.create_patient().code
    empty = progress(registry, code)
    assert (len(empty), empty.metric_names, empty.exercises) == (0, (), ())
    assert empty.table() == (TABLE_COLUMNS, [])
    with pytest.raises(PatientNotFound):
        progress(registry, "PZZZZZZ")


def test_a_trial_still_recording_appears_without_metrics(history):
    registry, code = history
    running = registry.begin_trial(code, EASY, backend="simulator", session_number=2)
    result = progress(registry, code)
    last = result.rows[-1]
    assert (last.trial.id, last.trial.status, last.file_state) == (
        running.trial_id, "recording", FILE_MISSING)
    assert last.exercise_index == 0
    assert np.isnan([result.values[name][-1] for name in result.metric_names]).all()


def test_a_game_s_score_is_a_figure_of_its_series_only(tmp_path):
    """The Progress tab offers a game's score over its rounds (metric_keys, the metrics
    table's rows), and not for an exercise without a game, whose trials have no score."""
    from app.reports.progress_figure import metric_keys, progress_figure

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Pat", "Games").code
    game = TrialParameters(game="reach", shape="targets", duration_s=8.0, repetitions=1,
                           assist="as-needed")
    for i, (params, metrics) in enumerate((
            (EASY, {"rmse_x_m": 0.02}),
            (game, {"rmse_x_m": 0.01, "game_score": 40.0, "game_hits": 4.0}),
            (game, {"rmse_x_m": 0.01, "game_score": 70.0, "game_hits": 7.0}))):
        started = T0 + datetime.timedelta(minutes=5 * i)
        begun = registry.begin_trial(code, params, backend="simulator", session_number=1,
                                     started_at=started)
        registry.finish_trial(begun.trial_id, "complete", metrics,
                              ended_at=started + datetime.timedelta(seconds=30))
    result = progress(registry, code, check_files=False)
    games = [i for i, e in enumerate(result.exercises) if e.game == "reach"]
    plain = [i for i, e in enumerate(result.exercises) if not e.game]
    assert len(games) == len(plain) == 1
    assert "game_score" in metric_keys(result, games[0])
    assert "game_score" not in metric_keys(result, plain[0])
    figure = progress_figure(result, games[0], "game_score")
    assert figure.values.tolist() == [40.0, 70.0]
    assert figure.row.label == "Game score"


def test_a_task_the_robot_leads_is_not_named_as_a_transparent_exercise():
    """Seen in the window: Progress and Replay named the strength task "Transparent ·
    point-to-point targets, r 5.0 cm", where its report says the robot held the handle
    still; and the position sense, where the robot takes the hand, "Transparent" too."""
    strength = Exercise("transparent", "targets", 0.05, "ctpid", assessment="strength")
    position = Exercise("transparent", "targets", 0.1, "ctpid", assessment="position")
    assert strength.label() == ("Assessment: Isometric strength · robot holds the handle "
                                "still · CTPID")
    assert position.label() == ("Assessment: Position sense · robot takes the hand to each "
                                "target · CTPID")
    circle = Exercise("transparent", "circle", 0.07, "smc", assessment="circle")
    assert circle.label() == "Assessment: Circle drawing · Transparent · circle, r 7.0 cm · SMC"
