"""The EMG tab (thesis chapter 5): each muscle's RMS envelope in % of the session's MVC,
above the joint torques on the same time axis, with each MVC's quality, for a saved trial
(after the trial, and in replay). And a live source (a Trigno base station or an LSL
stream, app.emg.live): its status, the guided MVC protocol of the patient's session
(app.emg.protocol: rest, push with a countdown, the MVC and its quality at once, record
again), and the last seconds' envelopes, in % MVC per muscle once the session has its
MVCs (µV per channel before), read on the capture's own thread (device.emg.capture),
never in the loop. While it streams, the window stores each trial's part of it, with the
session's MVCs, in the trial's file when the file closes (app.emg.protocol.store_trial).
Every status line and refusal also goes to the window's message model (`said`)."""

from __future__ import annotations

import html
import logging
import time

from PySide6.QtCore import QTimer, Signal
from PySide6.QtWidgets import (
    QComboBox,
    QGridLayout,
    QGroupBox,
    QLabel,
    QLineEdit,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from app.emg.live import KINDS
from app.emg.muscle_words import words
from app.emg.mvc_words import short_flags, todo
from app.emg.protocol import PUSH_S, REST_S, WAITING, SessionMvcs
from core.emg.synthetic import THESIS_MUSCLES
from ui import plots, theme
from ui.fields import DoubleSpinBox
from ui.tabs.emg_channels import ChannelChooser
from ui.views.emg import EmgView, emg_view, live_emg_view
from ui.views.trialview import TrialView

LIVE_S = 5.0
LIVE_REFRESH_MS = 200
PROTOCOL_TICK_MS = 100  # the countdown's refresh
log = logging.getLogger(__name__)  # the day log: a flagged MVC's reasons with their figures


def mvc_line(mvc) -> str:
    """One muscle's MVC and its quality, in words."""
    head = f"{words(mvc.muscle)}: MVC {1e6 * mvc.value_V:.0f} µV, held {mvc.hold_s:.1f} s"
    if mvc.ok:
        return f"{head}: ok"
    return f"{head}: {theme.PROBLEM_SIGN} {short_flags(mvc.flags)}. Record again."


class EmgTab(QWidget):
    said = Signal(str, bool)  # a line for the window's message model: text, problem
    mvc_recorded = Signal(str)  # a muscle's MVC was (re)recorded for the session
    range_problem = Signal(str)
    """The live source's numbers reach volts (app.emg.protocol.live_range_problem, in
    words; '' once they no longer do): seen whether the tab is in view or not, so that a
    running trial's file can say it (ui.window.trial_emg)."""

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self._view: TrialView | None = None
        self._shown: tuple = ()
        self.data = EmgView()
        # labels on two short lines, and the time said once under the torques (the axes
        # are linked): at 1366 × 768 with the live plot too, each plot's axis is 60-120 px
        # high, and "EMG envelope (% MVC)" was cut to "EMG envelope (% MV"
        self.envelopes = plots.make_plot("", "EMG<br>(% MVC)")
        self.torques = plots.make_plot("time (s)", "torque<br>(N·m)")
        self.torques.setXLink(self.envelopes)
        item = self.envelopes.getPlotItem()
        plots.legend(item)
        self.curves = []
        self.torque_curves = plots.joint_curves(self.torques.getPlotItem())
        self.cursors = [plots.cursor_line(item), plots.cursor_line(self.torques.getPlotItem())]
        self.status = theme.set_role(QLabel(""), "caption")
        self.status.setWordWrap(True)
        # the live source
        self.live_plot = plots.make_plot("time (s)", "live EMG<br>(µV)")
        self.live_plot.hide()
        # its key in the panel beside it, wrapped in as many lines as the names need: a
        # key above the plot showed the source's 16 channels on one row wider than the
        # plot (EMG7, EMG8 off its right, the plot widened past its window) and, once the
        # MVCs made them three muscles, spread these over that width, 'anterior deltoid'
        # cut; in rows it would take the height the plot's label needs at 1366 × 768
        self.live_key = theme.set_role(QLabel(""), "caption")
        self.live_key.setWordWrap(True)
        self.live_key.setAccessibleName("live EMG key")
        self.live_curves = []
        self.live_unit = ""
        self.source_kind = QComboBox()
        for kind, label in KINDS.items():
            self.source_kind.addItem(label, kind)
        self.source_edit = QLineEdit()
        self.source_edit.setPlaceholderText("host (192.168.1.20) or LSL stream name")
        self.connect_button = QPushButton("Connect EMG")
        self.connect_button.clicked.connect(self._toggle_live)
        self.live_status = theme.set_role(QLabel("No live EMG source: choose one and "
                                                 "press Connect EMG."), "caption")
        self.live_status.setWordWrap(True)
        self.capture = None
        self.live_label = ""
        self.live_problem = ""
        self.lost: tuple | None = None  # (Captured, label) of a source that died
        self.source_ports: dict = {}  # command_port / data_port for a non-standard TCU
        self.opener = plots.Background(self)
        self.opener.done.connect(self._opened)
        self.opener.failed.connect(self._open_failed)
        self.live_timer = QTimer(self)
        self.live_timer.setInterval(LIVE_REFRESH_MS)
        self.live_timer.timeout.connect(self._draw_live)
        # filtering the last seconds takes ~10 ms (bench/emg.py): off the GUI thread,
        # which repaints the live plots every 16 ms
        self.live_worker = plots.Background(self)
        self.live_worker.done.connect(self._show_live)
        self._build_protocol()
        stack = QWidget()
        column = QVBoxLayout(stack)
        column.setContentsMargins(0, 0, 0, 0)
        column.addWidget(self.envelopes, 5)
        column.addWidget(self.torques, 5)
        column.addWidget(self.live_plot, 6)  # its key takes two rows for 16 channels
        plots.plot_with_panel(self, stack, (), (self.status, self.source_kind,
                                                 self.source_edit, self.connect_button,
                                                 self.live_status, self.live_key,
                                                 self.protocol_box))

    def _build_protocol(self) -> None:
        """The guided MVC protocol: each muscle's source channel, its MVC and a button to
        record it; the rest and push durations; the prompt with the countdown."""
        self.session: SessionMvcs | None = None
        self.trial_running = False  # the window says so: no MVC while a trial runs
        self.clock = time.monotonic  # the clock of the capture's stamps (device.emg)
        self.guided = None
        self.guided_channel = 0
        self.protocol_box = QGroupBox("MVC protocol (one per muscle per session)")
        grid = QGridLayout(self.protocol_box)
        self.channel_boxes: dict[str, ChannelChooser] = {}
        self.mvc_labels: dict[str, QLabel] = {}
        self.record_buttons: dict[str, QPushButton] = {}
        for row, muscle in enumerate(THESIS_MUSCLES):
            grid.addWidget(QLabel(words(muscle)), row, 0)
            box = ChannelChooser()
            box.setAccessibleName(f"{words(muscle)}'s channel")
            box.setValue(row + 1)
            box.setToolTip("the source channel (sensor) on this muscle")
            box.valueChanged.connect(lambda value, m=muscle: self._channel_changed(m, value))
            self.channel_boxes[muscle] = box
            grid.addWidget(box, row, 1)
            button = QPushButton("Record")
            button.clicked.connect(lambda _=False, m=muscle: self.record_mvc(m))
            self.record_buttons[muscle] = button
            grid.addWidget(button, row, 2)
            label = theme.set_role(QLabel(f"{words(muscle)}: no MVC yet"), "caption")
            label.setWordWrap(True)
            self.mvc_labels[muscle] = label
            grid.addWidget(label, len(THESIS_MUSCLES) + 2 + row, 0, 1, 3)
        n = len(THESIS_MUSCLES)
        self.rest_seconds = DoubleSpinBox()
        self.rest_seconds.setAccessibleName("MVC rest")
        self.rest_seconds.setRange(0.0, 30.0)
        self.rest_seconds.setValue(REST_S)
        self.rest_seconds.setSuffix(" s rest")
        self.push_seconds = DoubleSpinBox()
        self.push_seconds.setAccessibleName("MVC push")
        self.push_seconds.setRange(0.5, 10.0)
        self.push_seconds.setValue(PUSH_S)
        self.push_seconds.setSuffix(" s push")
        grid.addWidget(self.rest_seconds, n, 0)
        grid.addWidget(self.push_seconds, n, 1)
        self.cancel_button = QPushButton("Cancel")
        self.cancel_button.setEnabled(False)
        self.cancel_button.clicked.connect(lambda _=False: self.cancel_mvc())
        grid.addWidget(self.cancel_button, n, 2)
        self.prompt = theme.set_role(QLabel("Register the patient, connect the EMG source, "
                                            "then record each muscle's MVC."), "heading")
        self.prompt.setWordWrap(True)
        grid.addWidget(self.prompt, n + 1, 0, 1, 3)
        self.protocol_timer = QTimer(self)
        self.protocol_timer.setInterval(PROTOCOL_TICK_MS)
        self.protocol_timer.timeout.connect(self._protocol_tick)
        self.measurer = plots.Background(self)
        self.measurer.done.connect(self._measured)
        self.measurer.failed.connect(self._measure_failed)

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
        # the muscles in words, as the live plot and the status line name them (the legend
        # said "anterior_deltoid" beside "anterior deltoid")
        self.curves = [plots.curve(item, theme.SERIES[i % len(theme.SERIES)], name=words(m),
                                   gaps=True)
                       for i, m in enumerate(self.data.muscles)]
        for i, c in enumerate(self.curves):
            c.setData(self.data.time_s, self.data.percent[:, i])
        ex = view.exercise
        torque = view.column("subject_torque")
        for j, line in enumerate(self.torque_curves):
            line.setData(view.time[ex], torque[j, ex])
        plots.show_whole(self.torques.getPlotItem(), view.time)
        lines = [self.data.message] if self.data.message else []
        lines += [f"{theme.PROBLEM_SIGN} The EMG: {note}." for note in self.data.notes]
        for muscle, peak in self.data.peaks.items():
            flags = self.data.flags.get(muscle, ())
            quality = "MVC ok" if not flags else f"{theme.PROBLEM_SIGN} MVC {short_flags(flags)}"
            # named as the key above names it ('biceps brachii', not 'biceps')
            lines.append(f"{words(muscle)}: up to {peak:.0f} % MVC; {quality}")
        self.status.setText("\n".join(lines))

    # -- the live source ------------------------------------------------------------
    def _say(self, text: str, problem: bool = False) -> None:
        self.said.emit(text, problem)

    def _toggle_live(self) -> None:
        if self.capture is not None:
            self.stop_live()
            return
        from app.emg.live import open_source, source_spec

        spec = source_spec(self.source_kind.currentData(), self.source_edit.text())
        self.connect_button.setEnabled(False)
        self.live_status.setText(f"Connecting to {spec} …")
        self.opener.submit(spec, lambda: open_source(spec, **self.source_ports))

    def _opened(self, _token, result) -> None:
        from device.emg.capture import EmgCapture

        source, label = result
        self.capture = EmgCapture(source, latest_s=LIVE_S).start()
        self.live_label = label
        self.live_problem = ""
        self.lost = None
        for box in self.channel_boxes.values():  # by the source's own names, if it has any
            box.name_channels(getattr(source, "labels", ()))
        self.connect_button.setEnabled(True)
        self.connect_button.setText("Disconnect EMG")
        self.live_plot.show()
        text = " ".join((f"EMG streaming from {label} at {source.rate_hz:g} Hz.",
                         *(f"{note[0].upper()}{note[1:]}." for note in
                           getattr(source, "notes", ()))))
        self.live_status.setText(text)
        self._say(text)
        self.live_timer.start()

    def _open_failed(self, _token, message: str) -> None:
        self.connect_button.setEnabled(True)
        self.live_status.setText(f"{theme.PROBLEM_SIGN} {message}")
        self._say(f"EMG not connected: {message}", True)

    def stop_live(self) -> None:
        self.live_timer.stop()
        if self.capture is not None:
            capture, self.capture = self.capture, None
            died = not capture.running
            captured = capture.stop()
            if self.guided is not None:
                self.cancel_mvc("the EMG source stopped; nothing recorded. Connect it "
                                "again, then record" if died else "")
            # a trial running now keeps what came before the source stopped
            self.lost = (captured, self.live_label) if self.trial_running else None
            if died:
                text = (f"EMG source {self.live_label} stopped after "
                        f"{captured.samples.shape[0]} samples: {captured.error or 'no data'}. "
                        "The trial goes on without EMG; check the source, then Connect EMG.")
                self.live_status.setText(f"{theme.PROBLEM_SIGN} {text}")
                self._say(text, True)
            else:
                self.live_status.setText(f"Disconnected from {self.live_label} after "
                                         f"{captured.samples.shape[0]} samples.")
        self.connect_button.setText("Connect EMG")

    def _draw_live(self) -> None:
        capture = self.capture
        if capture is None:
            return
        if not capture.running:
            self.stop_live()
            return
        if not self.isVisible():
            # nothing drawn, but the source's unit is still watched: a trial runs while
            # another tab is in view, and its file must say what its EMG is
            self._range_seen(capture)
            return
        if self.live_worker.busy:
            return  # the last refresh is still being computed: skip this one
        t, x = capture.latest()
        session = None if self.session is None else self.session.copy()
        # before a patient is registered, the muscles the choosers put on channels
        self.live_worker.submit(None, live_emg_view, t, x, capture.source.rate_hz, session,
                                getattr(capture.source, "labels", ()), self.live_label,
                                self._channels())

    def _show_live(self, _token, view) -> None:
        if view is None or self.capture is None:
            return
        item = self.live_plot.getPlotItem()
        names = tuple(words(n) for n in view.names)
        colours = [theme.SERIES[i % len(theme.SERIES)] for i in range(len(names))]
        if [c.name() for c in self.live_curves] != list(names):
            for c in self.live_curves:
                item.removeItem(c)
            self.live_curves = [plots.curve(item, colour, name=n)
                                for colour, n in zip(colours, names, strict=True)]
        # what streams but is not drawn, quietly under the key (a muscle without a usable
        # MVC, the channels no muscle is on)
        key = " &nbsp; ".join(f"<span style='color:{colour}'>━</span>&nbsp;{n}"
                              for colour, n in zip(colours, names, strict=True))
        key += "".join(f"<br><span style='color:{theme.MUTED}'>"
                       f"{html.escape(line, quote=False)}</span>"
                       for line in view.aside)
        if key != self.live_key.text():
            self.live_key.setText(key)
        if view.unit != self.live_unit:
            self.live_unit = view.unit
            item.setLabel("left", f"live EMG<br>({view.unit})")
            theme.style_plot(item)  # a bare setLabel sets it in pyqtgraph's larger type
        for i, c in enumerate(self.live_curves):
            c.setData(view.t_s, view.values[:, i])
        self._show_problem(view.problem)

    def _range_seen(self, capture) -> None:
        """The latest seconds' range checked on the window's thread (a maximum: well under
        a millisecond), the tab out of view."""
        from app.emg.importing import channel_names
        from app.emg.protocol import live_range_problem

        _t, x = capture.latest()
        if x.ndim != 2 or not x.shape[0]:
            return
        names = channel_names(getattr(capture.source, "labels", ()), x.shape[1])
        self._show_problem(live_range_problem(x, range(x.shape[1]), names, self.live_label))

    def _show_problem(self, problem: str) -> None:
        if problem and problem != self.live_problem:  # said once, not each refresh
            self.live_status.setText(f"{theme.PROBLEM_SIGN} {problem}")
            self._say(problem, True)
        if problem != self.live_problem:
            self.live_problem = problem
            self.range_problem.emit(problem)

    # -- the MVC protocol -----------------------------------------------------------
    def set_session(self, patient: str, session: int) -> None:
        """The registered patient's session: its MVCs are kept until another session is
        registered (a new patient or a new session starts without them)."""
        if self.session is not None and self.session.belongs_to(patient, session):
            return
        self.session = SessionMvcs(patient, session, self._channels())
        for muscle, label in self.mvc_labels.items():
            label.setText(f"{words(muscle)}: no MVC yet")
        self.prompt.setText(f"Session {session} of {patient}: record each muscle's MVC.")

    def _channels(self) -> dict[str, int]:
        return {m: box.value() - 1 for m, box in self.channel_boxes.items()}

    def _channel_changed(self, muscle: str, value: int) -> None:
        if self.session is None:
            return
        self.session.channels[muscle] = value - 1
        if self.session.forget(muscle):
            self.mvc_labels[muscle].setText(f"{words(muscle)}: no MVC yet (its channel "
                                            "changed: record it again)")

    def record_mvc(self, muscle: str) -> None:
        """Guide one muscle's MVC: rest, push with a countdown, then its MVC and quality."""
        refusal = self._refusal()
        if refusal:
            self.prompt.setText(f"{theme.PROBLEM_SIGN} {refusal}")
            self._say(refusal, True)
            return
        from app.emg.protocol import GuidedMvc

        self.guided = GuidedMvc(muscle, rest_s=self.rest_seconds.value(),
                                push_s=self.push_seconds.value(), clock=self.clock)
        self.guided_channel = self.session.channels[muscle]
        self._set_recording(True)
        self._protocol_tick()
        self.protocol_timer.start()

    def _refusal(self) -> str:
        if self.session is None:
            return ("Register the patient first (Registration tab): an MVC belongs to the "
                    "patient's session.")
        if self.capture is None:
            return "Connect an EMG source first (source above, then Connect EMG)."
        if self.trial_running:
            return ("A trial is running: record the MVCs before the session's trials or "
                    "between them.")
        if self.guided is not None or self.measurer.busy:
            return "An MVC is being recorded: wait for it, or Cancel."
        return ""

    def _set_recording(self, on: bool) -> None:
        for button in self.record_buttons.values():
            button.setEnabled(not on)
        for box in self.channel_boxes.values():
            box.setEnabled(not on)
        self.cancel_button.setEnabled(on)

    def cancel_mvc(self, why: str = "") -> None:
        self.protocol_timer.stop()
        if self.guided is not None:
            self.prompt.setText(f"{words(self.guided.muscle)}: "
                                f"{why or 'cancelled; nothing recorded'}.")
        self.guided = None
        self._set_recording(False)

    def _protocol_tick(self) -> None:
        guided, capture = self.guided, self.capture
        if guided is None or capture is None:
            return
        step = guided.step()
        self.prompt.setText(step.text)
        if step.phase != WAITING:
            return
        if guided.ready(capture.last_stamp_s):
            self.protocol_timer.stop()
            self._measure(guided, capture)
        elif guided.late():
            self.protocol_timer.stop()
            self._measure_failed(None, f"{words(guided.muscle)}: no EMG came from "
                                       f"{self.live_label} after the contraction; check the "
                                       "source's status, then record again")

    def _measure(self, guided, capture) -> None:
        """The MVC on the worker: filtering seconds of EMG and reading the session's trials
        must not hold the window."""
        from app.emg.importing import channel_names
        from app.emg.live import full_scale_of
        from app.emg.protocol import MvcRecord, contraction_mvc
        from app.emg.session import check_with_trials
        from core.emg.processing import EmgSettings

        stamps, samples = capture.between(*guided.push_span)
        _, resting = capture.between(*guided.rest_span)
        rate, muscle, channel = capture.source.rate_hz, guided.muscle, self.guided_channel
        label, trials = self.live_label, list(self.session.trials)
        settings, full_scale = EmgSettings(), full_scale_of(self.live_label)
        declared = getattr(capture.source, "labels", ())

        def measure():
            mvc = contraction_mvc(stamps, samples, rate, muscle, channel, settings=settings,
                                  full_scale_V=full_scale, wanted_s=guided.push_s,
                                  source=label, rest_samples=resting)
            checked = check_with_trials(trials, [mvc], settings_of={muscle: settings})
            # the channel in range (contraction_mvc refuses another), named as stored
            name = channel_names(declared, samples.shape[1])[channel]
            return mvc, checked[muscle], MvcRecord(mvc, channel, label, settings, name)

        self.prompt.setText(f"{words(muscle)}: relax. Computing the MVC …")
        self.measurer.submit(muscle, measure)

    def _measured(self, muscle, result) -> None:
        _mvc, checked, record = result
        self.guided = None
        self._set_recording(False)
        if self.session is None:
            return
        self.session.records[muscle] = record
        self.show_mvc(checked)
        self.record_buttons[muscle].setText("Record again")
        self.mvc_recorded.emit(muscle)

    def show_mvc(self, mvc) -> None:
        """A muscle's MVC with its quality, in its row and the prompt; the message line
        says a flagged one in short with what to do (its reasons, a paragraph each, are the
        row's tooltip and in the day log: said whole, they filled the line in small type)."""
        line = mvc_line(mvc)
        if self.session is not None and mvc.muscle in self.session.records:
            # the live view reads % MVC only by an MVC this row does not flag
            self.session.judged(mvc)
        self.mvc_labels[mvc.muscle].setText(line)
        self.mvc_labels[mvc.muscle].setToolTip("\n".join(mvc.reasons))
        self.prompt.setText(line)
        if mvc.ok:
            self._say(line)
            return
        for reason in mvc.reasons:
            log.warning("MVC flagged: %s", reason)
        self._say(f"{words(mvc.muscle)}'s MVC: {short_flags(mvc.flags)}. {todo(mvc.flags)} "
                  "(why: point at its row on the EMG tab).", True)

    def _measure_failed(self, _token, message: str) -> None:
        self.guided = None
        self._set_recording(False)
        self.prompt.setText(f"{theme.PROBLEM_SIGN} {message}")
        self._say(message, True)
