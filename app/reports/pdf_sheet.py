"""The report's page layout: an A4 sheet filled from the top, its type and its colours.

Lines are laid out top to bottom and wrapped by each text's measured width.
Fonts are DejaVu Sans (shipped with matplotlib, so it is there on every machine
and covers °, ±, ·, → and the arrows) embedded as TrueType (pdf.fonttype 42):
the text stays text, searchable and extractable. Colours are Okabe–Ito, safe for
colour-blind readers; the plots (app.reports.pdf_plots) give every colour a
line style too.

A `Sheet` is a `matplotlib.figure.Figure`, never a pyplot figure, so no global
figure list holds it and no interactive backend is involved.
"""

from __future__ import annotations

import functools
import math

import matplotlib
import matplotlib.lines
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties
from matplotlib.textpath import TextToPath

PAGE_IN = (8.27, 11.69)  # A4
LEFT_IN, RIGHT_IN, TOP_IN, BOTTOM_IN = 0.6, 0.6, 0.5, 0.45
TEXT_W_IN = PAGE_IN[0] - LEFT_IN - RIGHT_IN
TICK_ROOM_IN = 0.15  # right of a plot's frame: half its last tick label, centred on its end
PLOT_RIGHT_IN = PAGE_IN[0] - RIGHT_IN - TICK_ROOM_IN  # where a plot's frame ends at most
FOOTER_TOP_IN = 0.32  # from the bottom edge: the footer's ink stays 5 mm off the edge
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
    # A page drawn to pixels (docs/report-example*.png, a review) keeps the PDF's text
    # widths: FreeType's hinting widens small type at screen resolutions (the cut-short
    # page's 'Not compared' line ran 0.5 in past the margin at 80 dpi, never in the PDF).
    "text.hinting": "no_hinting",
}
"""matplotlib's settings while the report is drawn (`matplotlib.rc_context(RC)`)."""


class Sheet:
    """One page filled from the top: `y_in` is the next free height from the top edge.
    `scale` shrinks the texts drawn `scaled` (the first page's fit, app.reports.pdf)."""

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

    def legend(self, handles: list, x_in: float, *, ncols: int, size: float = 8) -> None:
        """A legend as a row of its own at the sheet's current height."""
        self.fig.legend(handles=handles, loc="upper left",
                        bbox_to_anchor=(self.fx(x_in), self.fy(self.y_in)), ncols=ncols,
                        frameon=False, borderaxespad=0.0, borderpad=0.0, fontsize=size,
                        handlelength=2.6, columnspacing=1.4)
        rows = math.ceil(len(handles) / ncols)
        self.y_in += rows * size * 1.55 / 72.0 + 0.05


def wrap(text: str, size_pt: float, width_in: float, weight: str = "normal") -> list[str]:
    """`text` in lines that fit `width_in` as the PDF draws them: words are added to a line
    while its width, measured in DejaVu Sans, fits; a word wider than a line is broken
    where it must be (never cut: every character is printed). Words are measured once
    each (a whole line per candidate would cost ~3 ms a word) and each line is measured
    whole at the end, so a kerning pair across a space cannot push it past the width."""
    limit = width_in * 72.0
    lines: list[str] = []
    line = ""
    for word in text.split():
        candidate = f"{line} {word}" if line else word
        if _sum_width_pt(candidate, size_pt, weight) <= limit:
            line = candidate
            continue
        if line:
            lines.append(line)
        line = word
        while _width_pt(line, size_pt, weight) > limit and len(line) > 1:
            head = _longest_head(line, size_pt, weight, limit)
            lines.append(head)
            line = line[len(head):]
    lines.append(line)
    return _measured(lines, size_pt, weight, limit)


def fit(text: str, size: float, width_in: float, weight: str = "normal") -> str:
    """`text`, cut with an ellipsis if it would run past `width_in`."""
    limit = width_in * 72.0
    if _width_pt(text, size, weight) <= limit:
        return text
    lines = wrap(text, size, width_in, weight)
    cut = lines[0].rstrip()
    while cut and _width_pt(cut + "…", size, weight) > limit:
        cut = cut[:-1].rstrip()
    return cut + "…"


def _sum_width_pt(line: str, size_pt: float, weight: str) -> float:
    """A line's width as the sum of its words' and spaces' (each measured once)."""
    words = line.split(" ")
    return sum(_width_pt(word, size_pt, weight) for word in words) \
        + (len(words) - 1) * _width_pt(" ", size_pt, weight)


def _longest_head(word: str, size_pt: float, weight: str, limit: float) -> str:
    """The longest start of `word` that fits `limit` (at least its first character)."""
    low, high = 1, len(word)
    while low < high:
        middle = (low + high + 1) // 2
        if _width_pt(word[:middle], size_pt, weight) <= limit:
            low = middle
        else:
            high = middle - 1
    return word[:low]


def _measured(lines: list[str], size_pt: float, weight: str, limit: float) -> list[str]:
    """`lines` with each measured whole: a line the sum of its parts let through but a
    kerning pair pushes past `limit` gives its last word to the next line."""
    checked: list[str] = []
    carry = ""
    for line in lines:
        line = f"{carry} {line}" if carry else line
        carry = ""
        while " " in line and _width_pt(line, size_pt, weight) > limit:
            line, last = line.rsplit(" ", 1)
            carry = f"{last} {carry}".strip()
        checked.append(line)
    if carry:
        checked.extend(_measured([carry], size_pt, weight, limit))
    return checked or [""]


def text_width_pt(text: str, size_pt: float, weight: str = "normal") -> float:
    """How wide `text` is set at `size_pt` in the sheets' font (its advance), in points."""
    return _width_pt(text, size_pt, weight)


@functools.lru_cache(maxsize=4096)
def _width_pt(text: str, size_pt: float, weight: str) -> float:
    """The advance of `text` in DejaVu Sans, unhinted as in the PDF (linear in the size,
    so measured once at 100 pt)."""
    return _unit_width(text, weight) * size_pt


@functools.lru_cache(maxsize=8192)
def _unit_width(text: str, weight: str) -> float:
    font = FontProperties(family=RC["font.family"], size=100.0, weight=weight)
    width, _, _ = _TEXT_TO_PATH.get_text_width_height_descent(text, font, ismath=False)
    return width / 100.0


_TEXT_TO_PATH = TextToPath()
