"""Issue 27 #7: Progress is one series per assistance mode and exercise; a change of the
robot's help or of the pace is drawn along the series (a staircase, the pace written where
it changed), never a new series; the mode's own success figure comes first; and it prints:
a PDF page an exercise. A course of simulated trials, registered and finished as the window
does (tests/app/reports/made.py)."""

from __future__ import annotations

import numpy as np
import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.progress import progress
from core.trial import THESIS_SUBJECT
from tests.app.reports.made import many_trials, page_texts, staircase_course

SHORT = THESIS_SUBJECT.replace(repetitions=1)


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    registry = Registry(DataDir(tmp_path_factory.mktemp("data")))
    code = registry.create_patient("Ada", "Example", side="right").code
    ids = staircase_course(registry, code, SHORT)
    return registry, code, ids


def test_one_series_per_mode_and_exercise_whatever_the_help_and_the_pace(course):
    registry, code, _ = course
    result = progress(registry, code)
    # the as-needed trials one series at every level and pace, the thesis-mode ones another
    assert [s.trial_index.tolist() for s in result.series("led_pct")] == [[0, 1, 2, 3, 4]]
    assert [s.trial_index.tolist() for s in result.series("directional_performance_pct")] \
        == [[0, 1, 2, 3, 4], [5, 6]]
    from app.reports.progress import Exercise  # (after what main's code had too)

    assert result.exercises == (Exercise("as-needed", "d", 0.1, "smc"),
                                Exercise("thesis", "d", 0.1, "smc"))
    assert result.exercise_index.tolist() == [0, 0, 0, 0, 0, 1, 1]
    (as_needed, thesis) = result.series("directional_performance_pct")
    assert as_needed.position.tolist() == [1, 2, 3, 4, 5]
    assert thesis.position.tolist() == [1, 2]
    # what each trial ran: the registry's levels, the live change included
    assert [levels.summary() for levels in result.levels[:5]] == [
        "100 %", "90 %", "80 %", "80 % → 70 % at 1.0 s", "70 %"]
    assert result.levels_recorded.all()
    assert result.duration_s[:5].tolist() == [4.0, 4.0, 3.6, 3.6, 3.6]
    assert result.complete.tolist() == [True, True, True, True, False, True, True]


def test_the_mode_s_own_success_figure_comes_first(course):
    from app.reports.progress_figure import metric_keys, progress_figure

    registry, code, _ = course
    result = progress(registry, code)
    assert metric_keys(result, 0)[0] == "led_pct"
    assert metric_keys(result, 1)[0] == "directional_performance_pct"
    assert "led_pct" not in metric_keys(result, 1)  # the thesis mode has no such figure
    assert progress_figure(result, 0).row.key == "led_pct"
    assert progress_figure(result, 1).row.key == "directional_performance_pct"


def test_the_help_is_a_staircase_along_the_series_and_the_pace_is_written_where_it_changed(
        course):
    from app.reports.progress_figure import SLOT_HALF_WIDTH, progress_figure

    registry, code, _ = course
    result = progress(registry, code)
    figure = progress_figure(result, 0)
    x, y = figure.help_x, figure.help_y
    # each trial's slot at its level, in order: the staircase
    for position, level in ((1, 100), (2, 90), (3, 80), (5, 70)):
        inside = (x > position - SLOT_HALF_WIDTH) & (x < position + SLOT_HALF_WIDTH)
        edges = np.isclose(np.abs(x - position), SLOT_HALF_WIDTH)
        assert set(y[inside].tolist()) <= {level}, position
        assert level in y[edges].tolist(), position
    # the live change is a step inside trial 4's slot, at its share of the exercise
    inside = (x > 4 - SLOT_HALF_WIDTH) & (x < 4 + SLOT_HALF_WIDTH)
    assert y[inside].tolist() == [80, 70]
    exercised = result.values["duration_s"][3]
    step = 4 - SLOT_HALF_WIDTH + 2 * SLOT_HALF_WIDTH * 1.0 / exercised
    assert x[inside].tolist() == pytest.approx([step, step])
    assert figure.live_x.tolist() == pytest.approx([step])
    assert figure.live_y.tolist() == [70]
    assert np.all(np.diff(x) >= 0)  # one line, left to right
    assert [(m.position, m.text) for m in figure.marks] == [(1, "4 s a lap · ±20°"),
                                                             (3, "3.6 s a lap")]
    assert figure.ticks == ("S1 T1", "S1 T2", "S1 T3", "S2 T1", "S2 T2")
    assert figure.complete.tolist() == [True, True, True, True, False]


def test_progress_prints_a_page_an_exercise(course, tmp_path):
    from app.reports.progress_pdf import write_progress_pdf

    registry, code, _ = course
    pdf = write_progress_pdf(progress(registry, code), tmp_path / "progress.pdf")
    assert oct(pdf.stat().st_mode & 0o777) == "0o600"
    pages = page_texts(pdf)
    assert len(pages) == 2
    first, second = pages
    assert f"Progress of {code}" in first
    assert "As needed · D shape, r 10.0 cm · SMC" in first
    assert "Led the movement (%)" in first
    assert "80 % → 70 % at 1.0 s" in first
    assert "3.6 s a lap" in first
    assert "did not run to its end" in first
    assert "Thesis mode · D shape, r 10.0 cm · SMC" in second
    assert "Directional performance (%)" in second
    assert "Led the movement" not in second
    # each trial's figure as the report's table and the tabs write it ("99", not "99.05")
    result = progress(registry, code)
    led = [float(v) for v in result.values["led_pct"] if np.isfinite(v)]
    assert led
    for value in led:
        assert f"{value:.0f}" in first
        assert f"{value:.2f}" not in first


def test_the_printed_line_joins_only_the_trials_that_ran_to_their_end(course):
    """The e-stopped fifth as-needed trial is a hollow mark off the line: its figure covers
    part of the exercise and makes no trend with the others."""
    from app.reports.progress_pdf import progress_pages

    registry, code, _ = course
    result = progress(registry, code)
    top = progress_pages(result)[0].axes[0]
    line, hollow = top.lines[:2]
    led = result.values["led_pct"][result.members(0)]
    assert line.get_xdata().tolist() == [1, 2, 3, 4]
    np.testing.assert_allclose(line.get_ydata(), led[:4])
    assert line.get_linestyle() == "-"
    assert hollow.get_xdata().tolist() == [5]
    assert hollow.get_linestyle() == "None"


def test_hundreds_of_trials_print_whole_end_markers_and_level_marks_inside_the_plot(
        tmp_path):
    """300 trials, the pace changing every 20th: padded by half a trial the end markers
    were cut at the plot's edges, and the pace's words, turned by 60°, ran out of the
    help's plot into the series above. The marks are level, inside the help's plot, and
    never over each other."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from app.reports.progress_pdf import MARKER_ROOM_PT, progress_pages

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Many", "Trials").code
    n = 300
    many_trials(registry, code, n, lambda k: 4.0 - 0.1 * (k // 20))
    page = progress_pages(progress(registry, code))[0]
    renderer = FigureCanvasAgg(page).get_renderer()
    top, bottom = page.axes[:2]
    box = top.get_window_extent(renderer)
    line = top.lines[0]
    ends = top.transData.transform([(x, 60.0) for x in line.get_xdata()[[0, -1]]])
    room = MARKER_ROOM_PT * page.dpi / 72.0
    assert box.x0 + room <= ends[0][0]
    assert ends[1][0] <= box.x1 - room
    marks = [t for t in bottom.texts if t.get_text().endswith(("s a lap", "±20°"))]
    assert marks
    assert marks[0].get_text() == "4 s a lap · ±20°"
    plot = bottom.get_window_extent(renderer)
    drawn = [t.get_window_extent(renderer) for t in marks]
    for text, extent in zip(marks, drawn, strict=True):
        assert text.get_rotation() == 0
        assert plot.x0 <= extent.x0
        assert extent.x1 <= plot.x1
        assert extent.y1 <= plot.y1, text.get_text()
    for k, a in enumerate(drawn):
        assert not any(a.overlaps(b) for b in drawn[k + 1:])
