"""The EMG tab (thesis chapter 5): each muscle's RMS envelope in % of the session's MVC,
above the joint torques on the same time axis, with each MVC's quality, for a saved trial
(after the trial, and in replay). And a live source (a Trigno base station or an LSL
stream, app.emg.live): its status and the last seconds' RMS envelopes per channel in µV,
read on the capture's own thread (device.emg.capture), never in the loop. While it
streams, the window stores each trial's part of it in the trial's file when the file
closes (app.emg.importing.store_live_capture)."""

from __future__ import annotations

from PySide6.QtCore import QTimer
from PySide6.QtWidgets import QLabel, QLineEdit, QPushButton, QVBoxLayout, QWidget

from ui import plots, theme
from ui.views.emg import EmgView, emg_view
from ui.views.trialview import TrialView

LIVE_S = 5.0
LIVE_REFRESH_MS = 200
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
        # the live source
        self.live_plot = plots.make_plot("time (s)", "live RMS envelope (µV)")
        self.live_plot.hide()
        plots.legend(self.live_plot.getPlotItem())
        self.live_curves = []
        self.source_edit = QLineEdit()
        self.source_edit.setPlaceholderText("trigno:HOST or lsl:STREAM")
        self.connect_button = QPushButton("Connect EMG")
        self.connect_button.clicked.connect(self._toggle_live)
        self.live_status = theme.set_role(QLabel("No live EMG source."), "caption")
        self.live_status.setWordWrap(True)
        self.capture = None
        self.source_ports: dict = {}  # command_port / data_port for a non-standard TCU
        self.opener = plots.Background(self)
        self.opener.done.connect(self._opened)
        self.opener.failed.connect(self._open_failed)
        self.live_timer = QTimer(self)
        self.live_timer.setInterval(LIVE_REFRESH_MS)
        self.live_timer.timeout.connect(self._draw_live)
        stack = QWidget()
        column = QVBoxLayout(stack)
        column.setContentsMargins(0, 0, 0, 0)
        column.addWidget(self.envelopes, 1)
        column.addWidget(self.torques, 1)
        column.addWidget(self.live_plot, 1)
        plots.plot_with_panel(self, stack, (), (self.status, self.source_edit,
                                                 self.connect_button, self.live_status))

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

    # -- the live source ------------------------------------------------------------
    def _toggle_live(self) -> None:
        if self.capture is not None:
            self.stop_live()
            return
        from app.emg.live import open_source

        spec = self.source_edit.text()
        self.connect_button.setEnabled(False)
        self.live_status.setText(f"Connecting to {spec} …")
        self.opener.submit(spec, lambda: open_source(spec, **self.source_ports))

    def _opened(self, _token, result) -> None:
        from device.emg.capture import EmgCapture

        source, label = result
        self.capture = EmgCapture(source, latest_s=LIVE_S).start()
        self.live_label = label
        self.connect_button.setEnabled(True)
        self.connect_button.setText("Disconnect EMG")
        self.live_plot.show()
        self.live_status.setText(f"Streaming from {label} at {source.rate_hz:g} Hz.")
        self.live_timer.start()

    def _open_failed(self, _token, message: str) -> None:
        self.connect_button.setEnabled(True)
        self.live_status.setText(f"{theme.PROBLEM_SIGN} {message}")

    def stop_live(self) -> None:
        self.live_timer.stop()
        if self.capture is not None:
            captured = self.capture.stop()
            self.capture = None
            self.live_status.setText(
                f"Disconnected from {self.live_label} after {captured.samples.shape[0]} "
                "samples." + (f" {theme.PROBLEM_SIGN} {captured.error}" if captured.error
                              else ""))
        self.connect_button.setText("Connect EMG")

    def _draw_live(self) -> None:
        from core.emg.processing import rms_envelope

        capture = self.capture
        if capture is None:
            return
        if not capture.running:
            self.stop_live()
            return
        t, x = capture.latest()
        rate = capture.source.rate_hz
        if t.size < round(0.125 * rate):
            return
        env = rms_envelope(x - x.mean(axis=0), rate, t0_s=t[0] - t[-1])
        item = self.live_plot.getPlotItem()
        if len(self.live_curves) != env.values.shape[1]:
            for c in self.live_curves:
                item.removeItem(c)
            self.live_curves = [plots.curve(item, theme.SERIES[i % len(theme.SERIES)],
                                            name=f"EMG{i + 1}")
                                for i in range(env.values.shape[1])]
        for i, c in enumerate(self.live_curves):
            c.setData(env.t_s, 1e6 * env.values[:, i])
