"""A patient's progress (app.reports.progress) as the Progress tab shows it in words: the
line that sums it up, the figures it can plot, and its table, one row a trial with its
status, its exercise and every figure in display units."""

from __future__ import annotations

from dataclasses import dataclass

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
