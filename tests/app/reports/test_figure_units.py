"""An assessment figure reads in one unit wherever it is shown: the therapist's table
(app.reports.task_table), Progress and its PDF (progress_figure.figure_row), `rehab
progress` and the scales' correlation (scales_progress.figure_label). Progress showed
"Absolute error (m)" at 0.04 while the report's table said 40 mm, and the scales' plot
labelled a ratio "(1)"."""

from __future__ import annotations

import pytest

from app.reports.progress_figure import figure_row
from app.reports.scales_progress import figure_display_scale, figure_label
from app.reports.task_table import task_rows
from app.units import shown
from core.assessment.figures import FIGURES, TASKS


@pytest.mark.parametrize("task", TASKS)
def test_every_place_reads_a_task_figure_in_the_table_unit(task):
    for row in task_rows(task):
        progress_row = figure_row(row.key)
        assert (progress_row.unit, progress_row.scale) == (row.unit, row.scale)
        assert figure_display_scale(row.key) == row.scale
        label = figure_label(row.key)
        assert label == (f"{row.label} ({row.unit})" if row.unit else row.label)
        assert not label.endswith(("(1)", "(count)"))


def test_the_unit_is_the_one_a_person_reads():
    for key, spec in FIGURES.items():
        scale, unit = shown(1.0, spec.unit)
        assert figure_row(key).scale == scale
        assert spec.unit not in ("m", "m/s", "rad", "m²") or figure_row(key).unit == unit
