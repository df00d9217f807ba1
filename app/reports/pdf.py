"""A trial's report as a two-page A4 PDF, drawn with matplotlib's PDF backend.

Page 1 is for the patient and the therapist together: who, when and what
exercise; how the trial ended; the patient's lines in big type; the change since
the previous trial and session with cautions where the exercise differed; and the
hand's path against the target (Fig. 3.7). Page 2 is for the therapist: the force
with its blue/red runs (Fig. 3.9), the ISB joint angles (Fig. 3.11), the joint
torques (Fig. 3.12), every figure in a table beside the earlier trials', and the
notes.

Figures are built with `matplotlib.figure.Figure` and never through pyplot, so no
global figure list holds them and no interactive backend is involved. Fonts are
DejaVu Sans (shipped with matplotlib, so it is there on every machine and covers
°, ±, ·, → and the arrows) embedded as TrueType (pdf.fonttype 42): the text stays
text, searchable and extractable. Colours are Okabe–Ito, safe for colour-blind
readers, and every colour has a line style too (within solid, outside dashed).

Lines are laid out top to bottom and wrapped by each text's measured width;
when page 1's texts leave too little room for the path, they are drawn smaller
(down to 80 %; the patient's own lines to 92 %) rather than spill onto a third
page. Long time series are thinned to their per-bucket minima and maxima
(`MAX_LINE_POINTS` a line), so a 20-minute trial draws as fast as a short one
and keeps the peaks its ranges are made of.
"""

from __future__ import annotations

import functools
import logging
import math
import os
import secrets
import textwrap
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties
from matplotlib.patches import Rectangle
from matplotlib.textpath import TextToPath

from app.errors import AppError
from app.reports.compare import Comparison
from app.reports.content import AnglesFigure, ReportContent, Run, TorquesFigure
from app.reports.plain_language import VERDICT_WORDS

log = logging.getLogger(__name__)

PAGE_IN = (8.27, 11.69)  # A4
LEFT_IN, RIGHT_IN, TOP_IN, BOTTOM_IN = 0.6, 0.6, 0.5, 0.45
TEXT_W_IN = PAGE_IN[0] - LEFT_IN - RIGHT_IN
LEADING = 1.3

BLUE = "#0072B2"
VERMILLION = "#D55E00"
PURPLE = "#CC79A7"
GREEN = "#009E73"
INK = "#1A1A1A"
GREY = "#595959"
TARGET_GREY = "#C8C8C8"
BANNER_FILL = "#FBE9DD"
VERDICT_COLOURS = {"better": BLUE, "worse": VERMILLION}
MAX_LINE_POINTS = 2500
MIN_PATH_IN = 2.5
# Page 1 around the path's axes: gap, heading and legend above; tick labels, axis
# label and the two caption lines below.
PATH_ABOVE_IN = 0.62
PATH_BELOW_IN = 0.8
MIN_SCALE = 0.8
PRIMARY_MIN_SCALE = 0.92

RC = {
    "pdf.fonttype": 42,
    "font.family": "DejaVu Sans",
    "font.size": 8.5,
    "axes.titlesize": 9,
    "axes.labelsize": 8.5,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "legend.fontsize": 7.5,
    "axes.edgecolor": GREY,
    "axes.linewidth": 0.6,
    "lines.solid_capstyle": "butt",
    "lines.dash_capstyle": "butt",
    "path.simplify": True,
}


def write_report_pdf(content: ReportContent, path: str | os.PathLike) -> Path:
    """Write the report to `path` (its folder must exist); returns the path.

    Written to a temporary file beside it and renamed, so a failure never leaves a
    half-written report under the real name.
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise AppError(f"cannot write the report {path}: the folder {path.parent} does not "
                       "exist. Create it or choose another place")
    metadata = {
        "Title": f"Trial report {content.patient_code}"
                 + (f" session {content.session_number}" if content.session_number else "")
                 + (f" trial {content.trial_number}" if content.trial_number else ""),
        "Creator": "rehab-console",
        "Subject": "Post-trial report of a planar upper-limb rehabilitation robot",
    }
    # Not tempfile.mkstemp: its files are private (0600), and a report must get the
    # same permissions as any file the console writes (the user's umask).
    temporary = path.with_name(f".{path.name}.{os.getpid()}-{secrets.token_hex(4)}.part")
    try:
        handle = temporary.open("xb")
    except OSError as exc:
        raise _write_error(path, exc) from exc
    try:
        with handle, matplotlib.rc_context(RC):
            pages = (_first_page(content), _second_page(content))
            with PdfPages(handle, metadata=metadata) as pdf:
                for page in pages:
                    pdf.savefig(page)
        os.replace(temporary, path)
    except OSError as exc:
        temporary.unlink(missing_ok=True)
        raise _write_error(path, exc) from exc
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    log.info("report written: %s", path)
    return path


def _write_error(path: Path, exc: OSError) -> AppError:
    return AppError(f"cannot write the report {path}: {exc.strerror or exc}. Check that the "
                    "folder is writable and the disk has space, or choose another place")


# -- layout ------------------------------------------------------------------------------

class _Sheet:
    """One page filled from the top: `y_in` is the next free height from the top edge."""

    def __init__(self, scale: float = 1.0) -> None:
        self.fig = Figure(figsize=PAGE_IN)
        self.scale = scale
        self.y_in = TOP_IN

    @property
    def room_in(self) -> float:
        return PAGE_IN[1] - BOTTOM_IN - self.y_in

    def fy(self, y_in: float) -> float:
        return 1.0 - y_in / PAGE_IN[1]

    def fx(self, x_in: float) -> float:
        return x_in / PAGE_IN[0]

    def text(self, text: str, size: float, *, x_in: float = LEFT_IN,
             width_in: float = TEXT_W_IN, scaled: bool = True, advance: bool = True,
             **style) -> float:
        """Draw `text` wrapped to `width_in`; returns the height it took (inches)."""
        size = size * self.scale if scaled else size
        lines = wrap(text, size, width_in, style.get("weight", "normal"))
        step = size * LEADING / 72.0
        colour = style.pop("color", INK)
        for i, line in enumerate(lines):
            self.fig.text(self.fx(x_in), self.fy(self.y_in + i * step), line, fontsize=size,
                          va="top", ha="left", color=colour, **style)
        height = len(lines) * step
        if advance:
            self.y_in += height
        return height

    def gap(self, inches: float) -> None:
        self.y_in += inches * self.scale

    def rule(self) -> None:
        self.fig.add_artist(matplotlib.lines.Line2D(
            [self.fx(LEFT_IN), self.fx(PAGE_IN[0] - RIGHT_IN)], [self.fy(self.y_in)] * 2,
            color=TARGET_GREY, linewidth=0.8))

    def axes(self, height_in: float, *, x_in: float = LEFT_IN,
             width_in: float = TEXT_W_IN) -> Axes:
        """Axes whose frame spans `height_in` below y_in (labels go outside it)."""
        return self.fig.add_axes((self.fx(x_in), self.fy(self.y_in + height_in),
                                  width_in / PAGE_IN[0], height_in / PAGE_IN[1]))


def wrap(text: str, size_pt: float, width_in: float, weight: str = "normal") -> list[str]:
    """`text` in lines that fit `width_in`, by the text's own average character width
    in DejaVu Sans (measured once per text: exact per line would cost ~1 ms a word)."""
    if not text:
        return [""]
    chars = max(8, int(len(text) * 0.97 * width_in * 72.0 / _width_pt(text, size_pt, weight)))
    return textwrap.wrap(text, chars) or [""]


@functools.lru_cache(maxsize=1024)
def _width_pt(text: str, size_pt: float, weight: str) -> float:
    font = FontProperties(family=RC["font.family"], size=size_pt, weight=weight)
    width, _, _ = _TEXT_TO_PATH.get_text_width_height_descent(text, font, ismath=False)
    return max(width, 1.0)


_TEXT_TO_PATH = TextToPath()


# -- page 1 ------------------------------------------------------------------------------

def _first_page(content: ReportContent) -> Figure:
    scale = 1.0
    while True:
        sheet = _Sheet(scale)
        _page_one_texts(sheet, content)
        if sheet.room_in - PATH_ABOVE_IN - PATH_BELOW_IN >= MIN_PATH_IN or scale <= MIN_SCALE:
            break
        scale = round(scale - 0.05, 2)
    log.debug("report page 1 drawn at %.0f %% of the full text size", 100 * scale)
    sheet.gap(0.15)
    _path_plot(sheet, content)
    return sheet.fig


def _title(sheet: _Sheet, content: ReportContent, title: str, size: float = 20) -> None:
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


def _page_one_texts(sheet: _Sheet, content: ReportContent) -> None:
    _title(sheet, content, content.title)
    label_w = 0.85
    for item in content.header:
        if item.label == "Patient" or (item.label == "Robot" and content.simulated):
            continue  # in the title, or in the simulation's line below
        sheet.text(item.label, 9, weight="bold", color=GREY, advance=False)
        sheet.text(item.value, 9, x_in=LEFT_IN + label_w, width_in=TEXT_W_IN - label_w,
                   color=VERMILLION if item.label == "Fault" else INK)
        sheet.gap(0.02)
    if content.simulated:
        sheet.gap(0.04)
        robot = next((i.value for i in content.header if i.label == "Robot"), "simulator")
        sheet.text(f"Simulated trial — {robot}: the robot and the patient were the "
                   "simulator's models, not a person.", 9, color=GREY)
    if content.status_text:
        _banner(sheet, content.status_text)
    sheet.gap(0.18)

    sheet.text("How it went", 16 * max(sheet.scale, PRIMARY_MIN_SCALE), weight="bold",
               scaled=False)
    sheet.gap(0.06)
    if not content.plain:
        sheet.text("No exercise was recorded in this trial, so there is nothing to show.", 13)
    for line in content.plain:
        # The patient's own lines shrink least: they are what the page is for.
        sheet.text(line.text, 14 * max(sheet.scale, PRIMARY_MIN_SCALE), weight="bold",
                   scaled=False)
        sheet.gap(0.02)
        sheet.text(line.detail, 10, color=GREY)
        sheet.gap(0.07)

    sheet.gap(0.1)
    sheet.text("Since last time", 16 * max(sheet.scale, PRIMARY_MIN_SCALE), weight="bold",
               scaled=False)
    sheet.gap(0.06)
    if not content.comparisons:
        sheet.text("There is no earlier trial to compare with yet.", 12)
        return
    _changes_table(sheet, content.comparisons)


def _changes_table(sheet: _Sheet, comparisons: tuple[Comparison, ...]) -> None:
    """The patient's figures now and then: one row a figure, one column an earlier trial;
    then the cautions, each once, saying which comparison it concerns."""
    name_w, now_w = 2.45, 1.05
    other_w = (TEXT_W_IN - name_w - now_w) / len(comparisons)
    xs = [LEFT_IN + name_w + now_w + i * other_w for i in range(len(comparisons))]
    top = sheet.y_in
    sheet.y_in = top
    sheet.text("This trial", 10, weight="bold", color=GREY, x_in=LEFT_IN + name_w,
               width_in=now_w, advance=False)
    bottom = top
    for comparison, x in zip(comparisons, xs, strict=True):
        sheet.y_in = top
        sheet.text(comparison.kind[0].upper() + comparison.kind[1:], 10, weight="bold",
                   color=GREY, x_in=x, width_in=other_w - 0.05)
        described = comparison.baseline.describe()
        if described:
            sheet.text(described, 8.5, color=GREY, x_in=x, width_in=other_w - 0.05)
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
        sheet.text(name, 12, width_in=name_w - 0.05, advance=False)
        sheet.text(now_text, 12, weight="bold", x_in=LEFT_IN + name_w, width_in=now_w,
                   advance=False)
        for comparison, x in zip(comparisons, xs, strict=True):
            change = next((c for c in comparison.changes if c.key == key), None)
            sheet.y_in = row_top
            if change is None:
                sheet.text("–", 12, x_in=x, width_in=other_w, advance=False)
                continue
            word = VERDICT_WORDS[change.verdict]
            sheet.text(f"{change.before_text}  {change.arrow} {word}", 12, x_in=x,
                       width_in=other_w - 0.05, advance=False,
                       color=VERDICT_COLOURS.get(change.verdict, INK),
                       weight="bold" if change.verdict in VERDICT_COLOURS else "normal")
        sheet.y_in = row_top + 12 * sheet.scale * LEADING / 72.0 + 0.03 * sheet.scale

    cautions: dict[str, list[str]] = {}
    for comparison in comparisons:
        for caution in comparison.cautions:
            cautions.setdefault(caution, []).append(comparison.kind)
    if cautions:
        sheet.gap(0.05)
    for caution, kinds in cautions.items():
        which = "" if len(kinds) == len(comparisons) else f" ({kinds[0]} only)"
        sheet.text(f"Note{which}: {caution}", 10, color=GREY)
        sheet.gap(0.02)


def _banner(sheet: _Sheet, text: str) -> None:
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


def _path_plot(sheet: _Sheet, content: ReportContent) -> None:
    figure = content.path
    if figure is None:
        sheet.text("No path to show: the trial has no exercise samples of the hand's "
                   "position.", 11, color=GREY)
        return
    sheet.text("Your hand's path and the target path (Fig. 3.7)", 12, weight="bold")
    handles = [
        matplotlib.lines.Line2D([], [], color=TARGET_GREY, linewidth=7, label="target path"),
        matplotlib.lines.Line2D([], [], color=INK, marker="o", markersize=6, linestyle="none",
                                label="start"),
        *_run_handles(figure.runs, "your hand: pushing the right way",
                      "your hand: pushing another way"),
    ]
    _legend_at(sheet, handles, LEFT_IN, ncols=4)
    height = max(1.0, sheet.room_in - PATH_BELOW_IN)
    ax = sheet.axes(height, x_in=LEFT_IN + 0.55, width_in=TEXT_W_IN - 0.55)
    desired = figure.desired_m * 1000.0
    position = figure.position_m * 1000.0
    outline = figure.outline_m * 1000.0
    ax.plot(outline[:, 0], outline[:, 1], color=TARGET_GREY, linewidth=7,
            solid_capstyle="round", zorder=1)
    _draw_runs(ax, position[:, 0], position[:, 1], figure.runs, linewidth=1.6)
    ax.plot(*desired[0], marker="o", markersize=6, color=INK, linestyle="none", zorder=4)
    _direction_arrow(ax, outline)
    # The box shrinks to the data's shape, so millimetres are equal both ways.
    ax.set_aspect("equal", adjustable="box")
    ax.set_anchor("C")
    ax.margins(0.08)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    if figure.flip_axes:
        ax.invert_xaxis()
        ax.invert_yaxis()
        view = "Seen from the patient's chair: both axes reversed, as in the thesis's Fig. 3.7."
    else:
        view = "Seen from above, in the robot's frame (the patient sits at the top, facing down)."
    _light_grid(ax)
    sheet.y_in += height + 0.42
    sheet.text(figure.caption, 9.5, scaled=False)
    sheet.text(view, 8.5, color=GREY, scaled=False)


def _legend_at(sheet: _Sheet, handles: list, x_in: float, *, ncols: int,
               size: float = 8) -> None:
    """A legend as a row of its own at the sheet's current height."""
    sheet.fig.legend(handles=handles, loc="upper left",
                     bbox_to_anchor=(sheet.fx(x_in), sheet.fy(sheet.y_in)), ncols=ncols,
                     frameon=False, borderaxespad=0.0, borderpad=0.0, fontsize=size,
                     handlelength=2.6, columnspacing=1.4)
    rows = math.ceil(len(handles) / ncols)
    sheet.y_in += rows * size * 1.55 / 72.0 + 0.05


def _direction_arrow(ax: Axes, desired_mm: np.ndarray) -> None:
    """An arrow along the first few percent of the target path: the way to go."""
    steps = np.hypot(*np.diff(desired_mm, axis=0).T)
    along = np.concatenate(([0.0], np.cumsum(steps)))
    if along[-1] <= 0:
        return
    k = int(np.searchsorted(along, 0.06 * along[-1]))
    k = min(max(k, 1), len(desired_mm) - 1)
    ax.annotate("", xy=desired_mm[k], xytext=desired_mm[0],
                arrowprops={"arrowstyle": "-|>", "color": INK, "linewidth": 1.2,
                            "shrinkA": 4, "shrinkB": 0}, zorder=5)


# -- page 2 ------------------------------------------------------------------------------

def _second_page(content: ReportContent) -> Figure:
    sheet = _Sheet()
    _title(sheet, content, "For the therapist", size=16)
    time_label = "time since the exercise started (s)"
    label_room = 0.55
    x0 = LEFT_IN + label_room
    plot_w = TEXT_W_IN - label_room

    force = content.force
    if force is not None:
        sheet.text("Force on the handle (Fig. 3.9)", 10, weight="bold", advance=False)
        sheet.text(force.caption, 8.5, color=GREY, x_in=LEFT_IN + 2.35,
                   width_in=TEXT_W_IN - 2.35)
        sheet.gap(0.04)
        handles = _run_handles(force.runs, force.within_label, force.outside_label)
        if handles:
            _legend_at(sheet, handles, LEFT_IN, ncols=2)
        sheet.gap(0.2)
        height = 0.95
        top = None
        for axis in range(2):
            ax = sheet.axes(height, x_in=x0, width_in=plot_w)
            ax.set_title(force.titles[axis], loc="left", pad=3)
            ax.axhline(0.0, color=TARGET_GREY, linewidth=0.6, zorder=0)
            _draw_runs(ax, force.t_s, force.force_N[:, axis], force.runs, linewidth=1.2)
            ax.set_ylabel("N")
            ax.set_xlim(force.t_s[0], force.t_s[-1])
            _light_grid(ax)
            if top is None:
                top = ax
                ax.tick_params(labelbottom=False)
                sheet.y_in += height + 0.27
            else:
                ax.sharex(top)
                ax.set_xlabel(time_label)
                sheet.y_in += height + 0.45

    if content.angles is not None or content.torques is not None:
        between = 0.35
        half = (TEXT_W_IN - 2 * label_room - between) / 2
        x1 = x0 + half + between + label_room
        top_in = sheet.y_in
        height = 1.25
        bottom_in = top_in
        for figure, x, title, draw in (
            (content.angles, x0, "Joint angles, ISB (Fig. 3.11)", _angles_plot),
            (content.torques, x1, "Joint torques (Fig. 3.12)", _torques_plot),
        ):
            if figure is None:
                continue
            sheet.y_in = top_in
            sheet.text(title, 10, weight="bold", x_in=x - label_room)
            sheet.gap(0.03)
            _legend_at(sheet, draw(figure), x - label_room, ncols=1, size=7.5)
            sheet.gap(0.04)
            ax = sheet.axes(height, x_in=x, width_in=half)
            _plot_series(ax, figure)
            ax.set_xlabel(time_label)
            sheet.y_in += height + 0.42
            if figure is content.torques:
                sheet.text(figure.caption, 7.5, color=GREY, x_in=x - label_room,
                           width_in=half + label_room)
            bottom_in = max(bottom_in, sheet.y_in)
        sheet.y_in = bottom_in + 0.1

    _table(sheet, content)
    _notes(sheet, content)
    return sheet.fig


def _light_grid(ax: Axes) -> None:
    ax.grid(True, color="#E6E6E6", linewidth=0.5)
    ax.set_axisbelow(True)


_JOINT_STYLES = ((PURPLE, "-"), (GREEN, "-."))


def _angles_plot(figure: AnglesFigure) -> list:
    return [matplotlib.lines.Line2D([], [], color=c, linestyle=ls, linewidth=1.4, label=label)
            for (c, ls), label in zip(_JOINT_STYLES, figure.labels, strict=True)]


def _torques_plot(figure: TorquesFigure) -> list:
    return [matplotlib.lines.Line2D([], [], color=c, linestyle=ls, linewidth=1.6, label=label)
            for (c, ls), label in zip(_JOINT_STYLES, figure.labels, strict=True)]


def _plot_series(ax: Axes, figure: AnglesFigure | TorquesFigure) -> None:
    t = figure.t_s
    for column, (colour, style) in enumerate(_JOINT_STYLES):
        if isinstance(figure, AnglesFigure):
            x, y = _envelope(t, np.degrees(figure.isb_rad[:, column]))
            ax.plot(x, y, color=colour, linestyle=style, linewidth=1.4)
        else:
            x, y = _envelope(t, figure.raw_Nm[:, column])
            ax.plot(x, y, color=colour, linewidth=0.6, alpha=0.35)
            x, y = _envelope(t, figure.smoothed_Nm[:, column])
            ax.plot(x, y, color=colour, linestyle=style, linewidth=1.6)
    if isinstance(figure, AnglesFigure):
        ax.set_ylabel("angle (°)")
    else:
        ax.axhline(0.0, color=TARGET_GREY, linewidth=0.6, zorder=0)
        ax.set_ylabel("torque (N·m)")
    ax.set_xlim(t[0], t[-1])
    _light_grid(ax)


def _table(sheet: _Sheet, content: ReportContent) -> None:
    if not content.table:
        return
    sheet.text("Every figure of this trial", 11, weight="bold")
    sheet.gap(0.06)
    columns = ("Figure", "This trial", *content.table_columns)
    n_earlier = len(content.table_columns)
    label_w, value_w = 2.75, 1.0
    earlier_w = (TEXT_W_IN - label_w - value_w) / max(1, n_earlier)
    lefts = [LEFT_IN, LEFT_IN + label_w]
    lefts += [LEFT_IN + label_w + value_w + i * earlier_w for i in range(n_earlier)]
    widths = [label_w, value_w] + [earlier_w] * n_earlier
    row_h = 0.16
    size = 8
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
    for i, row in enumerate(content.table):
        y = sheet.y_in
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
            sheet.fig.text(sheet.fx(x + 0.04), sheet.fy(y), _fit(cell, size, w - 0.08),
                           fontsize=size, va="top", ha="left", color=colour,
                           weight="bold" if j == 1 else "normal")
        sheet.y_in = y + row_h
    sheet.gap(0.12)


def _fit(text: str, size: float, width_in: float) -> str:
    """`text`, cut with an ellipsis if it would run past `width_in`."""
    lines = wrap(text, size, width_in)
    return text if len(lines) == 1 else lines[0].rstrip() + "…"


def _notes(sheet: _Sheet, content: ReportContent) -> None:
    notes = [f"Fault at {fault}" for fault in content.faults] + list(content.notes)
    size = 7.5
    step = size * LEADING / 72.0
    footer = f"rehab-console · {content.source.name}"
    if notes:
        sheet.text("Notes", 9, weight="bold", scaled=False)
    for k, note in enumerate(notes):
        lines = wrap("• " + note, size, TEXT_W_IN)
        if sheet.y_in + (len(lines) + 1) * step > PAGE_IN[1] - BOTTOM_IN:
            sheet.text(f"… and {len(notes) - k} more note(s): see the trial file's notes.",
                       size, color=GREY, scaled=False)
            break
        sheet.text("• " + note, size, color=GREY, scaled=False)
    sheet.fig.text(sheet.fx(LEFT_IN), sheet.fy(PAGE_IN[1] - BOTTOM_IN + 0.2), footer,
                   fontsize=7, color=GREY, va="top")


# -- drawing helpers -----------------------------------------------------------------------

def _draw_runs(ax: Axes, x: np.ndarray, y: np.ndarray, runs: tuple[Run, ...], *,
               linewidth: float) -> None:
    """Within runs solid blue, outside runs dashed vermillion; one black line when
    there are no runs (no force or direction to judge by)."""
    if not runs:
        xs, ys = _envelope(x, y) if x.ndim == 1 and _is_time(x) else (x, y)
        ax.plot(xs, ys, color=INK, linewidth=linewidth, zorder=3)
        return
    budget = max(2, MAX_LINE_POINTS // max(1, len(runs)))
    for run in runs:
        part = slice(run.start, run.stop + 1)
        xs, ys = _thin(x[part], y[part], max(budget, int(MAX_LINE_POINTS * (run.stop + 1 -
                                                                            run.start)
                                                          / max(1, len(x)))))
        if run.within:
            ax.plot(xs, ys, color=BLUE, linewidth=linewidth, linestyle="-", zorder=3)
        else:
            ax.plot(xs, ys, color=VERMILLION, linewidth=linewidth, linestyle=(0, (3.5, 1.8)),
                    zorder=3)


def _run_handles(runs: tuple[Run, ...], within: str, outside: str) -> list:
    handles = []
    if runs:
        handles += [
            matplotlib.lines.Line2D([], [], color=BLUE, linewidth=1.6, label=within),
            matplotlib.lines.Line2D([], [], color=VERMILLION, linewidth=1.6,
                                    linestyle=(0, (3.5, 1.8)), label=outside),
        ]
    return handles


def _is_time(x: np.ndarray) -> bool:
    return x.size < 2 or bool(np.all(np.diff(x) >= 0))


def _thin(x: np.ndarray, y: np.ndarray, max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """At most about `max_points` points, keeping each stretch's extremes (time series)
    or every k-th point (a path); the ends are always kept."""
    if x.size <= max_points:
        return x, y
    if _is_time(x):
        return _envelope(x, y, max_points)
    index = np.unique(np.r_[np.linspace(0, x.size - 1, max_points).astype(int), x.size - 1])
    return x[index], y[index]


def _envelope(t: np.ndarray, y: np.ndarray,
              max_points: int = MAX_LINE_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """Min-max decimation: per bucket, the lowest and highest sample in time order, so
    a long trial's peaks (which set the ranges shown) survive the thinning."""
    n = t.size
    if n <= max_points:
        return t, y
    size = math.ceil(n / max(1, max_points // 2))
    buckets = math.ceil(n / size)
    padded = np.full(buckets * size, np.nan)
    padded[:n] = y
    padded = padded.reshape(buckets, size)
    missing = np.isnan(padded)
    base = np.arange(buckets) * size
    low = base + np.argmin(np.where(missing, np.inf, padded), axis=1)
    high = base + np.argmax(np.where(missing, -np.inf, padded), axis=1)
    index = np.unique(np.concatenate(([0, n - 1], np.minimum(low, n - 1),
                                      np.minimum(high, n - 1))))
    return t[index], y[index]
