"""The Trajectory performance tab (thesis Fig. 3.7, A.7, A.9): the hand's path against the
target, the position error in x and in y against time beneath it (the thesis window's
"position performance" plots, A.7), and the two kinds of performance as big numbers: how
close (RMSE in x and y) and how well aimed (directional performance, the share of the time
the push pointed within the tolerance of the path's direction).

The thesis draws this plot with both axes reversed so that it matches what the
patient sees across the robot; the flip is a display setting here (the data
stay in the robot's frame, docs/frames.md).
"""

from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Signal
from PySide6.QtWidgets import QCheckBox, QLabel, QVBoxLayout, QWidget

from app.reports.plain_language import own_pace_task
from app.units import CM_PER_M as CM, MM_PER_M as MM
from core.trial import TrialParameters
from ui import plots, theme
from ui.views import samples
from ui.views.trialview import TrialView

PATH_SPACING_M = 0.002


class TrajectoryTab(QWidget):
    """Signals: flip_changed(flip_x, flip_y) when the therapist mirrors the display
    (the window stores it in Settings.flip_x / flip_y)."""

    flip_changed = Signal(bool, bool)

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self._view: TrialView | None = None
        self._drawn: tuple = ()
        self._target_for: TrialParameters | None = None

        self.plot = plots.make_plot("x (cm)", "y (cm)")
        item = self.plot.getPlotItem()
        item.setAspectLocked(True)
        self.target = plots.curve(item, theme.TARGET, dashed=True, name="path to follow", xy=True)
        self.hand = plots.curve(item, theme.WITHIN, name="hand", xy=True)
        self.desired_mark = pg.ScatterPlotItem(symbol="o", size=16, pen=theme.pen(theme.BLACK),
                                               brush=pg.mkBrush(None))
        self.hand_mark = pg.ScatterPlotItem(symbol="o", size=10, pen=theme.pen(theme.BLUE),
                                            brush=pg.mkBrush(theme.BLUE))
        item.addItem(self.desired_mark)
        item.addItem(self.hand_mark)

        # the error on each axis against time: where in the trial the hand left the path
        self.error_plot = plots.make_plot("time (s)", "error (mm)")
        errors = self.error_plot.getPlotItem()
        plots.legend(errors)
        self.error_curves = [plots.curve(errors, theme.BLUE, name="x (sideways)"),
                             plots.curve(errors, theme.ORANGE, dashed=True,
                                         name="y (forward and back)")]
        self.cursor_line = plots.cursor_line(errors)
        # tall enough for its turned label beside the data at any font scale (at 1366 × 768
        # the label was cut): the label, the time axis below and the key above
        self.error_plot.setMinimumHeight(plots.label_room("error (mm)"))
        self.error_plot.setMaximumHeight(round(260 * theme.font_scale()))
        both = QWidget()
        stack = QVBoxLayout(both)
        stack.setContentsMargins(0, 0, 0, 0)
        stack.addWidget(self.plot, 3)
        stack.addWidget(self.error_plot, 1)

        self.rmse_x = plots.BigNumber("Position error, x (RMSE)", "mm")
        self.rmse_y = plots.BigNumber("Position error, y (RMSE)", "mm")
        self.directional = plots.BigNumber("Directional performance", "%", decimals=0)
        self.flip_x = QCheckBox("Flip left–right")
        self.flip_y = QCheckBox("Flip near–far")
        self.flip_x.setToolTip("Mirror the picture so it matches what the patient sees")
        self.flip_y.setToolTip("Mirror the picture so it matches what the patient sees")
        self.flip_x.toggled.connect(self._flip_toggled)
        self.flip_y.toggled.connect(self._flip_toggled)
        key = theme.set_role(QLabel(
            f"<span style='color:{theme.WITHIN}'>——</span> the hand &nbsp; "
            f"<span style='color:{theme.TARGET}'>- - -</span> the path to follow<br>"
            "● where the hand is &nbsp; ○ where it should be"), "caption")
        key.setWordWrap(True)

        plots.plot_with_panel(self, both, (self.rmse_x, self.rmse_y, self.directional),
                              (key, self.flip_x, self.flip_y))

    # -- flip -------------------------------------------------------------------
    def set_flip(self, flip_x: bool, flip_y: bool) -> None:
        """Restore the saved flip (Settings.flip_x, Settings.flip_y) without emitting."""
        for box, value in ((self.flip_x, flip_x), (self.flip_y, flip_y)):
            box.blockSignals(True)
            box.setChecked(value)
            box.blockSignals(False)
        self._apply_flip()

    def _flip_toggled(self) -> None:
        self._apply_flip()
        self.flip_changed.emit(self.flip_x.isChecked(), self.flip_y.isChecked())

    def _apply_flip(self) -> None:
        item = self.plot.getPlotItem()
        item.invertX(self.flip_x.isChecked())
        item.invertY(self.flip_y.isChecked())

    # -- data -------------------------------------------------------------------
    def show_view(self, view: TrialView) -> None:
        state = (id(view), view.n, view.cursor)
        if view is self._view and state == self._drawn:
            return
        self._view = view
        self._drawn = state
        self._draw_target(view)
        ex = view.exercise
        i = view.current_index
        own_pace = own_pace_task(view.parameters)
        self.error_plot.setVisible(not own_pace)
        if own_pace:
            self._show_own_pace(view, i)
            return
        if i < 0:
            self.hand.setData([], [])
            self.hand_mark.setData([], [])
            self.desired_mark.setData([], [])
            for line in self.error_curves:
                line.setData([], [])
        else:
            position = view.column("position")
            self._draw_errors(view, position, min(ex.stop, i + 1))
            self._draw_hand(view, position, i)
            desired = view.column("position_desired")[:, i]
            if np.isfinite(desired).all():
                self.desired_mark.setData([desired[0] * CM], [desired[1] * CM])
            else:
                self.desired_mark.setData([], [])
        rx, ry = view.rmse_xy_m
        self.rmse_x.set_value(rx * MM, "sideways, over the exercise")
        self.rmse_y.set_value(ry * MM, "forward and back, over the exercise")
        tolerance = math.degrees(view.tolerance_rad)
        self.directional.set_value(
            view.directional_percent,
            f"of the time the push pointed within {tolerance:.0f}° of the path's direction")

    def _draw_hand(self, view: TrialView, position: np.ndarray, i: int) -> None:
        """The hand's path over the exercise up to sample i, and where it is at i."""
        ex = view.exercise
        end = min(ex.stop, i + 1)
        if ex.start < end:
            # Thinned for drawing, always ending at the newest sample.
            step = samples.xy_step(end - ex.start)
            first = ex.start + (end - 1 - ex.start) % step
            trace = position[:, first:end:step] * CM
            self.hand.setData(trace[0], trace[1])
        else:
            self.hand.setData([], [])
        self.hand_mark.setData([position[0, i] * CM], [position[1, i] * CM])

    def _show_own_pace(self, view: TrialView, i: int) -> None:
        """A task the patient leads at their own pace (own_pace_task): the hand's path over
        the task's layout, and no error from, or push along, a reference on the task's clock
        (measured against it, the healthy patient's free reaches read 33 / 31 mm): the
        task's own figures are on the Assessments tab and the report's task page."""
        for line in self.error_curves:
            line.setData([], [])
        self.desired_mark.setData([], [])
        if i < 0:
            self.hand.setData([], [])
            self.hand_mark.setData([], [])
        else:
            self._draw_hand(view, view.column("position"), i)
        why = ("not for this task: the patient moves at their own pace, not the task's clock; "
               "its own figures are on the Assessments tab")
        self.rmse_x.set_value(math.nan, why)
        self.rmse_y.set_value(math.nan, "")
        self.directional.set_value(math.nan, "")

    def _draw_errors(self, view: TrialView, position: np.ndarray, end: int) -> None:
        """Hand minus desired position on each axis, in mm, over the exercise up to `end`."""
        ex = view.exercise
        if end <= ex.start:
            for line in self.error_curves:
                line.setData([], [])
            return
        span = slice(ex.start, end)
        error = (position[:, span] - view.column("position_desired")[:, span]) * MM
        t = view.time[span]
        for axis, line in enumerate(self.error_curves):
            line.setData(t, error[axis])
        plots.place_cursor(self.cursor_line, view.cursor)

    def set_cursor(self, t: float | None) -> None:
        if self._view is not None:
            self._view.cursor = t
            self.show_view(self._view)

    def _draw_target(self, view: TrialView) -> None:
        parameters = view.parameters
        if parameters is not None:
            if parameters == self._target_for:
                return
            points = parameters.path().points(PATH_SPACING_M) * CM
            self.target.setData(points[:, 0], points[:, 1])
            self._target_for = parameters
            return
        # A file without parameters: the desired positions are the path.
        self._target_for = None
        desired = view.column("position_desired")[:, view.exercise]
        desired = desired[:, ::samples.xy_step(desired.shape[1])] * CM
        self.target.setData(desired[0], desired[1])
