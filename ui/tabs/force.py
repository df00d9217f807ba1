"""The End-effector force tab (thesis Fig. 3.9, A.10): the hand's force on the handle in
x and y over the exercise, blue and solid while it pointed within the tolerance of
the path's direction, vermillion and dashed while it did not, with each axis's range.

Runs shorter than `ui.views.samples.MERGE_RUNS_S` are merged into their neighbour for the
picture only; the percentage and the ranges count every sample.
"""

from __future__ import annotations

import math

import pyqtgraph as pg
from PySide6.QtWidgets import QLabel, QWidget

from ui import plots, theme
from ui.views import samples
from ui.views.numbers import format_number
from ui.views.trialview import TrialView

AXES = ("x", "y")
MEANING = {"x": "sideways", "y": "forward and back"}


class ForceTab(QWidget):
    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self._view: TrialView | None = None
        self._drawn: tuple = ()
        self.graphics = pg.GraphicsLayoutWidget()
        self.plots: list[pg.PlotItem] = []
        self.inside: list[pg.PlotDataItem] = []
        self.outside: list[pg.PlotDataItem] = []
        self.cursors: list[pg.InfiniteLine] = []
        for row, axis in enumerate(AXES):
            item = self.graphics.addPlot(row=row, col=0)
            plots.configure_plot(item, "time (s)", f"force {axis} (N)")
            if self.plots:
                item.setXLink(self.plots[0])
            self.plots.append(item)
            self.inside.append(plots.curve(item, theme.WITHIN, gaps=True))
            self.outside.append(plots.curve(item, theme.OUTSIDE, dashed=True, gaps=True))
            self.cursors.append(plots.cursor_line(item))

        self.ranges = [plots.BigNumber(f"Force range, {axis}", "N", decimals=2) for axis in AXES]
        self.directional = plots.BigNumber("Directional performance", "%", decimals=0)
        self.key = theme.set_role(QLabel(""), "caption")
        self.key.setWordWrap(True)
        self._set_key(math.radians(20.0))
        plots.plot_with_panel(self, self.graphics, (*self.ranges, self.directional), (self.key,))

    def _set_key(self, tolerance_rad: float) -> None:
        degrees = math.degrees(tolerance_rad)
        self.key.setText(
            f"<span style='color:{theme.WITHIN}'>━━ solid blue</span>: pushing within "
            f"{degrees:.0f}° of the path's direction<br>"
            f"<span style='color:{theme.OUTSIDE}'>- - dashed vermillion</span>: pushing another "
            "way, or too lightly to tell")

    def show_view(self, view: TrialView) -> None:
        state = (id(view), view.n)
        if view is self._view and state == self._drawn:
            self._place_cursor(view)
            return
        first = view is not self._view
        self._view = view
        self._drawn = state
        if first:
            self._set_key(view.tolerance_rad)
        ex = view.exercise
        t = view.time[ex]
        period = view.sample_period_s * view.stride
        mask = samples.merge_short_runs(view.within[ex], round(samples.MERGE_RUNS_S / period))
        force = view.column("force")
        for a in range(len(AXES)):
            inside, outside = samples.split_by_mask(force[a, ex], mask)
            self.inside[a].setData(t, inside)
            self.outside[a].setData(t, outside)
        low, high = view.range_of("force")
        for a, axis in enumerate(AXES):
            self.ranges[a].set_value(
                high[a] - low[a],
                f"{MEANING[axis]}: from {format_number(low[a], 2)} to "
                f"{format_number(high[a], 2)} N")
        self.directional.set_value(
            view.directional_percent,
            f"of the exercise time within {math.degrees(view.tolerance_rad):.0f}° of the "
            "path's direction")
        self._place_cursor(view)

    def set_cursor(self, t: float | None) -> None:
        if self._view is not None:
            self._view.cursor = t
            self._place_cursor(self._view)

    def _place_cursor(self, view: TrialView) -> None:
        for line in self.cursors:
            plots.place_cursor(line, view.cursor)
