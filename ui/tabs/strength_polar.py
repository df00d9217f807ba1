"""The isometric strength task's polar plot on the Assessments tab (the issue's "peak and
mean force per direction as a polar plot"), as the PDF page draws it
(app.reports.strength_polar): the peak and the mean force along each push direction as
two closed polygons, the line the patient was shown (the robot's limit) dashed, circles
for the force's grid, each direction named from the patient's seat.

pyqtgraph has no polar axes, so the polygons are drawn in the plane with equal aspect:
a direction θ and force r at (r cos θ, r sin θ) N, in the robot frame's directions
(core.assessment.strength.StrengthPolar), both axes reversed so the plot is seen from
the patient's seat (docs/frames.md; the Report tab's path plot does the same).
"""

from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt

from core.assessment.strength import StrengthPolar, closed_outline
from ui import plots, theme

SERIES = (("peak", theme.BLUE, False, "o"), ("mean", theme.ORANGE, False, "s"),
          ("robot's limit", theme.TARGET, True, None))
"""Each drawn series (StrengthPolar.drawn's order): its key, colour, dashed, symbol."""
RING_STEPS_N = (0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0)
"""The grid circles' spacing: the first that needs at most RINGS_MAX circles to the
largest force."""
RINGS_MAX = 4  # more and their labels crowd a plot a few hundred pixels across
LABEL_OUT = 1.25
"""Direction labels' centres this many times the outer circle from the centre."""
REACH = 1.75
"""The view's half-width at least, times the outer circle: room for the labels beyond it
(more when a label is wider than that leaves room for: `fitted_reach`)."""
EDGE_PX = 4  # between a label and the plot's edge
CIRCLE_SAMPLES = 121  # points per grid circle: smooth at any size the tab gives


class StrengthPolarPlot(pg.PlotWidget):
    """The plot, empty until `show_polar` is given a strength page's data."""

    def __init__(self) -> None:
        super().__init__()
        self.setBackground(theme.BACKGROUND)
        self.setMinimumSize(260, 260)
        item = self.getPlotItem()
        plots.seat_view(item)  # the patient's view (module notes)
        item.setAspectLocked(True)
        plots.legend(item)
        self.series: list[pg.PlotDataItem] = []
        for label, colour, dashed, symbol in SERIES:
            pen = pg.mkPen(colour, width=1 if dashed else 2,
                           style=Qt.PenStyle.DashLine if dashed else Qt.PenStyle.SolidLine)
            curve = pg.PlotDataItem(pen=pen, name=label, connect="finite", symbol=symbol,
                                    symbolSize=7, symbolBrush=colour, symbolPen=colour)
            curve.setZValue(1)  # above the grid
            item.addItem(curve)
            self.series.append(curve)
        self.peak_curve, self.mean_curve, self.line_curve = self.series
        self.grid: list[pg.PlotDataItem] = []
        """The circles and the spokes of the force's grid."""
        self.labels: list[pg.TextItem] = []
        """The directions' names and the circles' forces."""
        self._outer: float | None = None  # the outer circle's force, N, once drawn
        # the labels keep their size in pixels as the plot's changes: fitted again
        item.getViewBox().sigResized.connect(self._fit)

    def show_polar(self, polar: StrengthPolar) -> None:
        """Draw `polar`: its polygons, a grid fitted to its largest force, its labels."""
        item = self.getPlotItem()
        for old in (*self.grid, *self.labels):
            item.removeItem(old)
        self.grid, self.labels = [], []
        drawn = polar.drawn()
        item.legend.clear()  # refilled in the series' order: removing one reorders the rest
        for k, curve in enumerate(self.series):
            if k >= len(drawn):  # no line known: neither drawn nor in the key
                curve.setData([], [])
                continue
            theta, radius = closed_outline(polar.angles_rad, drawn[k])
            curve.setData(radius * np.cos(theta), radius * np.sin(theta))
            item.legend.addItem(curve, SERIES[k][0])
        rings = ring_radii_n(polar.largest_n())
        outer = rings[-1]
        circle = np.linspace(0.0, 2.0 * math.pi, CIRCLE_SAMPLES)
        grid_pen = pg.mkPen(theme.GRID, width=1)
        for r in rings:
            self._grid_line(r * np.cos(circle), r * np.sin(circle), grid_pen)
            # each circle's force just inside it on the spoke "away" (the plot's top), right
            # of the spoke: stacked up the plot, clear of the directions' names outside
            self._label(f"{r:g} N", 0.0, -r, theme.MUTED, anchor=(-0.1, 0.0),
                        over_lines=True)
        missing = set(polar.not_measured)
        # the name over its degrees: two short lines fit beside a narrow plot
        names = polar.labels(between="\n")
        for deg, angle, name in zip(polar.directions_deg, polar.angles_rad, names, strict=True):
            cos, sin = math.cos(angle), math.sin(angle)
            self._grid_line(np.array([0.0, outer * cos]), np.array([0.0, outer * sin]),
                            grid_pen)
            self._label(name + ("\nnot measured" if deg in missing else ""),
                        LABEL_OUT * outer * cos, LABEL_OUT * outer * sin, theme.TEXT,
                        anchor=(0.5, 0.5))
        self._outer = outer
        self._fit()

    def _fit(self, *_args) -> None:
        """The view's range: the circles and every label whole inside the plot
        (`fitted_reach`); "not measured" ran past a narrow plot's edge."""
        if self._outer is None:
            return
        box = self.getPlotItem().getViewBox()
        sizes = [(label.pos().x(), label.pos().y(), label.textItem.boundingRect().width(),
                  label.textItem.boundingRect().height()) for label in self.labels
                 if label.anchor == pg.Point(0.5, 0.5)]
        reach = fitted_reach(REACH * self._outer, sizes, box.width(), box.height())
        self.getPlotItem().setRange(xRange=(-reach, reach), yRange=(-reach, reach),
                                    padding=0)

    def _grid_line(self, x: np.ndarray, y: np.ndarray, pen) -> None:
        line = pg.PlotDataItem(x, y, pen=pen)
        line.setZValue(-1)
        self.getPlotItem().addItem(line)
        self.grid.append(line)

    def _label(self, text: str, x: float, y: float, colour: str, *, anchor,
               over_lines: bool = False) -> None:
        """A text at (x, y) N by its `anchor` (pyqtgraph's: a share of its width and
        height), its lines centred; over the polygons on a pale ground when it may sit
        on them, so both stay readable."""
        fill = pg.mkBrush(255, 255, 255, 210) if over_lines else None
        label = pg.TextItem(text, color=colour, anchor=anchor, fill=fill)
        if over_lines:
            label.setZValue(2)
        label.setFont(theme.axis_font())
        document = label.textItem.document()
        label.textItem.setTextWidth(document.idealWidth())
        option = document.defaultTextOption()
        option.setAlignment(Qt.AlignmentFlag.AlignHCenter)
        document.setDefaultTextOption(option)
        label.setPos(x, y)
        self.getPlotItem().addItem(label)
        self.labels.append(label)


def fitted_reach(least: float, labels: list[tuple[float, float, float, float]],
                 width_px: float, height_px: float) -> float:
    """The view's half-range R (N) to ask for so that each label, centred at (x, y) N and
    (w, h) px in size, lies whole inside a view box of `width_px` × `height_px`, at
    least `least`. With the aspect locked the view shows ±R along the box's shorter side,
    so s = 2R / min(W, H) N per pixel and it shows ±s·W/2 across, ±s·H/2 up; a label fits
    across when |x| + s·w/2 ≤ s·W/2 − s·EDGE_PX, i.e. s ≥ |x| / ((W − w)/2 − EDGE_PX),
    and likewise up. A label wider than the box, or a box not laid out yet: `least`."""
    scale = 0.0
    for x, y, w, h in labels:
        for centre, size, room in ((x, w, width_px), (y, h, height_px)):
            free = (room - size) / 2.0 - EDGE_PX
            if free <= 0:
                return least
            scale = max(scale, abs(centre) / free)
    return max(least, scale * min(width_px, height_px) / 2.0)


def ring_radii_n(largest_n: float) -> tuple[float, ...]:
    """The grid circles' radii, N: multiples of the first RING_STEPS_N that needs at most
    RINGS_MAX circles, the last at or beyond `largest_n` (one circle of 1 N when it is 0)."""
    if largest_n <= 0:
        return (1.0,)
    step = next((s for s in RING_STEPS_N if largest_n / s <= RINGS_MAX), RING_STEPS_N[-1])
    count = max(1, math.ceil(largest_n / step - 1e-9))
    return tuple(step * k for k in range(1, count + 1))
