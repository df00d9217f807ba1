"""A trial's report as an A4 PDF, drawn with matplotlib's PDF backend.

Page 1 is the patient's, in plain words: when and what exercise, the robot's help as
the trial ran it, how it ended; the mode's own success figure as the headline and the
patient's other lines in big type; the change since the last trial and session, a
verdict only where the trials compare (app.reports.compare), with why not where they do
not; and the hand's path as the patient saw it from their seat. No coordinates, seeds,
file names or instructions to the therapist: page 2 is the therapist's: every setting,
the robot, each fault with what to do, the force with its blue/red runs (Fig. 3.9), the
ISB joint angles (Fig. 3.11), the joint torques (Fig. 3.12), every figure in a table
beside the earlier trials', and the notes, continued on further pages when they do not
fit (never a pointer to notes elsewhere). A trial with EMG gets a page of its envelopes
beside the torques (chapter 5), an as-needed trial a page of the help the robot learned
along the path, per repetition, and a trial `rehab pose` ran on a page of the camera's
angles against the solver's.

This module lays the texts and tables out on the pages; the file is written by
app.reports.pdf_file, the sheet, its type and colours are app.reports.pdf_sheet, the
plots app.reports.pdf_plots. When page 1's texts leave too little room for the path,
they are drawn smaller (down to 80 %; the patient's own lines to 92 %) rather than spill
onto another page.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import matplotlib
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from app.reports.compare import Comparison, TableRow
from app.reports.content import ReportContent
from app.reports.pdf_file import write_pdf
from app.reports.pdf_plots import (
    PATH_ABOVE_IN,
    PATH_BELOW_IN,
    emg_plots,
    feedforward_plot,
    force_plots,
    joint_plots,
    path_plot,
    pose_plots,
)
from app.reports.pdf_sheet import (
    BANNER_FILL,
    BOTTOM_IN,
    FOOTER_TOP_IN,
    GREY,
    INK,
    LEADING,
    LEFT_IN,
    PAGE_IN,
    PLOT_RIGHT_IN,
    RC,
    RIGHT_IN,
    TEXT_W_IN,
    VERDICT_COLOURS,
    VERMILLION,
    Sheet,
    fit,
    wrap,
)
from app.reports.plain_language import VERDICT_WORDS

log = logging.getLogger(__name__)

MIN_PATH_IN = 2.5
_PLOT_SPAN = (LEFT_IN + 0.55, PLOT_RIGHT_IN - LEFT_IN - 0.55)  # a full-width plot's x, width
FOOTER_IN = 0.1  # room kept above the footer line
MIN_SCALE = 0.8
PRIMARY_MIN_SCALE = 0.92
NOTHING_TO_COMPARE = ("No earlier trial of this exercise, with this kind of help from the "
                      "robot, to compare with yet.")


def write_report_pdf(content: ReportContent, path: str | os.PathLike) -> Path:
    """Write the report to `path` (its folder must exist); returns the path. Private and
    never half-written under its name (app.reports.pdf_file): a report holds a patient's
    figures (and, when asked, their first name)."""
    metadata = {
        "Title": f"Trial report {content.patient_code}"
                 + (f" session {content.session_number}" if content.session_number else "")
                 + (f" trial {content.trial_number}" if content.trial_number else ""),
        "Subject": "Post-trial report of a planar upper-limb rehabilitation robot",
    }
    path = write_pdf(path, lambda: report_pages(content), metadata, "the report")
    log.info("report written: %s", path)
    return path


def report_pages(content: ReportContent) -> tuple[Figure, ...]:
    """The report's pages as matplotlib figures, in order (drawn under RC): the patient's,
    the therapist's (and its continuation), then an assessment trial's task page, EMG, the
    as-needed help, the pose."""
    with matplotlib.rc_context(RC):
        pages = (_first_page(content), *_second_page(content))
        if content.assessment is not None:
            from app.reports.assessment_page import page_figure

            pages += (page_figure(content.assessment),)
        if content.emg is not None:
            pages += (_emg_page(content),)
        if content.feedforward is not None:
            pages += (_assistance_page(content),)
        if content.pose is not None:
            pages += (_pose_page(content),)
    return pages


def _title(sheet: Sheet, content: ReportContent, title: str, size: float = 20) -> None:
    sheet.text(title, size, weight="bold", advance=False)
    who = content.patient_code + (f" · {content.first_name}" if content.first_name else "")
    numbers = " · ".join(part for part in (
        f"session {content.session_number}" if content.session_number is not None else "",
        f"trial {content.trial_number}" if content.trial_number is not None else "",
    ) if part)
    sheet.fig.text(sheet.fx(PAGE_IN[0] - RIGHT_IN), sheet.fy(sheet.y_in), who,
                   fontsize=14 * sheet.scale, weight="bold", ha="right", va="top", color=INK)
    if numbers:
        sheet.fig.text(sheet.fx(PAGE_IN[0] - RIGHT_IN), sheet.fy(sheet.y_in + 0.27 * sheet.scale),
                       numbers, fontsize=10 * sheet.scale, ha="right", va="top", color=GREY)
    sheet.gap(0.5 * size / 20)
    sheet.rule()
    sheet.gap(0.1)


# -- page 1 ------------------------------------------------------------------------------

def _first_page(content: ReportContent) -> Figure:
    scale = 1.0
    while True:
        sheet = Sheet(scale)
        _page_one_texts(sheet, content)
        if sheet.room_in - PATH_ABOVE_IN - PATH_BELOW_IN >= MIN_PATH_IN or scale <= MIN_SCALE:
            break
        scale = round(scale - 0.05, 2)
    log.debug("report page 1 drawn at %.0f %% of the full text size", 100 * scale)
    sheet.gap(0.15)
    path_plot(sheet, content.path)
    return sheet.fig


def _page_one_texts(sheet: Sheet, content: ReportContent) -> None:
    """The patient's page: plain words only (no coordinates, seeds, instructions to the
    therapist or file names: those are on page 2)."""
    _title(sheet, content, content.title)
    label_w = 1.0
    for item in content.header:
        if item.label == "Patient":
            continue  # in the title
        sheet.text(item.label, 9, weight="bold", color=GREY, advance=False)
        sheet.text(item.value, 9, x_in=LEFT_IN + label_w, width_in=TEXT_W_IN - label_w)
        sheet.gap(0.02)
    if content.simulated:
        sheet.gap(0.04)
        sheet.text("Simulated trial: the robot and the patient were the simulator's models, "
                   "not a person.", 9, color=GREY)
    if content.status_text:
        _banner(sheet, content.status_text)
    sheet.gap(0.18)

    primary = max(sheet.scale, PRIMARY_MIN_SCALE)
    sheet.text("How it went", 16 * primary, weight="bold", scaled=False)
    sheet.gap(0.06)
    if not content.plain:
        sheet.text("No exercise was recorded in this trial, so there is nothing to show.", 13)
    for k, line in enumerate(content.plain):
        # The headline (the mode's success figure) largest; the patient's own lines
        # shrink least: they are what the page is for.
        sheet.text(line.text, (17 if k == 0 else 14) * primary, weight="bold", scaled=False)
        sheet.gap(0.02)
        sheet.text(line.detail, 10, color=GREY)
        sheet.gap(0.07)

    sheet.gap(0.1)
    sheet.text("Since last time", 16 * primary, weight="bold", scaled=False)
    sheet.gap(0.06)
    if not content.comparisons:
        # only trials of the same exercise and mode are compared (build.earlier_like): the
        # patient may well have done others before this one
        sheet.text(NOTHING_TO_COMPARE, 12)
        return
    _changes_table(sheet, content.comparisons)


def _changes_table(sheet: Sheet, comparisons: tuple[Comparison, ...]) -> None:
    """The patient's figures then and now, oldest on the left, then one column per
    earlier trial with the change *to this trial* (an arrow and a word), or "not
    compared" when the trials do not compare; then why, each reason once."""
    name_w, value_w = 1.9, 0.9
    earliest_first = comparisons[::-1]
    change_w = (TEXT_W_IN - name_w - value_w * (len(comparisons) + 1)) / len(comparisons)
    value_x = [LEFT_IN + name_w + i * value_w for i in range(len(comparisons) + 1)]
    change_x = [value_x[-1] + value_w + i * change_w for i in range(len(comparisons))]
    top = bottom = sheet.y_in
    for comparison, x in zip(earliest_first, value_x, strict=False):
        sheet.y_in = top
        sheet.text(comparison.label, 10, weight="bold", color=GREY, x_in=x,
                   width_in=value_w - 0.05)
        described = comparison.baseline.describe()
        if described:
            sheet.text(described, 7.5, color=GREY, x_in=x, width_in=value_w - 0.05)
        bottom = max(bottom, sheet.y_in)
    for title, x, w in (("This trial", value_x[-1], value_w),
                        *((f"Change since {c.label.lower()}", x, change_w)
                          for c, x in zip(comparisons, change_x, strict=True))):
        sheet.y_in = top
        sheet.text(title, 10, weight="bold", color=GREY, x_in=x, width_in=w - 0.05)
        bottom = max(bottom, sheet.y_in)
    sheet.y_in = bottom + 0.04 * sheet.scale
    keys: dict[str, tuple[str, str]] = {}
    for comparison in comparisons:
        for change in comparison.changes:
            keys.setdefault(change.key, (change.name, change.after_text))
    if not keys:
        sheet.text("No figure of the earlier trials compares with this one.", 12)
    for key, (name, now_text) in keys.items():
        row_top = sheet.y_in
        name_h = sheet.text(name, 12, width_in=name_w - 0.05, advance=False)  # may wrap
        sheet.text(now_text, 12, weight="bold", x_in=value_x[-1], width_in=value_w,
                   advance=False)
        for comparison, x in zip(earliest_first, value_x, strict=False):
            change = next((c for c in comparison.changes if c.key == key), None)
            sheet.y_in = row_top
            sheet.text(change.before_text if change else "–", 12, x_in=x, width_in=value_w,
                       advance=False)
        for comparison, x in zip(comparisons, change_x, strict=True):
            change = next((c for c in comparison.changes if c.key == key), None)
            sheet.y_in = row_top
            if change is None:
                sheet.text("–", 12, x_in=x, width_in=change_w, advance=False)
            elif not change.verdict:
                sheet.text("not compared", 10, x_in=x, width_in=change_w - 0.05,
                           advance=False, color=GREY)
            else:
                sheet.text(f"{change.arrow} {VERDICT_WORDS[change.verdict]}", 12, x_in=x,
                           width_in=change_w - 0.05, advance=False,
                           color=VERDICT_COLOURS.get(change.verdict, INK),
                           weight="bold" if change.verdict in VERDICT_COLOURS else "normal")
        sheet.y_in = row_top + max(name_h, 12 * sheet.scale * LEADING / 72.0) \
            + 0.03 * sheet.scale

    cautions: dict[str, list[str]] = {}
    for comparison in comparisons:
        for caution in comparison.cautions:
            cautions.setdefault(caution, []).append(comparison.label.lower())
    if cautions:
        sheet.gap(0.05)
    for caution, labels in cautions.items():
        which = "" if len(labels) == len(comparisons) else f" with the {labels[0]}"
        sheet.text(f"Not compared{which}: {caution[0].lower()}{caution[1:]}", 10, color=GREY)
        sheet.gap(0.02)


def _banner(sheet: Sheet, text: str) -> None:
    sheet.gap(0.1)
    pad = 0.08
    top = sheet.y_in
    sheet.y_in += pad
    height = sheet.text(text, 12, x_in=LEFT_IN + pad, width_in=TEXT_W_IN - 2 * pad,
                        weight="bold", color=INK)
    sheet.y_in += pad
    sheet.fig.add_artist(Rectangle(
        (sheet.fx(LEFT_IN), sheet.fy(top + height + 2 * pad)), TEXT_W_IN / PAGE_IN[0],
        (height + 2 * pad) / PAGE_IN[1], transform=sheet.fig.transFigure,
        facecolor=BANNER_FILL, edgecolor=VERMILLION, linewidth=1.2, zorder=-1))


# -- page 2 ------------------------------------------------------------------------------

ROW_HEIGHTS_IN = (0.15, 0.14, 0.13)
"""The figure table's row heights tried, tallest first (8 pt type needs 0.11 in): a table
that leaves its last note or row alone on a page of its own is drawn tighter instead."""


def _second_page(content: ReportContent) -> tuple[Figure, ...]:
    """The therapist's page, and as many more as its table and notes need: the fewest
    pages any row height of ROW_HEIGHTS_IN gives, with the tallest rows among them (a
    report whose one short note went on a page of its own came out tighter on one)."""
    tallest = _therapist_pages(content, ROW_HEIGHTS_IN[0])
    if len(tallest) == 1:
        return tallest
    # tighter rows never take more pages: the tightest says whether any saves one (a long
    # report that spills whatever the rows is drawn twice, not once per height)
    tightest = _therapist_pages(content, ROW_HEIGHTS_IN[-1])
    if len(tightest) == len(tallest):
        return tallest
    for row_h in ROW_HEIGHTS_IN[1:-1]:
        pages = _therapist_pages(content, row_h)
        if len(pages) == len(tightest):
            return pages
    return tightest


def _therapist_pages(content: ReportContent, row_h: float) -> tuple[Figure, ...]:
    """The therapist's pages with the figure table's rows `row_h` inches tall."""
    sheet = Sheet()
    _title(sheet, content, "For the therapist", size=16)
    _therapist_header(sheet, content)
    label_room = 0.55
    x0 = LEFT_IN + label_room
    if content.force is not None:
        force_plots(sheet, content.force, x0, PLOT_RIGHT_IN - x0)
    if content.angles is not None or content.torques is not None:
        joint_plots(sheet, content.angles, content.torques, x0, label_room)
    pages = [sheet]

    def next_page() -> None:
        sheet = Sheet()
        _title(sheet, content, "For the therapist (continued)", size=16)
        pages.append(sheet)

    rows = list(content.table)
    while rows:
        rows = _table(pages[-1], content, rows, continued=len(rows) < len(content.table),
                      row_h=row_h)
        if rows:
            next_page()
    notes = list(content.notes)  # the faults are in the header, once
    total = len(notes)
    while notes:
        notes = _notes(pages[-1], notes, continued=len(notes) < total)
        if notes:
            next_page()
    for page in pages:
        _footer(page, content)
    return tuple(page.fig for page in pages)


def _therapist_header(sheet: Sheet, content: ReportContent) -> None:
    label_w = 0.85
    for item in content.therapist_header:
        if item.label == "File":
            continue  # in every page's footer
        sheet.text(item.label, 8, weight="bold", color=GREY, advance=False, scaled=False)
        sheet.text(item.value, 8, x_in=LEFT_IN + label_w, width_in=TEXT_W_IN - label_w,
                   color=VERMILLION if item.label == "Fault" else INK, scaled=False)
    sheet.gap(0.1)


def _emg_page(content: ReportContent) -> Figure:
    sheet = Sheet()
    _title(sheet, content, "Muscle activity (surface EMG)", size=16)
    emg_plots(sheet, content.emg, content.torques, *_PLOT_SPAN)
    return sheet.fig


def _assistance_page(content: ReportContent) -> Figure:
    sheet = Sheet()
    _title(sheet, content, "The robot's help (as-needed assistance)", size=16)
    feedforward_plot(sheet, content.feedforward, *_PLOT_SPAN)
    return sheet.fig


def _pose_page(content: ReportContent) -> Figure:
    sheet = Sheet()
    _title(sheet, content, "The camera against the equation solver (Table 3.4)", size=16)
    pose_plots(sheet, content.pose, *_PLOT_SPAN)
    return sheet.fig


def _table(sheet: Sheet, content: ReportContent, rows: list[TableRow], *,
           continued: bool, row_h: float = ROW_HEIGHTS_IN[0]) -> list[TableRow]:
    """Draw the rows of the table that fit on this sheet, under its headings; return the
    rest, for the next page."""
    size = 8
    bottom_in = PAGE_IN[1] - BOTTOM_IN - FOOTER_IN
    if not rows or sheet.y_in + 0.9 + 2 * row_h > bottom_in:
        return rows  # not even the headings and two rows: all on the next page
    sheet.text("Every figure of this trial" + (" (continued)" if continued else ""), 11,
               weight="bold")
    sheet.gap(0.06)
    columns = ("Figure", "This trial", *content.table_columns)
    n_earlier = len(content.table_columns)
    label_w, value_w = 2.75, 1.0
    earlier_w = (TEXT_W_IN - label_w - value_w) / max(1, n_earlier)
    lefts = [LEFT_IN, LEFT_IN + label_w]
    lefts += [LEFT_IN + label_w + value_w + i * earlier_w for i in range(n_earlier)]
    widths = [label_w, value_w] + [earlier_w] * n_earlier
    top = bottom = sheet.y_in
    for column, x, w in zip(columns, lefts, widths, strict=True):
        sheet.y_in = top
        title, _, detail = column.partition(" (")
        sheet.text(title, size, x_in=x + 0.04, width_in=w - 0.08, weight="bold", scaled=False)
        if detail:
            sheet.text(detail.removesuffix(")"), size - 0.5, x_in=x + 0.04, width_in=w - 0.08,
                       color=GREY, scaled=False)
        bottom = max(bottom, sheet.y_in)
    sheet.y_in = max(bottom, top + row_h) + 0.03
    for i, row in enumerate(rows):
        y = sheet.y_in
        if y + row_h > bottom_in:
            return rows[i:]
        if i % 2 == 0:
            sheet.fig.add_artist(Rectangle(
                (sheet.fx(LEFT_IN), sheet.fy(y + row_h - 0.03)), TEXT_W_IN / PAGE_IN[0],
                row_h / PAGE_IN[1], transform=sheet.fig.transFigure, facecolor="#F2F2F2",
                edgecolor="none", zorder=-1))
        unit = f" ({row.unit})" if row.unit else ""
        cells = (row.label + unit, row.value_text, *row.earlier_texts)
        for j, (cell, x, w) in enumerate(zip(cells, lefts, widths, strict=True)):
            colour = INK
            if j >= 2:
                colour = VERDICT_COLOURS.get(row.verdicts[j - 2], INK)
            sheet.y_in = y
            sheet.fig.text(sheet.fx(x + 0.04), sheet.fy(y), fit(cell, size, w - 0.08),
                           fontsize=size, va="top", ha="left", color=colour,
                           weight="bold" if j == 1 else "normal")
        sheet.y_in = y + row_h
    sheet.gap(0.12)
    return []


def _notes(sheet: Sheet, notes: list[str], *, continued: bool) -> list[str]:
    """Draw the notes that fit on this sheet above its footer; return the rest, for the
    next page (never a pointer to notes that are somewhere else)."""
    size = 7.5
    step = size * LEADING / 72.0
    bottom = PAGE_IN[1] - BOTTOM_IN - FOOTER_IN
    if sheet.y_in + 2 * step > bottom:
        return notes
    sheet.text("Notes (continued)" if continued else "Notes", 9, weight="bold", scaled=False)
    for k, note in enumerate(notes):
        lines = wrap("• " + note, size, TEXT_W_IN)
        if sheet.y_in + len(lines) * step > bottom:
            return notes[k:]
        sheet.text("• " + note, size, color=GREY, scaled=False)
    return []


def _footer(sheet: Sheet, content: ReportContent) -> None:
    sheet.fig.text(sheet.fx(LEFT_IN), sheet.fy(PAGE_IN[1] - FOOTER_TOP_IN),
                   f"rehab-console · {content.source.name}", fontsize=7, color=GREY, va="top")
