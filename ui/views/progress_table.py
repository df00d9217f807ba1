"""A patient's progress (app.reports.progress) as the Progress tab shows it in words: the
line that sums it up, the figures it can plot, and its table, one row a trial with its
status, its exercise and every figure in display units."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.reports.metrics_table import ROWS, MetricRow
from app.reports.progress import FILE_OK, FILE_UNCHECKED, Progress
from ui.views.numbers import format_number

STATUS_WORDS = {"complete": "complete", "stopped_early": "stopped early",
                "faulted": "safety stop", "recording_lost": "recording lost",
                "recording": "recording"}
LEADING_HEADINGS = ("Session", "Trial", "Date", "Status", "Exercise")


def metric_rows(result: Progress) -> list[MetricRow]:
    """The figures this patient's trials have, in the metrics table's order."""
    return [row for row in ROWS if row.key in result.values]


def metric_heading(row: MetricRow) -> str:
    """A figure's name with its display unit, as a heading or an axis label."""
    return f"{row.label} ({row.unit})" if row.unit else row.label


def progress_summary(result: Progress) -> str:
    """How many trials, sessions and exercise settings, and how to read the plot."""
    n = len(result)
    if n == 0:
        return "No trials yet."
    sessions = len(set(result.session.tolist()))
    sets = len(result.parameter_sets)
    return (f"{n} trial{'s' if n != 1 else ''} in {sessions} "
            f"session{'s' if sessions != 1 else ''}, "
            f"{sets} exercise setting{'s' if sets != 1 else ''}. Compare points of the same "
            "colour and shape: they are the same exercise.")


@dataclass(frozen=True, slots=True)
class ProgressTable:
    """The table's headings and its rows of cell texts."""

    headings: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]

    @staticmethod
    def right_aligned(column: int) -> bool:
        """Numbers read best right-aligned: the session and trial numbers, the figures."""
        return column >= len(LEADING_HEADINGS) or column < 2


def progress_table(result: Progress) -> ProgressTable:
    figures = metric_rows(result)
    rows = []
    for i, summary in enumerate(result.trials):
        status = STATUS_WORDS.get(summary.status, summary.status)
        if result.file_states[i] not in (FILE_OK, FILE_UNCHECKED):
            status += f" (file {result.file_states[i]})"
        cells = [str(summary.session_number), str(summary.number),
                 summary.session_date.isoformat(), status,
                 result.parameter_sets[int(result.parameter_set_index[i])].label()]
        cells += [format_number(float(result.values[r.key][i]) * r.scale, 2) for r in figures]
        rows.append(tuple(cells))
    return ProgressTable((*LEADING_HEADINGS, *(metric_heading(r) for r in figures)),
                         tuple(rows))


def tick_label(session: int, trial: int) -> str:
    """A trial on the progress plot's x axis: 'S1 T2' (never '1.2', which reads as a
    decimal)."""
    return f"S{session} T{trial}"


MIN_SPAN = {"%": 10.0, "mm": 2.0, "°": 10.0}
"""The least y span the progress plot shows, by display unit: one trial (or trials that
hardly differ) must not zoom 17.8–18.6 % to the whole height."""


def value_span(values: np.ndarray, unit: str) -> tuple[float, float]:
    """The y range for the plotted values: theirs, widened about its middle to at least
    MIN_SPAN of the unit (percentages kept within 0–100)."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return 0.0, 0.0
    low, high = float(finite.min()), float(finite.max())
    least = MIN_SPAN.get(unit, 0.0) or max(abs(high) * 0.2, 1e-9)
    if high - low < least:
        middle = (high + low) / 2.0
        low, high = middle - least / 2.0, middle + least / 2.0
    if unit == "%":
        low, high = max(0.0, low), min(100.0, high)
        if high - low < least:
            low, high = (0.0, least) if low == 0.0 else (100.0 - least, 100.0)
    return low, high
