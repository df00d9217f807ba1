"""A patient's progress as the Progress tab's words and table, without Qt."""

from __future__ import annotations

import datetime

import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.metrics_table import ROWS
from app.reports.progress import progress
from core.trial import THESIS_SUBJECT
from ui.views.progress_table import (
    LEADING_HEADINGS,
    ROWS_SHOWN,
    ProgressTable,
    metric_heading,
    metric_rows,
    progress_summary,
    progress_table,
    split_sizes,
)

T0 = datetime.datetime(2024, 5, 2, 9, 30, tzinfo=datetime.UTC)


@pytest.fixture
def history(tmp_path):
    """Three trials over two sessions at two exercises; the files were never written."""
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Lovelace").code
    for session, radius, status, rmse in ((1, 0.10, "complete", 0.004),
                                          (1, 0.12, "stopped_early", 0.006),
                                          (2, 0.10, "complete", 0.003)):
        begun = registry.begin_trial(code, THESIS_SUBJECT.replace(radius_m=radius),
                                     backend="simulator", session_number=session,
                                     started_at=T0 + datetime.timedelta(days=session))
        registry.finish_trial(begun.trial_id, status,
                              {"rmse_x_m": rmse, "directional_performance_pct": 61.25},
                              T0 + datetime.timedelta(days=session, minutes=1))
    return progress(registry, code)


def test_the_summary_counts_trials_sessions_and_exercises(history):
    assert progress_summary(history) == (
        "3 trials in 2 sessions, 2 exercises. Each exercise is one series; under it, the "
        "robot's help as it ran, with the pace and the tolerance where they changed.")


def test_one_row_a_trial_with_status_file_state_exercise_and_figures(history):
    table = progress_table(history)
    figures = metric_rows(history)
    # the thesis mode's own success figure first
    assert [row.key for row in figures] == ["directional_performance_pct", "rmse_x_m"]
    assert table.headings == (*LEADING_HEADINGS, "Directional performance (%)",
                              "Position error, x (RMSE) (mm)")
    first, second, third = table.rows
    assert first[:2] == ("1", "1")
    assert third[:2] == ("2", "1")
    assert first[3] == ""  # a registry without a station id: none to name
    assert first[4] == "complete (file missing)"
    assert second[4] == "stopped early (file missing)"
    assert first[5] == history.exercises[0].label() == third[5] != second[5]
    # registered without the levels it ran: the built level, said so
    assert first[6:9] == ("100 % (built)", "4.00", "20")
    # each figure in its unit's decimals (MetricRow.places), as the report writes it:
    # the % whole, the mm to a tenth (the table wrote "61.25", "4.00")
    assert first[9:] == ("61", "4.0")
    assert third[10] == "3.0"


def test_numbers_are_right_aligned_and_words_left():
    assert [ProgressTable.right_aligned(c) for c in range(11)] == [
        True, True, False, False, False, False, False, True, True, True, True]


def test_a_figures_heading_carries_its_unit():
    by_key = {row.key: row for row in ROWS}
    assert metric_heading(by_key["rmse_x_m"]) == "Position error, x (RMSE) (mm)"
    assert all(metric_heading(row).startswith(row.label) for row in ROWS)


def test_one_trial_does_not_zoom_the_axis_to_a_sliver():
    """17.8–18.6 % filled the whole height: the span is at least 10 % (kept in 0–100),
    2 mm for errors; a wide spread keeps its own range."""
    import numpy as np

    from app.reports.progress_figure import value_span

    low, high = value_span(np.array([17.8, 18.6]), "%")
    assert high - low >= 10.0
    assert low <= 17.8
    assert high >= 18.6
    assert value_span(np.array([99.0]), "%") == (90.0, 100.0)
    assert value_span(np.array([2.0, 40.0]), "%") == (2.0, 40.0)
    low, high = value_span(np.array([3.0, 3.1, np.nan]), "mm")
    assert high - low == 2.0


@pytest.mark.parametrize(("height", "rows_whole"), [(383, ROWS_SHOWN), (695, 6)])
def test_the_table_shows_rows_whole_and_the_plots_keep_their_least(height, rows_whole):
    """The Progress tab's room in a 1366 × 768 window (383 px) and a 1920 × 1080 one
    (695 px), 30 px rows under 40 px of heading and scroll bar: the table shows
    ROWS_SHOWN rows whole (it showed one at a laptop's height, the plots taking the rest),
    more on a tall screen, and the plots keep their least."""
    plot, help_, table = split_sizes(height, 7, 30, 40, 104, 95)
    assert plot + help_ + table == height
    assert (table - 40) // 30 >= rows_whole
    assert plot >= 104
    assert help_ >= 95


def test_a_short_room_keeps_a_row_and_shares_the_rest_and_few_trials_take_less():
    plot, help_, table = split_sizes(200, 7, 30, 40, 104, 95)
    assert table == 70
    assert plot + help_ == 130
    assert plot > help_
    assert split_sizes(383, 1, 30, 40, 104, 95)[2] == round(0.35 * 383)
