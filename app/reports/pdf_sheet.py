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
import textwrap

import matplotlib
import matplotlib.lines
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties
from matplotlib.textpath import TextToPath

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
    """`text` in lines that fit `width_in`, by the text's own average character width
    in DejaVu Sans (measured once per text: exact per line would cost ~1 ms a word)."""
    if not text:
        return [""]
    chars = max(8, int(len(text) * 0.97 * width_in * 72.0 / _width_pt(text, size_pt, weight)))
    return textwrap.wrap(text, chars) or [""]


def fit(text: str, size: float, width_in: float) -> str:
    """`text`, cut with an ellipsis if it would run past `width_in`."""
    lines = wrap(text, size, width_in)
    return text if len(lines) == 1 else lines[0].rstrip() + "…"


@functools.lru_cache(maxsize=1024)
def _width_pt(text: str, size_pt: float, weight: str) -> float:
    font = FontProperties(family=RC["font.family"], size=size_pt, weight=weight)
    width, _, _ = _TEXT_TO_PATH.get_text_width_height_descent(text, font, ismath=False)
    return max(width, 1.0)


_TEXT_TO_PATH = TextToPath()
