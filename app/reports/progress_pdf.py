"""A patient's progress on paper: one A4 page (or more, for a long table) per exercise, with
what the Progress tab shows (app.reports.progress_figure): the mode's own success figure
over the exercise's trials, the robot's help as it ran as a staircase beneath on the same
trial axis with the pace and the tolerance where they changed, the key on a line of its
own above the plots, and the exercise's trials in a table; then the session plans' dose
and the clinical scales per session with each exercise's success figure against them.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from pathlib import Path

import matplotlib.lines
import numpy as np
from matplotlib.figure import Figure

from app.reports.metrics_table import number_text
from app.reports.pdf_file import write_pdf
from app.reports.pdf_sheet import (
    BLUE,
    GREEN,
    GREY,
    INK,
    LEFT_IN,
    PAGE_IN,
    PLOT_RIGHT_IN,
    TEXT_W_IN,
    VERMILLION,
    Sheet,
    fit,
    text_width_pt,
)
from app.reports.progress import Progress
from app.reports.progress_figure import (
    ProgressFigure,
    progress_figure,
    trial_limits,
    value_span,
)
from app.units import assistance_percent

log = logging.getLogger(__name__)

HELP_COLOUR = GREEN
ROW_H_IN = 0.17
BOTTOM_ROOM_IN = 0.7
DOSE_LINE_IN = 0.18  # a line of the dose's table at 8 pt, with its leading
MAX_LABELLED_TICKS = 30
MARKER_ROOM_PT = 5.5  # the largest marker's radius (8 pt across) and its edge
MARK_PT = 6.5  # the pace's and tolerance's words over the help
MARK_ROWS = (103.0, 113.0)  # their rows' baselines (%), above the help's 100 %
MARK_GAP_PT = 4.0  # the least space between two marks on a row


def write_progress_pdf(progress: Progress, path: str | os.PathLike, *,
                       overwrite: bool = True, doses: Sequence = (),
                       scales: dict | None = None, series: Sequence = ()) -> Path:
    """Write the patient's progress to `path` (its folder must exist), a page per
    exercise, then the session plans' dose (`doses`: app.plans.dose.patient_doses, the
    heading and the dose of each run), then the clinical scales (`scales`: the registry's
    session_scales, and `series`: app.reports.scales_progress.ScaleSeries, each figure
    against a scale with its correlation); returns the path (app.reports.pdf_file:
    private, never half-written, an existing file replaced only with `overwrite`)."""
    metadata = {"Title": f"Progress {progress.patient_code}",
                "Subject": "Progress across trials of a planar upper-limb rehabilitation "
                           "robot"}
    path = write_pdf(path, lambda: progress_pages(progress, doses, scales, series), metadata,
                     "the progress", overwrite=overwrite)
    log.info("progress written: %s", path)
    return path


def progress_pages(progress: Progress, doses: Sequence = (), scales: dict | None = None,
                   series: Sequence = ()) -> tuple[Figure, ...]:
    """The pages: for each exercise, its figure and its trials' table (one page saying so
    when the patient has no trials), then the session plans' dose when there is one, then
    the clinical scales when any were recorded (app.reports.session_report.scales_pages)."""
    from app.reports.session_report import scales_pages

    if not len(progress):
        sheet = Sheet()
        sheet.text(f"Progress of {progress.patient_code}", 20, weight="bold")
        sheet.text("No trials yet.", 12)
        pages = [sheet.fig]
    else:
        pages = []
        for index in range(len(progress.exercises)):
            pages += _exercise_pages(progress, index)
    return tuple(pages + _dose_pages(progress.patient_code, doses)
                 + scales_pages(progress.patient_code, scales or {}, tuple(series)))


def _dose_pages(code: str, doses: Sequence) -> list[Figure]:
    """The dose of each plan run (issue 30): movements, active time and rest per block
    against the plan, and the run's total, as `rehab plan dose` prints them, in order;
    a new page when one is full."""
    pages: list[Figure] = []
    sheet = None
    for heading, dose in doses:
        lines = dose.table() + [f"note: {n}" for n in dose.notes]
        need = (len(lines) + 2) * DOSE_LINE_IN + 0.2
        if sheet is None or sheet.y_in + need > PAGE_IN[1] - BOTTOM_ROOM_IN:
            sheet = Sheet()
            pages.append(sheet.fig)
            sheet.text(f"Session plans of {code}: the dose", 16, weight="bold")
            sheet.text("Movements (a lap of the D or the circle one, a reach out and back "
                       "two), active time (the exercise) and rest of each block, against "
                       "the plan; counted from the trial files.", 9, color=GREY)
            sheet.gap(0.15)
        sheet.text(heading, 10, weight="bold")
        for line in lines:
            # a table's columns are its spaces: drawn as they are, not re-wrapped
            sheet.fig.text(sheet.fx(LEFT_IN), sheet.fy(sheet.y_in), line, fontsize=8,
                           family="monospace", va="top", ha="left")
            sheet.y_in += DOSE_LINE_IN
        sheet.gap(0.2)
    return pages


def _exercise_pages(progress: Progress, index: int) -> list[Figure]:
    figure = progress_figure(progress, index)
    sheet = Sheet()
    _heading(sheet, progress, figure)
    _plots(sheet, figure)
    members = progress.members(index).tolist()
    pages = [sheet]
    while members:
        members = _table(pages[-1], progress, figure, members)
        if members:
            sheet = Sheet()
            _heading(sheet, progress, figure, continued=True)
            pages.append(sheet)
    return [page.fig for page in pages]


def _heading(sheet: Sheet, progress: Progress, figure: ProgressFigure, *,
             continued: bool = False) -> None:
    sheet.text(f"Progress of {progress.patient_code}" + (" (continued)" if continued else ""),
               18, weight="bold")
    sheet.gap(0.04)
    sheet.text(figure.exercise.label(), 12, weight="bold", color=GREY)
    sheet.gap(0.12)


def _plots(sheet: Sheet, figure: ProgressFigure) -> None:
    handles = [
        matplotlib.lines.Line2D([], [], color=BLUE, marker="o", linestyle="-", label="complete"),
        matplotlib.lines.Line2D([], [], color=VERMILLION, marker="o", markerfacecolor="white",
                                linestyle="none", label="did not run to its end"),
        matplotlib.lines.Line2D([], [], color=HELP_COLOUR, linewidth=2,
                                label="the robot's help as it ran"),
        matplotlib.lines.Line2D([], [], color=INK, marker="D", markersize=5, linestyle="none",
                                label="changed during the trial"),
    ]
    sheet.legend(handles, LEFT_IN, ncols=4)  # the key on its own line, off the data
    sheet.gap(0.1)
    x0 = LEFT_IN + 0.6
    width = PLOT_RIGHT_IN - x0
    n = len(figure.positions)
    top = sheet.axes(2.9, x_in=x0, width_in=width)
    shown = np.isfinite(figure.values)
    # the line joins the trials that ran the whole exercise; one cut short is a hollow
    # mark off it (its figures cover part of the exercise, no trend with the others)
    whole = shown & figure.complete
    top.plot(figure.positions[whole], figure.values[whole], color=BLUE, marker="o",
             markersize=5, linewidth=1.2)
    partial = shown & ~figure.complete
    top.plot(figure.positions[partial], figure.values[partial], linestyle="none",
             marker="o", markersize=8, markerfacecolor="white", markeredgecolor=VERMILLION,
             markeredgewidth=1.4)
    top.set_ylabel(figure.title)
    low, high = value_span(figure.values, figure.row.unit)
    if low < high:
        margin = 0.05 * (high - low)
        top.set_ylim(low - margin, high + margin)
    top.set_xlim(*trial_limits(n, width, MARKER_ROOM_PT / 72.0))
    top.tick_params(labelbottom=False)
    top.grid(True, color="#E6E6E6", linewidth=0.5)
    sheet.y_in += 2.9 + 0.15
    bottom = sheet.axes(1.5, x_in=x0, width_in=width)
    bottom.plot(figure.help_x, figure.help_y, color=HELP_COLOUR, linewidth=2)
    bottom.plot(figure.live_x, figure.live_y, linestyle="none", marker="D", markersize=5,
                color=INK)
    low, high = trial_limits(n, width, MARKER_ROOM_PT / 72.0)
    _marks(bottom, figure, low, high, width)
    bottom.set_ylim(0.0, 125.0)
    bottom.set_yticks([0, 25, 50, 75, 100])
    bottom.set_ylabel("robot's help (%)")
    bottom.set_xlim(low, high)
    bottom.sharex(top)
    if n <= MAX_LABELLED_TICKS:
        bottom.set_xticks(figure.positions, figure.ticks, rotation=90 if n > 12 else 0,
                          fontsize=7)
    bottom.set_xlabel("trial (session, trial)")
    bottom.grid(True, color="#E6E6E6", linewidth=0.5)
    sheet.y_in += 1.5 + (0.75 if n > 12 else 0.5)


def _marks(axes, figure: ProgressFigure, low: float, high: float, width_in: float) -> None:
    """The pace and the tolerance written over the trial where they changed, level, in
    one of MARK_ROWS rows above 100 %: each whole inside the plot (as near its trial as
    fits), on the first row where it clears the mark before it; one that clears none is
    left to the table under the plot, which says every trial's pace and tolerance. Turned
    by 60° over more than 12 trials, they ran out of the plot into the series above."""
    per_pt = (high - low) / (width_in * 72.0)  # trials a point
    ends = [-np.inf] * len(MARK_ROWS)  # where each row's last mark ends (trials)
    for mark in figure.marks:
        half = 0.5 * text_width_pt(mark.text, MARK_PT) * per_pt
        edge = half + 0.5 * MARK_GAP_PT * per_pt  # off the plot's frame
        x = min(max(float(mark.position), low + edge), max(high - edge, low + edge))
        free = [row for row, end in enumerate(ends) if x - half > end]
        if free:
            ends[free[0]] = x + half + MARK_GAP_PT * per_pt
            axes.annotate(mark.text, (x, MARK_ROWS[free[0]]), ha="center", va="bottom",
                          fontsize=MARK_PT, color=INK)


COLUMNS = (("Session", 0.6), ("Trial", 0.45), ("Date", 0.8), ("Station", 0.6),
           ("Status", 0.9), ("Robot's help", 1.4), ("Pace (s)", 0.6), ("Tol. (°)", 0.55))
"""The table's leading columns (heading, width in inches); the exercise's figure takes the
rest of the line. The station that recorded each trial: a patient seen at several."""


def _table(sheet: Sheet, progress: Progress, figure: ProgressFigure,
           members: list[int]) -> list[int]:
    """The exercise's trials (`members`, its last ones, in order) that fit on this sheet;
    returns the rest."""
    size = 7.5
    rest = TEXT_W_IN - sum(width for _, width in COLUMNS)
    headings = [*COLUMNS, (figure.title, rest)]
    x, top, height = LEFT_IN, sheet.y_in, 0.0
    for title, width in headings:  # a heading wider than its column takes two lines
        height = max(height, sheet.text(title, size, x_in=x, width_in=width - 0.05,
                                        weight="bold", color=GREY, advance=False))
        x += width
    sheet.y_in = top + height + 0.05
    values = figure.values
    first = len(figure.positions) - len(members)  # members: the exercise's last trials
    for k, i in enumerate(members):
        if sheet.y_in + ROW_H_IN > PAGE_IN[1] - BOTTOM_ROOM_IN:
            return members[k:]
        trial = progress.trials[i]
        levels = progress.levels[i]
        help_text = levels.summary() if progress.levels_recorded[i] else \
            f"{assistance_percent(levels.at_start)} (built)"
        value = values[first + k]
        cells = (str(trial.session_number), str(trial.number), trial.session_date.isoformat(),
                 trial.station or "", trial.status.replace("_", " "), help_text,
                 f"{progress.duration_s[i]:g}",
                 f"{np.degrees(progress.tolerance_rad[i]):.0f}",
                 number_text(value, figure.row.places))
        x = LEFT_IN
        for text, (_, width) in zip(cells, headings, strict=True):
            sheet.fig.text(sheet.fx(x), sheet.fy(sheet.y_in), fit(text, size, width - 0.05),
                           fontsize=size, va="top", color=INK)
            x += width
        sheet.y_in += ROW_H_IN
    return []
