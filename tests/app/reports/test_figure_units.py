"""An assessment figure reads in one unit wherever it is shown: the therapist's table
(app.reports.task_table), Progress and its PDF (progress_figure.figure_row), `rehab
progress` and the scales' correlation (progress_figure.shown_row). Progress showed
"Absolute error (m)" at 0.04 while the report's table said 40 mm, and the scales' plot
labelled a ratio "(1)"."""

from __future__ import annotations

import pytest

from app.reports.progress_figure import figure_row, shown_row
from app.reports.task_table import task_rows
from app.units import shown
from core.assessment.figures import FIGURES, TASKS


@pytest.mark.parametrize("task", TASKS)
def test_every_place_reads_a_task_figure_in_the_table_unit(task):
    for row in task_rows(task):
        progress_row = figure_row(row.key)
        assert (progress_row.unit, progress_row.scale) == (row.unit, row.scale)
        assert shown_row(row.key).scale == row.scale
        label = shown_row(row.key).heading_in_unit
        assert label == (f"{row.label} ({row.unit})" if row.unit else row.label)
        assert not label.endswith(("(1)", "(count)"))


def test_the_unit_is_the_one_a_person_reads():
    for key, spec in FIGURES.items():
        scale, unit = shown(1.0, spec.unit)
        assert figure_row(key).scale == scale
        assert spec.unit not in ("m", "m/s", "rad", "m²") or figure_row(key).unit == unit


def test_a_key_neither_table_knows_is_shown_by_its_key_unscaled():
    """A record's bookkeeping (duration_s) asked for by its key (`rehab progress --metrics`,
    the scales' choice): named by the key, in SI, with no unit."""
    row = shown_row("duration_s")
    assert (row.heading_in_unit, row.label_in_unit, row.unit, row.scale) == (
        "duration_s", "duration_s", "", 1.0)
    assert shown_row("rmse_x_m") == figure_row("rmse_x_m")
