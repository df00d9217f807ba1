"""The console's window: the thesis's tabs (Appendix A), the robot buttons and the emergency
stop on every tab, a fault banner, and a status bar with the loop's state and health.

The window only arranges and forwards: the loop runs in its own process behind
`DeviceBridge`, files and the registry live in `app`, and anything that touches the disk
(finishing a trial, writing a report) runs on the job thread (`ui.jobs`) so the window
never waits. The loop's health in the status bar is `ui.views.loop_health`.
"""

from __future__ import annotations

import base64
import contextlib
import logging
from pathlib import Path

from PySide6.QtCore import Qt, QTimer
from PySide6.QtGui import QFont, QFontMetrics, QKeySequence, QShortcut
from PySide6.QtWidgets import (
    QDialog,
    QFrame,
    QHBoxLayout,
    QLabel,
    QMainWindow,
    QMessageBox,
    QPlainTextEdit,
    QPushButton,
    QSizePolicy,
    QTabWidget,
    QVBoxLayout,
    QWidget,
)

from app.records.registry import Patient, Registration
from app.records.settings import Settings, load_settings, save_settings
from app.records.store import RecordStore
from app.trials.finalize import finish_interrupted
from core.trial import TrialParameters
from device.loop.messages import BackendConfig
from device.loop.states import State
from device.recording.trialfile import SubjectInfo
from device.safety.faults import Fault
from ui import theme
from ui.device_bridge import DeviceBridge
from ui.force_estimate import ForceEstimateControl
from ui.jobs import Jobs
from ui.robot_bar import RobotBar
from ui.tabs import (
    TABS,
    VIEW_TABS,
    AnglesTab,
    EmgTab,
    ForceTab,
    InstructionsTab,
    ParametersTab,
    ProgressTab,
    RegistrationTab,
    ReplayTab,
    ReportTab,
    TorquesTab,
    TrajectoryTab,
    VideoTab,
)
from ui.tabs.parameters import HARDWARE, SIMULATOR, BackendChoice
from ui.views.loop_health import LoopHealth
from ui.views.messages import Messages
from ui.views.trialview import TrialView

log = logging.getLogger(__name__)

REPAINT_MS = 16  # ~60 Hz; the tabs draw only what is visible
HEARTBEAT_MS = 100  # the loop faults after 0.5 s without one
HEALTH_MS = 500
CLEAR_DELAY_MS = 20  # ten loop ticks
MESSAGE_LINES = 2
"""Lines of text the event line and the fault banner have: fixed, so that no message can
grow the window and push the emergency stop off the screen (the full text is the tooltip
and in the history)."""
CONNECTED_STATES = (State.CONNECTED, State.RUNNING, State.STOPPING)


class MainWindow(QMainWindow):
    """The therapist's console."""

    def __init__(self, registry: RecordStore, *, bridge: DeviceBridge | None = None,
                 settings: Settings | None = None, settings_path: Path | None = None) -> None:
        super().__init__()
        self.setWindowTitle("Rehabilitation robot console")
        self.registry = registry
        self.settings_path = settings_path
        self.settings = settings or load_settings(settings_path)
        self.bridge = bridge or DeviceBridge()
        self.state = State.IDLE
        self.built: TrialParameters | None = None
        self.patient: Patient | None = None
        self.registration: Registration | None = None
        self.trial_id: int | None = None
        self.trial_fault = ""  # the fault that ended the running trial, if one did
        self.trial_path: Path | None = None
        self.unsaved_trial: int | None = None
        self.live: TrialView | None = None
        self.shown_view: TrialView | None = None
        self.fault_code = 0
        self.closing_by_signal = False
        self.loop_health = LoopHealth()
        self.messages = Messages()
        self.history_dialog: QDialog | None = None
        self.jobs = Jobs()
        self.jobs.failed.connect(self._job_failed)

        self._build_tabs()
        self._build_layout()
        self._connect_signals()
        self._restore()
        self._refresh_buttons()

        self.repaint_timer = QTimer(self)
        self.repaint_timer.setInterval(REPAINT_MS)
        self.repaint_timer.timeout.connect(self._repaint)
        self.heartbeat_timer = QTimer(self)
        self.heartbeat_timer.setInterval(HEARTBEAT_MS)
        self.heartbeat_timer.timeout.connect(self.bridge.heartbeat)
        self.health_timer = QTimer(self)
        self.health_timer.setInterval(HEALTH_MS)
        self.health_timer.timeout.connect(self._show_health)

    # ------------------------------------------------------------------ construction
    def _build_tabs(self) -> None:
        self.tabs = QTabWidget()
        self.tabs.setDocumentMode(True)
        self.instructions = InstructionsTab()
        self.registration_tab = RegistrationTab(self.registry)
        self.parameters_tab = ParametersTab()
        self.force_estimate = ForceEstimateControl(self)
        self.refresh_learned_models()
        self.trajectory = TrajectoryTab()
        self.force = ForceTab()
        self.angles = AnglesTab()
        self.torques = TorquesTab()
        self.emg = EmgTab()
        self.video = VideoTab()
        self.report = ReportTab()
        self.progress = ProgressTab()
        self.progress.set_registry(self.registry)
        self.replay = ReplayTab()
        self.replay.set_registry(self.registry)
        made = (self.instructions, self.registration_tab, self.parameters_tab, self.trajectory,
                self.force, self.angles, self.torques, self.emg, self.video, self.report,
                self.progress, self.replay)
        by_class = {type(tab): tab for tab in made}
        for title, cls in TABS:  # in the thesis's order, with the titles it uses
            self.tabs.addTab(by_class[cls], title)
        self.view_tabs = [self.tabs.widget(i) for i in range(self.tabs.count())
                          if isinstance(self.tabs.widget(i), VIEW_TABS)]

    def _build_layout(self) -> None:
        self.banner = QFrame()
        self.banner.setObjectName("fault_banner")
        self.banner.setStyleSheet(
            f"#fault_banner {{ background: {theme.VERMILLION}; }}"
            " #fault_banner QLabel { color: white; font-weight: bold; }")
        self.banner_text = QLabel()
        lines = _fixed_lines(self.banner_text, MESSAGE_LINES)
        self.banner.setFixedHeight(max(lines, 40) + 16)
        # its place is kept while hidden: a fault never pushes the window taller (issue 13 #3)
        policy = self.banner.sizePolicy()
        policy.setRetainSizeWhenHidden(True)
        self.banner.setSizePolicy(policy)
        self.banner_text.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self.clear_button = QPushButton("Clear fault")
        self.clear_button.setObjectName("clear_fault")
        self.clear_button.setMinimumHeight(40)
        row = QHBoxLayout(self.banner)
        row.addWidget(self.banner_text, 1)
        row.addWidget(self.clear_button)
        self.banner.hide()

        # the event line always holds its place (empty when nothing is current): showing
        # or hiding it must not move the tabs or the robot buttons under the mouse
        self.message = QLabel()
        self.message.setObjectName("console_message")
        _fixed_lines(self.message, MESSAGE_LINES)
        self.message.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self.history_button = QPushButton("History…")
        self.history_button.setObjectName("message_history")
        self.history_button.setToolTip("Everything the console said today, with its time")
        self.history_button.clicked.connect(self.show_history)
        message_row = QHBoxLayout()
        message_row.setContentsMargins(0, 0, 0, 0)
        message_row.addWidget(self.message, 1)
        message_row.addWidget(self.history_button)

        self.robot = RobotBar()
        central = QWidget()
        column = QVBoxLayout(central)
        column.setContentsMargins(4, 4, 4, 4)
        column.addWidget(self.banner)
        column.addLayout(message_row)
        column.addWidget(self.tabs, 1)
        column.addWidget(self.robot)
        self.setCentralWidget(central)

        self.state_label = QLabel("Idle")
        self.backend_label = QLabel("")
        self.health_label = QLabel("loop: –")
        self.trial_label = QLabel("")
        bar = self.statusBar()
        for widget in (self.state_label, self.backend_label, self.trial_label):
            bar.addWidget(widget)
        bar.addPermanentWidget(self.health_label)

        # The emergency stop works from every tab and every dialog of the application.
        self.estop_keys = [QShortcut(QKeySequence(key), self) for key in ("Esc", "Space")]
        for shortcut in self.estop_keys:
            shortcut.setContext(Qt.ShortcutContext.ApplicationShortcut)
            shortcut.activated.connect(self.emergency_stop)

    def _connect_signals(self) -> None:
        b, r = self.bridge, self.robot
        b.state_changed.connect(self._on_state)
        b.fault_raised.connect(self._on_fault)
        b.trial_started.connect(self._on_trial_started)
        b.trial_ended.connect(self._on_trial_ended)
        b.file_notice.connect(self._on_file_notice)
        b.notice.connect(lambda level, text: self._say(text, level == "error"))
        b.replied.connect(self._on_reply)
        b.loop_lost.connect(self._on_loop_lost)
        r.build_clicked.connect(self.build)
        r.connect_clicked.connect(self.bridge.connect)
        r.disconnect_clicked.connect(self.bridge.disconnect)
        r.start_clicked.connect(self.start_trial)
        r.stop_clicked.connect(self.bridge.stop)
        r.save_clicked.connect(self.save_data)
        r.estop_clicked.connect(self.emergency_stop)
        self.clear_button.clicked.connect(self.clear_fault)
        self.registration_tab.registered.connect(self._on_registered)
        self.registration_tab.patient_selected.connect(self._on_patient)
        self.parameters_tab.parameters_changed.connect(lambda *_: self._refresh_buttons())
        self.parameters_tab.assistance_changed.connect(self._assistance_changed)
        self.parameters_tab.camera_changed.connect(self.video.open_camera)
        self.trajectory.flip_changed.connect(self._on_flip)
        self.replay.view_loaded.connect(self._on_replay)
        self.replay.cursor_moved.connect(self._on_cursor)
        self.tabs.currentChanged.connect(lambda _i: self._show_current())
        self.emg.said.connect(lambda text, problem: self._say(text, problem))
        self.emg.mvc_recorded.connect(self._store_session_mvcs)
        # a model saved while the console runs appears when the Parameters tab is shown
        self.tabs.currentChanged.connect(self._tab_shown)

    def start_device(self) -> None:
        """Start the loop processes and the timers (after the window is shown)."""
        try:
            self.bridge.start()
        except Exception as exc:  # shown to the therapist, then logged
            log.exception("the control loop did not start")
            self._say(f"The robot link could not start: {exc}. Restart the console; if it "
                      "happens again, see the log file.", problem=True)
            return
        self.heartbeat_timer.start()
        self.repaint_timer.start()
        self.health_timer.start()

    # ------------------------------------------------------------------ robot buttons
    def build(self) -> None:
        try:
            params = self.parameters_tab.parameters()
        except Exception as exc:  # ParameterError/UnreachableError: shown as is
            self._say(f"Build refused: {exc}", problem=True)
            self.tabs.setCurrentWidget(self.parameters_tab)
            return
        choice = self.parameters_tab.backend()
        model = None
        if params.learned_model:
            # the model file is read and checked here, at each Build: missing, corrupt
            # (hash), another system's or size's model, or on the robot a model not of
            # that robot's own trials, is refused with its reason
            from app.learning.library import inverse_dynamics, robot_model
            from app.learning.modelfile import ModelFileError

            try:
                checked = robot_model(self.registry.data_dir.models_dir, params.learned_model,
                                      "quanser" if choice.name == HARDWARE else "simulator")
            except ModelFileError as exc:
                self._say(f"Build refused: {exc}", problem=True)
                self.tabs.setCurrentWidget(self.parameters_tab)
                return
            params = params.replace(learned_model_sha256=checked.content_sha256)
            model = inverse_dynamics(checked)
        # an EMG model for the patient's force: read and checked, with the EMG tab's source
        # and MVCs, at each Build
        params = self.force_estimate.checked(params)
        if params is None:
            return
        if choice.name == HARDWARE:
            backend = BackendConfig(kind="quanser", hardware_settings=str(choice.settings_path))
        else:
            backend = BackendConfig(patient=choice.patient_kind or "healthy")
        self._pending_build = params
        if model is None:
            self.bridge.build(params, backend)
        else:
            self.bridge.build(params, backend, model=model)
        self._say("Building the trial…")

    def _tab_shown(self, _index: int) -> None:
        if self.tabs.currentWidget() is self.parameters_tab:
            self.refresh_learned_models()

    def refresh_learned_models(self) -> None:
        """Offer the model files in the data folder's models/ in the controller choice, and
        the approved EMG models in models/emg/ in the Patient's force choice."""
        from app.emg.modelfile import emg_model_names
        from app.learning.library import model_names

        models = self.registry.data_dir.models_dir
        self.parameters_tab.set_learned_models(model_names(models))
        self.parameters_tab.set_emg_models(emg_model_names(models))

    def say(self, text: str, problem: bool = False) -> None:
        """A new line in the message line (and its history)."""
        self._say(text, problem=problem)

    def refuse_build(self, reason: str) -> None:
        self._say(f"Build refused: {reason}", problem=True)
        self.tabs.setCurrentWidget(self.parameters_tab)

    def start_trial(self) -> None:
        if self.patient is None or self.registration is None:
            self._say("Register the patient first (Registration tab: choose the patient and "
                      "confirm the session and trial numbers).", problem=True)
            self.tabs.setCurrentWidget(self.registration_tab)
            return
        reg = self.registration
        try:
            begun = self.registry.begin_trial(
                self.patient.code, self.built, backend=self.backend_label.text() or "simulator",
                session_number=reg.session_number, trial_number=reg.trial_number)
        except Exception as exc:  # RegistryError etc., shown as is
            self._say(f"Start refused: {exc}", problem=True)
            self.registration_tab.show_refusal(exc)
            return
        self.trial_id = begun.trial_id
        self.trial_fault = ""
        self.trial_path = begun.path
        subject = SubjectInfo.from_parameters(self.patient.code, self.built)
        camera = self.video.camera
        if camera is not None and camera.running:
            camera.start_recording(begun.path.with_suffix(".mp4"))
        self.bridge.start_trial(str(begun.path), subject)

    def save_data(self) -> None:
        trial_id = self.unsaved_trial
        if trial_id is None:
            return
        self._say("Saving the report and the MATLAB file…")
        from app.exports.run import export_trial
        from app.reports.build import report_for_registry_trial

        flip = self.settings.flip_x or self.settings.flip_y

        def save() -> tuple[Path, Path]:
            # the thesis window's Save data wrote MATLAB data (A.3): the trial's .mat goes
            # beside its report, named as its trial file; saving again replaces both
            pdf = report_for_registry_trial(self.registry, trial_id, flip_axes=flip)
            source = self.registry.trial_path(self.registry.trial(trial_id))
            mat = export_trial(source, pdf.parent, format="mat", overwrite=True)[0]
            return pdf, mat

        self.jobs.run(save, self._saved)

    def _saved(self, paths: tuple[Path, Path]) -> None:
        pdf, mat = paths
        self.unsaved_trial = None
        self._refresh_buttons()
        self._say(f"Saved: the report {pdf.name} and the MATLAB file {mat.name}, in "
                  f"{pdf.parent}")

    def _assistance_changed(self, level: float) -> None:
        """A connected robot takes the new assistance level at once, mid-trial too (the
        trial file keeps an event of the change)."""
        if self.state in (State.CONNECTED, State.RUNNING):
            self.bridge.set_assistance(level)
            self._say(f"Assistance set to {level:.0%}; the robot uses it from now on.",
                      states=CONNECTED_STATES)

    def emergency_stop(self) -> None:
        self.bridge.estop(True)
        # the supervisor's own words for it, as the loop will report it (one wording)
        self._show_banner(Fault.ESTOP.banner())

    def clear_fault(self) -> None:
        self.bridge.estop(False)
        # the supervisor clears only once a tick has seen the e-stop released
        QTimer.singleShot(CLEAR_DELAY_MS, self.bridge.clear_fault)

    # ------------------------------------------------------------------ loop events
    def _on_reply(self, command: str, ok: bool, message: str) -> None:
        if not ok:
            self._say(message, problem=True)
            if command == "clear_fault" and self.fault_code == Fault.ESTOP:
                self.bridge.estop(True)  # keep it latched: clearing was refused
            return
        if command == "build":
            self.built = self._pending_build
            self.video.pose_side = self.built.side  # the live pose follows the arm in use
            self._say("Trial built. Connect to the robot, then Start.", states=(State.BUILT,))
        elif command == "clear_fault":
            self.fault_code = 0
            self.banner.hide()
            self.messages.clear_fault()
            self._say("Fault cleared.", states=(State.IDLE, State.BUILT, *CONNECTED_STATES))
        self._refresh_buttons()

    def _on_state(self, state: int, reason: str) -> None:
        if State(state) != self.state:
            # the clinic's events in the day's log: build, connect, start, stop, faults
            log.info("robot %s → %s%s", self.state.label, State(state).label,
                     f": {reason}" if reason else "")
        self.state = State(state)
        self.emg.trial_running = self.state in (State.RUNNING, State.STOPPING)
        self.messages.set_state(self.state)
        self._show_message()
        self.state_label.setText(f"<b>{self.state.label}</b>")
        if (self.state == State.CONNECTED and self.built is not None
                and reason.startswith("connected to the ")):
            # only Connect names the robot: other ways back to CONNECTED (a trial's file
            # complete, a fault cleared) give their own reason, not a robot's name
            self.backend_label.setText(reason.removeprefix("connected to the "))
        if self.state == State.CONNECTED and self.start_needs():
            self._say(f"Connected. Start needs {self.start_needs()}.",
                      states=(State.CONNECTED,))
        self._refresh_buttons()

    def _on_fault(self, code: int, message: str, detail: dict) -> None:
        log.warning("fault %s: %s %s", Fault(code).label, message,
                    {k: v for k, v in detail.items() if k != "monotonic_s"})
        self.fault_code = code
        if self.trial_id is not None:
            self.trial_fault = message  # kept with the trial in the registry (finalize)
        self._show_banner(message)
        if detail.get("cause") == "recorder process stopped" and self.trial_id is not None:
            # no recorder is left to close the file and say so: finish the trial from
            # what reached its file, as a crash's trial is finished at the next start
            from app.trials.finalize import finalize_lost

            trial_id, self.trial_id = self.trial_id, None
            self.jobs.run(lambda: finalize_lost(self.registry, trial_id, message),
                          lambda done: self._finalized(trial_id, done))

    def _on_trial_started(self, path: str, approach: int, total: int) -> None:
        log.info("trial started: %s (%d ticks)", Path(path).name, total)
        self.live = TrialView(self.built)
        self.shown_view = self.live
        self.video.close_replay()  # the live camera again, not a past trial's video
        if self.emg.capture is not None:
            # the EMG before this trial's margin was stored with the trials before it
            import time

            from app.emg.importing import LIVE_MARGIN_S

            self.emg.capture.forget_before(time.monotonic() - 2 * LIVE_MARGIN_S)
        self.trial_label.setText(f"recording {Path(path).name}")
        self._say(f"Trial running: {Path(path).name}. Stop (F6) ends it early.",
                  states=(State.RUNNING,))
        self.force_estimate.trial_started(self.built)
        if not isinstance(self.tabs.currentWidget(), VIEW_TABS):
            self.tabs.setCurrentWidget(self.trajectory)

    def _on_trial_ended(self, path: str, status: str, summary: dict) -> None:
        log.info("trial ended: %s, %s", Path(path).name, status)
        self.trial_label.setText(f"{Path(path).name}: {status.replace('_', ' ')}")
        camera = self.video.camera
        if camera is not None and camera.recording:
            camera.stop_recording()

    def _on_file_notice(self, kind: str, path: str, status: str, message: str) -> None:
        if kind == "error":
            self._say(f"Recording problem: {message}", problem=True)
        if kind == "closed" and self.trial_id is not None:
            from app.trials.finalize import finalize_trial

            trial_id, reason = self.trial_id, self.trial_fault
            self.trial_id = None
            self.jobs.run(lambda: finalize_trial(self.registry, trial_id, status, reason),
                          lambda done: self._finalized(trial_id, done))
            self._store_trial_emg(path)
        if kind == "closed":
            self.force_estimate.trial_closed(path)

    def _store_trial_emg(self, path: str) -> None:
        """The live EMG source's part of the trial into its file, after the metrics (one
        job thread: in that order). With the session's MVC protocol under way, the
        muscles' channels under their names and the session's MVCs, checked against this
        trial too (app.emg.protocol.store_trial); else every channel as it came. A source
        that died (or was disconnected) during the trial gives what it had before."""
        emg = self.emg
        if emg.capture is not None:
            captured, label, died = emg.capture.snapshot(), emg.live_label, False
        elif emg.lost is not None:
            (captured, label), died, emg.lost = emg.lost, True, None
        else:
            return
        session = emg.session
        ended = " up to where the source stopped" if died else ""
        if session is None or not session.records:
            # no MVC protocol under way: every channel as it came, named EMG1…
            from app.emg.importing import store_live_capture

            self.jobs.run(lambda: store_live_capture(path, captured, label),
                          lambda done: self._say(
                              f"EMG stored with the trial{ended}: {len(done.names)} channels, "
                              f"{done.n_samples} samples from {label}"))
            return
        from app.emg.protocol import store_trial

        def stored(result) -> None:
            done, checked = result
            self._say(f"EMG stored with the trial{ended}: {', '.join(done.muscles)}, "
                      f"{done.n_samples} samples from {label}, in % of the session's MVCs")
            for mvc in checked.values():
                if not mvc.ok:
                    emg.show_mvc(mvc)

        self.jobs.run(lambda: store_trial(path, captured, label, session), stored)

    def _store_session_mvcs(self, _muscle: str) -> None:
        """An MVC recorded again: the session's trials so far are normalised by it too, as
        `rehab emg mvc` stores one MVC in all the session's trials."""
        session = self.emg.session
        if session is None or not session.trials:
            return
        from app.emg.session import store_mvcs

        trials = list(session.trials)
        from app.emg.importing import when_free

        measured = session.measured()
        self.jobs.run(lambda: when_free(lambda: store_mvcs(trials, measured)),
                      lambda _checked: self._say(f"The session's MVCs are stored in its "
                                                 f"{len(trials)} trial(s) so far."))

    def _finalized(self, trial_id: int, done) -> None:
        self.unsaved_trial = trial_id
        self.parameters_tab.show_proposal(done.proposal)
        if self.registration is not None:
            self.registration_tab.refresh_numbers()
        self.report.load_registry_trial(self.registry, trial_id)
        if self.patient is not None:
            self.progress.set_patient(self.patient.code)
            self.replay.set_patient(self.patient.code)
        self.tabs.setCurrentWidget(self.report)
        self._refresh_buttons()

    def _on_loop_lost(self, message: str) -> None:
        self._show_banner(message)
        self.clear_button.setEnabled(False)

    # ------------------------------------------------------------------ other tabs
    def _on_patient(self, patient: Patient) -> None:
        self.patient = patient
        self.parameters_tab.show_proposal(None)  # a proposal belongs to its patient
        self.parameters_tab.apply_patient(patient)
        self.progress.set_patient(patient.code)
        self.replay.set_patient(patient.code)

    def _on_registered(self, patient: Patient, registration: Registration) -> None:
        self.patient = patient
        self.registration = registration
        self.emg.set_session(patient.code, registration.session_number)
        self._refresh_buttons()

    def _on_flip(self, flip_x: bool, flip_y: bool) -> None:
        self.settings = self.settings.replace(flip_x=flip_x, flip_y=flip_y)
        self.parameters_tab.set_flip(flip_x, flip_y)
        self.report.set_flip(flip_x, flip_y)

    def _on_replay(self, view: TrialView) -> None:
        self.shown_view = view
        for tab in self.view_tabs:
            tab.show_view(view)
        # the trial's video follows the slider too (the Video tab shows its last frame)
        self.video.show_replay(view.video)
        if view.video is not None and view.n:
            self.video.seek(view.cursor if view.cursor is not None else float(view.time[0]))

    def _on_cursor(self, t: float) -> None:
        for tab in self.view_tabs:
            tab.set_cursor(t)
        self.video.seek(t)

    # ------------------------------------------------------------------ live view
    def _repaint(self) -> None:
        records = self.bridge.take_records()
        if len(records):
            self.loop_health.add(records["lateness"])
            if self.live is not None and self.state == State.RUNNING:
                self.live.append(records[records["phase"] > 0])
        if self.shown_view is self.live and self.live is not None:
            self._show_current()
        self.force_estimate.poll()

    def _show_current(self) -> None:
        tab = self.tabs.currentWidget()
        if self.shown_view is not None and isinstance(tab, VIEW_TABS):
            tab.show_view(self.shown_view)

    def _show_health(self) -> None:
        text = self.loop_health.text(self.fault_code)
        if text is not None:
            self.health_label.setText(text)

    # ------------------------------------------------------------------ helpers
    def _refresh_buttons(self) -> None:
        tab = self.parameters_tab
        params_ok = tab.check() is not None and not tab.problem() and not tab.backend_problem()
        self.robot.update_for(
            self.state, can_build=params_ok,
            can_start=self.built is not None and self.registration is not None,
            can_save=self.unsaved_trial is not None, start_needs=self.start_needs())
        self.clear_button.setEnabled(self.state == State.FAULTED or self.fault_code != 0)

    def start_needs(self) -> str:
        """What Start waits for beyond the robot's state, in words ("" when nothing)."""
        if self.registration is None:
            return ("a registered patient: Registration tab, choose the patient and press "
                    "Confirm")
        if self.built is None:
            return "a built trial: press Build"
        return ""

    def _show_banner(self, text: str) -> None:
        self.banner_text.setText(f"{theme.PROBLEM_SIGN} {text}")
        self.banner_text.setToolTip(text)
        self.banner.show()
        self.clear_button.setEnabled(True)
        self.messages.set_fault(text)
        self._show_message()

    def _say(self, text: str, problem: bool = False, states=None) -> None:
        """A new event line; `states`: the robot states it stays current in (it leaves the
        line, not the history, when the robot leaves them; ui.views.messages)."""
        self.messages.say(text, problem=problem, states=states)
        self._show_message()
        (log.warning if problem else log.info)("%s", text)

    def _show_message(self) -> None:
        event = self.messages.last
        problem = event is not None and event.problem
        colour = theme.PROBLEM_TEXT if problem else theme.TEXT
        sign = f"{theme.PROBLEM_SIGN} " if problem else ""
        self.message.setStyleSheet(f"color: {colour}; font-weight: bold;" if problem else "")
        self.message.setText("" if event is None else f"{sign}{event.text}")
        self.message.setToolTip("" if event is None else event.text)

    def show_history(self) -> QDialog:
        """Everything said this session, oldest first, in a window of its own."""
        dialog = QDialog(self)
        dialog.setWindowTitle("What the console said")
        text = QPlainTextEdit("\n".join(self.messages.history()) or "Nothing yet.")
        text.setReadOnly(True)
        layout = QVBoxLayout(dialog)
        layout.addWidget(text)
        dialog.resize(700, 400)
        dialog.show()
        self.history_dialog = dialog
        return dialog

    def finish_interrupted_trials(self) -> None:
        """At start-up: trials a crashed console left recording are finished from their
        files (app.trials.finalize.finish_interrupted), and the therapist is told which."""
        def said(lines: list[str]) -> None:
            if lines:
                more = f" (and {len(lines) - 1} more; see the log)" if len(lines) > 1 else ""
                self._say(lines[0][0].upper() + lines[0][1:] + more, problem=True)

        self.jobs.run(lambda: finish_interrupted(self.registry), said)

    def _job_failed(self, error: Exception) -> None:
        log.error("background job failed: %s", error)
        self._say(f"{error}", problem=True)

    # ------------------------------------------------------------------ settings
    def _restore(self) -> None:
        s = self.settings
        if s.window_geometry:
            self.restoreGeometry(base64.b64decode(s.window_geometry))
        else:
            self.resize(1400, 900)
        params = s.trial_parameters()
        if params is not None:
            self.parameters_tab.set_parameters(params)
        self.parameters_tab.set_backend(BackendChoice(
            HARDWARE if s.robot == "hardware" else SIMULATOR, patient_kind=s.virtual_patient,
            settings_path=Path(s.hardware_settings) if s.hardware_settings else None))
        self.trajectory.set_flip(s.flip_x, s.flip_y)

    def closeEvent(self, event) -> None:
        if self.state == State.RUNNING and not self.closing_by_signal:
            answer = QMessageBox.question(
                self, "A trial is running",
                "A trial is running. Stop it, save it and close the console?")
            if answer != QMessageBox.StandardButton.Yes:
                event.ignore()
                return
        geometry = base64.b64encode(bytes(self.saveGeometry())).decode("ascii")
        choice = self.parameters_tab.backend()
        settings = self.settings.replace(
            window_geometry=geometry,
            robot="hardware" if choice.name == HARDWARE else "simulator",
            virtual_patient=choice.patient_kind or self.settings.virtual_patient,
            hardware_settings=(str(choice.settings_path) if choice.settings_path
                               else self.settings.hardware_settings))
        # invalid parameters are simply not remembered
        with contextlib.suppress(Exception):
            settings = settings.with_trial_parameters(self.parameters_tab.parameters())
        try:
            save_settings(settings, self.settings_path)
        except Exception as exc:  # closing must not fail on settings
            log.warning("settings not saved: %s", exc)
        for timer in (self.repaint_timer, self.heartbeat_timer, self.health_timer):
            timer.stop()
        self.video.close_camera()
        self.bridge.close()
        self.jobs.shutdown()
        super().closeEvent(event)


def _fixed_lines(label: QLabel, lines: int) -> int:
    """Make `label` a word-wrapped box of `lines` lines, as tall as they are in bold (a
    fault or a problem is shown bold), filled from the top: a longer text shows its first
    lines whole and the rest stays in its tooltip and the history, instead of half lines
    cut at top and bottom. Returns the height."""
    label.setWordWrap(True)
    label.setAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignTop)
    font = QFont(label.font())
    font.setBold(True)
    height = QFontMetrics(font).lineSpacing() * lines
    label.setFixedHeight(height)
    return height
