"""The Human joint torques tab (thesis Fig. 3.12, A.8): the net shoulder and elbow
torques over the exercise, raw as the thesis shows them, or smoothed on request
with the 10 Hz zero-lag low-pass the thesis suggests (section 3.6.3), with each
joint's range.

The raw torques are noisy because they come from differentiated encoder angles.
Smoothing filters the whole exercise, so it runs off the GUI thread: once when
switched on for a finished trial, at most once a second while a trial runs.
"""

from __future__ import annotations

import math
import time

import numpy as np
from PySide6.QtCore import Signal
from PySide6.QtWidgets import QCheckBox, QLabel, QWidget

from app.reports.plain_language import robot_only_lightened
from core.metrics import DEFAULT_TORQUE_CUTOFF_HZ, value_range
from core.signal import lowpass, min_samples
from ui import plots, theme
from ui.views.numbers import format_number
from ui.views.trialview import TrialView

JOINTS = ("shoulder", "elbow")
LIVE_SMOOTHING_INTERVAL_S = 1.0


def smooth_torques(torque: np.ndarray, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(smoothed (2, n), ranges (2,)): the job run off the GUI thread."""
    smoothed = lowpass(torque.T, dt_s, DEFAULT_TORQUE_CUTOFF_HZ, nan_policy="interpolate",
                       name="subject_torque").T
    return smoothed, value_range(smoothed.T)


def help_words(help_J: float) -> str:
    """The robot's help as the therapist reads it: a negative help is the robot holding
    the hand back (its pull against the hand's way), said so rather than as a help of
    "−0.22 J" beside a share of 0 %."""
    if math.isfinite(help_J) and round(help_J, 2) < 0.0:
        return f"the robot held the hand back {format_number(-help_J, 2)} J"
    # one that rounds to zero is none, never "−0.00" (metrics_table.number_text)
    shown = abs(help_J) if math.isfinite(help_J) and not round(help_J, 2) else help_J
    return f"robot's help {format_number(shown, 2)} J"


class TorquesTab(QWidget):
    """Signals: smoothed() when the smoothed curves are on screen."""

    smoothed = Signal()

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self._view: TrialView | None = None
        self._drawn: tuple = ()
        self._smoothed_for: tuple = ()
        self._requested: tuple = ()
        self._requested_at = -np.inf
        self._smoothed: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self.background = plots.Background(self)
        self.background.done.connect(self._smoothing_done)
        self.background.failed.connect(self._smoothing_failed)

        self.plot = plots.make_plot("time (s)", "torque (N·m)")
        item = self.plot.getPlotItem()
        self.curves = plots.joint_curves(item)
        self.cursor_line = plots.cursor_line(item)
        self.ranges = [plots.BigNumber(f"{joint.capitalize()} torque range", "N·m", decimals=2)
                       for joint in JOINTS]
        # who moved the handle: the robot gives way as the patient does more (the
        # as-needed assistance), and this is where the therapist sees it during a trial
        self.work_share = plots.BigNumber("Robot's share of the work", "%", decimals=0)
        self.smoothing = QCheckBox(f"Smooth ({DEFAULT_TORQUE_CUTOFF_HZ:g} Hz low-pass)")
        self.smoothing.setToolTip("The raw torques carry the noise of differentiated encoder "
                                  "angles; smoothing removes what is faster than human movement")
        self.smoothing.toggled.connect(self._smoothing_toggled)
        self.note = theme.set_role(QLabel("Raw torques, as computed every 2 ms."), "caption")
        self.note.setWordWrap(True)
        plots.plot_with_panel(self, self.plot, (*self.ranges, self.work_share),
                              (self.smoothing, self.note))

    # -- public -------------------------------------------------------------------
    def set_smoothing(self, on: bool) -> None:
        self.smoothing.setChecked(on)

    def show_view(self, view: TrialView) -> None:
        state = (id(view), view.n, view.finished)
        if view is self._view and state == self._drawn:
            plots.place_cursor(self.cursor_line, view.cursor)
            return
        if view is not self._view:
            self._smoothed = None
        self._view = view
        self._drawn = state
        if self.smoothing.isChecked():
            self._request_smoothing(view)
            self._draw_smoothed()
        else:
            self._draw_raw(view)
        self._draw_work(view)
        plots.place_cursor(self.cursor_line, view.cursor)

    def set_cursor(self, t: float | None) -> None:
        if self._view is not None:
            self._view.cursor = t
            plots.place_cursor(self.cursor_line, self._view.cursor)

    # -- drawing ------------------------------------------------------------------
    def _draw_work(self, view: TrialView) -> None:
        robot, patient = view.work_J
        share = view.robot_work_share
        # the share counts the help alone (core.work.MechanicalWork): its work is shown
        # beside the motors' so that the two are not read as one
        detail = (f"{help_words(view.help_J)} (motors {format_number(robot, 2)} J), "
                  f"patient {format_number(patient, 2)} J, over the exercise"
                  f"{'' if view.finished else ' so far'}")
        if robot_only_lightened(view.parameters):
            # the motors' work went into the robot's own friction and inertia: no share of
            # moving the handle (plain_language.own_work_line)
            share = float("nan")
            detail += "; the motors only made up for the robot's own friction and inertia"
        self.work_share.set_value(share * 100.0, detail)

    def _draw_raw(self, view: TrialView) -> None:
        ex = view.exercise
        t = view.time[ex]
        torque = view.column("subject_torque")
        for j, line in enumerate(self.curves):
            line.setData(t, torque[j, ex])
        low, high = view.range_of("subject_torque")
        for j, number in enumerate(self.ranges):
            number.set_value(high[j] - low[j], f"raw: from {format_number(low[j], 2)} "
                                               f"to {format_number(high[j], 2)} N·m")
        self.note.setText("Raw torques, as computed every 2 ms.")

    def _draw_smoothed(self) -> None:
        if self._smoothed is None:
            if self._view is not None:
                self._draw_raw(self._view)
            self.note.setText("Smoothing…")
            return
        t, smoothed, ranges = self._smoothed
        for j, line in enumerate(self.curves):
            line.setData(t, smoothed[j])
        for j, number in enumerate(self.ranges):
            number.set_value(ranges[j], f"smoothed ({DEFAULT_TORQUE_CUTOFF_HZ:g} Hz)")
        live = self._view is not None and not self._view.finished
        self.note.setText("Smoothed; updated once a second while the trial runs." if live
                          else "Smoothed with a zero-lag 10 Hz low-pass filter.")

    # -- smoothing off the GUI thread ------------------------------------------------
    def _smoothing_toggled(self, on: bool) -> None:
        if self._view is None:
            return
        if on:
            self._requested = ()
            self._request_smoothing(self._view)
            self._draw_smoothed()
        else:
            self._draw_raw(self._view)

    def _request_smoothing(self, view: TrialView) -> None:
        token = (id(view), view.n, view.finished)
        if token in (self._requested, self._smoothed_for):
            return
        now = time.monotonic()
        if not view.finished and now - self._requested_at < LIVE_SMOOTHING_INTERVAL_S:
            return
        ex = view.exercise
        if ex.stop - ex.start < min_samples():
            return
        self._requested = token
        self._requested_at = now
        t = view.time[ex].copy()
        torque = view.column("subject_torque")[:, ex].copy()
        dt = view.sample_period_s * view.stride
        self.background.submit(token, lambda: (t, *smooth_torques(torque, dt)))

    def _smoothing_done(self, token, result) -> None:
        view = self._view
        if view is None or token[0] != id(view):
            return
        self._smoothed_for = token
        self._smoothed = result
        if self.smoothing.isChecked():
            self._draw_smoothed()
            self.smoothed.emit()

    def _smoothing_failed(self, token, message: str) -> None:
        if self._view is not None:
            self._draw_raw(self._view)
        self.note.setText(f"{theme.PROBLEM_SIGN} Smoothing failed ({message}); showing raw.")

