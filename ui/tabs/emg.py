"""The EMG tab (thesis chapter 5): each muscle's RMS envelope in % of the session's MVC,
above the joint torques on the same time axis, with each MVC's quality. Shown for a saved
trial (after the trial, and in replay); EMG captured live is stored with the trial when it
ends (docs/data-format.md, `/emg`)."""

from __future__ import annotations

from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget

from ui import plots, theme
from ui.views.emg import EmgView, emg_view
from ui.views.trialview import TrialView

FLAG_WORDS = {"too_short": "too short", "saturated": "saturated",
              "below_trial_activity": "lower than the trial's activity"}


class EmgTab(QWidget):
    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self._view: TrialView | None = None
        self._shown: tuple = ()
        self.data = EmgView()
        self.envelopes = plots.make_plot("time (s)", "EMG envelope (% MVC)")
        self.torques = plots.make_plot("time (s)", "torque (N·m)")
        self.torques.setXLink(self.envelopes)
        item = self.envelopes.getPlotItem()
        plots.legend(item)
        self.curves = []
        self.torque_curves = plots.joint_curves(self.torques.getPlotItem())
        self.cursors = [plots.cursor_line(item), plots.cursor_line(self.torques.getPlotItem())]
        self.status = theme.set_role(QLabel(""), "caption")
        self.status.setWordWrap(True)
        stack = QWidget()
        column = QVBoxLayout(stack)
        column.setContentsMargins(0, 0, 0, 0)
        column.addWidget(self.envelopes, 1)
        column.addWidget(self.torques, 1)
        plots.plot_with_panel(self, stack, (), (self.status,))

    def show_view(self, view: TrialView) -> None:
        key = (id(view), view.finished, str(view.source))
        if key != self._shown:
            self._shown, self._view = key, view
            if view.finished:
                self.data = emg_view(view.source)
            else:
                self.data = EmgView(message="EMG shows here when the trial is saved.")
            self._draw(view)
        for line in self.cursors:
            plots.place_cursor(line, view.cursor)

    def set_cursor(self, t: float | None) -> None:
        if self._view is not None:
            self._view.cursor = t
            for line in self.cursors:
                plots.place_cursor(line, t)

    def _draw(self, view: TrialView) -> None:
        item = self.envelopes.getPlotItem()
        for c in self.curves:
            item.removeItem(c)
        self.curves = [plots.curve(item, theme.SERIES[i % len(theme.SERIES)], name=m, gaps=True)
                       for i, m in enumerate(self.data.muscles)]
        for i, c in enumerate(self.curves):
            c.setData(self.data.time_s, self.data.percent[:, i])
        ex = view.exercise
        torque = view.column("subject_torque")
        for j, line in enumerate(self.torque_curves):
            line.setData(view.time[ex], torque[j, ex])
        lines = [self.data.message] if self.data.message else []
        for muscle, peak in self.data.peaks.items():
            flags = self.data.flags.get(muscle, ())
            quality = "MVC ok" if not flags else theme.PROBLEM_SIGN + " MVC " + \
                ", ".join(FLAG_WORDS.get(f, f) for f in flags)
            lines.append(f"{muscle.replace('_', ' ')}: up to {peak:.0f} % MVC; {quality}")
        self.status.setText("\n".join(lines))
