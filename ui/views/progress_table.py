"""A patient's progress (app.reports.progress) as the Progress tab shows it in words: the
line that sums it up, the exercises and figures it can plot, and its table, one row a
trial with the station that recorded it, its status and where its file is, its exercise,
the help, pace and tolerance it ran with, and every figure in display units."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.reports.metrics_table import ROWS, MetricRow
from app.reports.progress import Progress, file_note
from app.units import assistance_percent
from ui.views.numbers import format_number

STATUS_WORDS = {"complete": "complete", "stopped_early": "stopped early",
                "faulted": "safety stop", "recording_lost": "recording lost",
                "recording": "recording"}
LEADING_HEADINGS = ("Session", "Trial", "Date", "Station", "Status", "Exercise",
                    "Robot's help", "Pace (s a lap)", "Tolerance (°)")


def metric_rows(result: Progress) -> list[MetricRow]:
    """The figures this patient's trials have: the success figures of the modes the
    patient trained in first, then the metrics table's order."""
    first = list(dict.fromkeys(e.success_key for e in result.exercises))
    have = [row for row in ROWS if row.key in result.values]
    return sorted(have, key=lambda row: first.index(row.key) if row.key in first
                  else len(first))


def metric_heading(row: MetricRow) -> str:
    """A figure's name with its display unit, as a heading or an axis label."""
    return row.label_in_unit


def exercise_choice(result: Progress, index: int) -> str:
    """'As needed · D shape, r 10.0 cm · SMC (7)', for the exercise chooser: the number of
    trials in brackets."""
    return f"{result.exercises[index].label()} ({len(result.members(index))})"


def progress_summary(result: Progress) -> str:
    """How many trials, sessions and exercises, and how to read the plot."""
    n = len(result)
    if n == 0:
        return "No trials yet."
    sessions = len(set(result.session.tolist()))
    exercises = len(result.exercises)
    return (f"{n} trial{'s' if n != 1 else ''} in {sessions} "
            f"session{'s' if sessions != 1 else ''}, "
            f"{exercises} exercise{'s' if exercises != 1 else ''}. Each exercise is one "
            "series; under it, the robot's help as it ran, with the pace and the tolerance "
            "where they changed.")


@dataclass(frozen=True, slots=True)
class ProgressTable:
    """The table's headings and its rows of cell texts."""

    headings: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]

    @staticmethod
    def right_aligned(column: int) -> bool:
        """Numbers read best right-aligned: the session and trial numbers, the pace, the
        tolerance and the figures."""
        return column >= len(LEADING_HEADINGS) - 2 or column < 2


def help_text(result: Progress, i: int) -> str:
    """The levels trial i ran at ('100 % → 60 % at 5.8 s'), or the built level when the
    registry did not keep them ('100 % (built)')."""
    levels = result.levels[i]
    if not result.levels_recorded[i]:
        return f"{assistance_percent(levels.at_start)} (built)"
    return levels.summary()


def progress_table(result: Progress) -> ProgressTable:
    figures = metric_rows(result)
    rows = []
    for i, summary in enumerate(result.trials):
        status = STATUS_WORDS.get(summary.status, summary.status)
        if note := file_note(result.file_states[i], summary.station):
            status += f" ({note})"
        if summary.invalid_reason:
            status += f" — INVALID: {summary.invalid_reason}"
        cells = [str(summary.session_number), str(summary.number),
                 summary.session_date.isoformat(), summary.station or "", status,
                 result.exercises[int(result.exercise_index[i])].label(),
                 help_text(result, i), format_number(float(result.duration_s[i]), 2),
                 format_number(float(np.degrees(result.tolerance_rad[i])), 0)]
        # each figure in its unit's decimals, as the report and the tabs write it
        cells += [format_number(float(result.values[r.key][i]) * r.scale, r.places)
                  for r in figures]
        rows.append(tuple(cells))
    return ProgressTable((*LEADING_HEADINGS, *(metric_heading(r) for r in figures)),
                         tuple(rows))


ROWS_SHOWN = 3
"""Trials' rows the table shows whole by default when the height allows (a laptop's
1366 × 768 does, with the plots at their readable least: the help plot's least is the
height its axis title "help (%)" needs whole, which leaves three rows, not four)."""
TABLE_SHARE = 0.35  # of a tall tab's plots and table (1920 × 1080: about 8 rows)
HELP_SHARE = 0.4  # of the plots' room, the help's staircase under the series


def split_sizes(height: int, rows: int, row_px: int, table_chrome_px: int,
                plot_least_px: int, help_least_px: int) -> tuple[int, int, int]:
    """The Progress tab's default heights (px) of its series plot, the help plot under it
    and the trials' table, from the room they share (`height`): the table ROWS_SHOWN rows
    (fewer trials: as many; `table_chrome_px` its heading and scroll bar) or TABLE_SHARE
    of the room, whichever is more, as long as the plots keep their readable least
    (`plot_least_px`, `help_least_px`); the table never less than one row. The plots
    share the rest, the help HELP_SHARE of it, never less than its least. A short room
    (a large font on a laptop) shrinks the plots below their least in proportion."""
    one_row = table_chrome_px + row_px
    wanted = table_chrome_px + row_px * min(max(rows, 1), ROWS_SHOWN)
    table = max(wanted, round(TABLE_SHARE * height))
    table = max(one_row, min(table, height - plot_least_px - help_least_px))
    rest = max(0, height - table)
    if rest < plot_least_px + help_least_px:
        help_ = round(rest * help_least_px / (plot_least_px + help_least_px))
    else:
        help_ = max(help_least_px, round(HELP_SHARE * rest))
    return rest - help_, help_, table
