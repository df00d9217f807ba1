"""The console's window: the thesis's tabs (Appendix A), the robot buttons and the emergency
stop on every tab, a fault banner, and a status bar with the loop's state and health.

The window only arranges and forwards: the loop runs in its own process behind
`DeviceBridge`, files and the registry live in `app`, and anything that touches the disk
(finishing a trial, writing a report) runs on the job thread (`ui.jobs`) so the window
never waits. Its jobs are the modules of `ui.window`, each a part of the window: the robot
buttons and the trial's life (`trial`, `start`, `trial_emg`), the e-stop and the fault banner
(`fault_latch`), the event line and the status bar (`message_line`), what it remembers
(`settings`), the measurements the Parameters tab keeps in the patient's record
(`kept_measurements`). What is left here is the window itself: its tabs, their layout and wiring,
the other tabs' events and the live view.
"""

from __future__ import annotations

import logging
from pathlib import Path

from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import (
    QAbstractSpinBox,
    QApplication,
    QFrame,
    QHBoxLayout,
    QLabel,
    QMainWindow,
    QPushButton,
    QSizePolicy,
    QTabWidget,
    QVBoxLayout,
    QWidget,
)

from app.records.registry import Patient, Registration
from app.records.settings import Settings, load_settings
from app.records.store import RecordStore
from core.trial import TrialParameters
from device.loop.states import State
from ui import theme
from ui.device_bridge import DeviceBridge
from ui.fields import REFUSING
from ui.force_estimate import ForceEstimateControl
from ui.jobs import Jobs
from ui.patient.control import PatientScreenControl
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
from ui.tabs.replay import PATH_ROLE
from ui.views.latch import Latch
from ui.views.loop_health import LoopHealth
from ui.views.messages import Messages
from ui.views.replay_strip import replay_line
from ui.views.trialview import TrialView
from ui.window.after_trial import AfterTrial, Pending, pending_offer
from ui.window.assessments import AssessmentControl
from ui.window.fault_latch import FaultLatch
from ui.window.kept_measurements import KeptMeasurements
from ui.window.message_line import MessageLine
from ui.window.plan import PlanControl
from ui.window.settings import RememberedSettings
from ui.window.start import TrialStart
from ui.window.station import StationStatus
from ui.window.trial import BuiltSetup, TrialActions
from ui.window.trial_emg import TrialEmg

log = logging.getLogger(__name__)

REPAINT_MS = 16  # ~60 Hz; the tabs draw only what is visible
HEARTBEAT_MS = 100  # the loop faults after 0.5 s without one
HEALTH_MS = 500


class MainWindow(AssessmentControl, PlanControl, TrialStart, AfterTrial, TrialActions, TrialEmg,
                 FaultLatch, MessageLine, RememberedSettings, StationStatus, PatientScreenControl,
                 KeptMeasurements, QMainWindow):
    """The therapist's console."""

    def __init__(self, registry: RecordStore, *, bridge: DeviceBridge | None = None,
                 settings: Settings | None = None, settings_path: Path | None = None) -> None:
        super().__init__()
        # a station on a department's shared registry says which, and where it records
        where = registry.location()
        self.setWindowTitle("Rehabilitation robot console" + (f" — {where}" if where else ""))
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
        self._finishing: set[int] = set()  # trials being finished into the registry
        self.live: TrialView | None = None
        self.shown_view: TrialView | None = None
        self.live_report: int | None = None  # the registered trial of the live view's report
        self.latch = Latch()  # the e-stop and the loop's fault: the banner is this
        self._clear_asked = 0  # Clear faults sent, not yet answered
        self.built_setup: BuiltSetup | None = None  # what the form showed at Build
        self.built_backend = None  # the BackendConfig built
        self._builds_asked: list[tuple] = []  # (parameters, setup, backend) of each Build
        # sent, not yet answered, in the order the loop answers them
        self._live_levels: list[float] = []  # live assistance changes awaiting the loop
        self._connecting = False  # a Connect sent, its answer not yet back
        self.handle_outside = ""  # between trials: the loop's line, the handle outside the area
        self.closing_by_signal = False
        self.closing_signal = ""
        """The stop signal the console was given (SIGINT, SIGTERM, SIGHUP), if any."""
        self.loop_health = LoopHealth()
        self.messages = Messages()
        self.history_dialog = None  # the History… dialog, once opened
        self.jobs = Jobs()
        self.jobs.failed.connect(self._job_failed)

        self._build_tabs()
        self._build_layout()
        self._connect_signals()
        self._connect_plan()  # after the window's own: its Build is taken before the plan's
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
    def keyPressEvent(self, event) -> None:
        """Enter presses the button that has the focus. Elsewhere Space does, but here Space
        is the emergency stop (FaultLatch), so without this a therapist who tabs to a button
        (Register new patient, Use this patient…) could not press it from the keyboard: a
        button outside a dialog ignores Enter and the key comes here."""
        if event.key() in (Qt.Key.Key_Return, Qt.Key.Key_Enter):
            focus = QApplication.focusWidget()
            if isinstance(focus, QPushButton) and focus.isEnabled() \
                    and focus.isVisibleTo(self) and self.isAncestorOf(focus):
                focus.click()
                event.accept()
                return
        super().keyPressEvent(event)

    def _build_tabs(self) -> None:
        self.tabs = QTabWidget()
        self.tabs.setDocumentMode(True)
        # every tab always in view: the window is never narrower than its tabs (at font
        # scale 1.5 four tabs hid behind scroll arrows, issue 27 #13)
        self.tabs.tabBar().setUsesScrollButtons(False)
        self.tabs.tabBar().setElideMode(Qt.TextElideMode.ElideNone)
        self.instructions = InstructionsTab()
        self.registration_tab = RegistrationTab(self.registry, jobs=self.jobs)
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
        self.replay = ReplayTab(self.registry, jobs=self.jobs)
        self.parameters_tab.robot_choice.settings_folder = str(self.registry.data_dir.root)
        made = (self.instructions, self.registration_tab, self.parameters_tab, self.trajectory,
                self.force, self.angles, self.torques, self.emg, self.video, self.report,
                self.progress, self.replay)
        by_class = {type(tab): tab for tab in made}
        for title, cls in TABS:  # in the thesis's order, with the titles it uses
            self.tabs.addTab(by_class[cls], title)
        # the session plan beside the Parameters tab (ui.window.plan)
        self.tabs.insertTab(self.tabs.indexOf(self.parameters_tab) + 1,
                            self._build_plan_tab(), "Plan")
        # the assessment battery beside the plan (ui.window.assessments)
        self.tabs.insertTab(self.tabs.indexOf(self.parameters_tab) + 2,
                            self._build_assessments_tab(), "Assessments")
        self.view_tabs = [self.tabs.widget(i) for i in range(self.tabs.count())
                          if isinstance(self.tabs.widget(i), VIEW_TABS)]

    def _build_layout(self) -> None:
        message_row = self._build_message_row(self._build_banner())
        message_row.addWidget(self._build_patient_button())
        self.robot = RobotBar()
        central = QWidget()
        column = QVBoxLayout(central)
        column.setContentsMargins(4, 4, 4, 4)
        column.addLayout(message_row)
        column.addWidget(self._build_replay_strip())
        column.addWidget(self.tabs, 1)
        column.addWidget(self.robot)
        self.setCentralWidget(central)
        self._build_status_bar()
        self._build_station_status()
        self._bind_estop_keys()

    def _build_replay_strip(self) -> QFrame:
        """Over the tabs while they show a past trial: which trial and which moment, on a
        colour no live trial has, and the way back to the live trial."""
        self.replay_strip = QFrame()
        self.replay_strip.setObjectName("replay_strip")
        self.replay_strip.setStyleSheet(
            f"#replay_strip {{ background: {theme.BLUE}; border-radius: 4px; }}"
            " #replay_strip QLabel { color: white; font-weight: bold; }")
        self.replay_text = QLabel()
        self.replay_text.setSizePolicy(QSizePolicy.Policy.Ignored,
                                       QSizePolicy.Policy.Preferred)
        self.back_to_live = QPushButton("Back to the live trial")
        self.back_to_live.clicked.connect(self.show_live)
        row = QHBoxLayout(self.replay_strip)
        row.setContentsMargins(8, 2, 4, 2)
        row.addWidget(self.replay_text, 1)
        row.addWidget(self.back_to_live)
        self.replay_strip.hide()
        return self.replay_strip

    def _show_replay_strip(self) -> None:
        view = self.shown_view
        replaying = view is not None and view is not self.live
        on_a_view = isinstance(self.tabs.currentWidget(), (*VIEW_TABS, ReportTab, ReplayTab))
        self.replay_strip.setVisible(replaying and on_a_view)
        if replaying:
            text = replay_line(view)
            self.replay_text.setText(text)
            self.replay_text.setToolTip(text)
            self.back_to_live.setVisible(self.live is not None)

    def show_live(self) -> None:
        """The tabs show the live (or last live) trial again instead of a replay."""
        if self.live is None:
            return
        self.shown_view = self.live
        self._show_current()

    def _connect_signals(self) -> None:
        b, r = self.bridge, self.robot
        # a number a field refuses (out of range, not a number) is said where the window
        # says what happened (ui.fields): Qt used to drop the keystroke without a word
        for field in self.findChildren(QAbstractSpinBox):
            if isinstance(field, REFUSING):
                field.refused.connect(lambda line: self._say(line, problem=True))
        b.state_changed.connect(self._on_state)
        b.fault_raised.connect(self._on_fault)
        b.trial_started.connect(self._on_trial_started)
        b.trial_ended.connect(self._on_trial_ended)
        b.file_notice.connect(self._on_file_notice)
        b.notice.connect(lambda level, text: self._say(text, level == "error"))
        b.replied.connect(self._on_reply)
        b.loop_lost.connect(self._on_loop_lost)
        r.build_clicked.connect(self.build)
        r.connect_clicked.connect(self.connect_robot)
        b.sensor_zeroed.connect(self._on_sensor_zeroed)
        b.handle_area.connect(self._on_handle_area)
        r.disconnect_clicked.connect(self.bridge.disconnect)
        r.start_clicked.connect(self.start_trial)
        r.stop_clicked.connect(self.bridge.stop)
        r.save_clicked.connect(self.save_data)
        r.estop_clicked.connect(self.emergency_stop)
        self.clear_button.clicked.connect(self.clear_fault)
        self.registration_tab.registered.connect(self._on_registered)
        self.registration_tab.unconfirmed.connect(self._on_unconfirmed)
        self.registration_tab.patient_selected.connect(self._on_patient)
        self._connect_kept_measurements()
        self.parameters_tab.parameters_changed.connect(lambda *_: self._refresh_buttons())
        # at once, not after the check's debounce: Start must never run a stale trial
        self.parameters_tab.edited.connect(self._refresh_buttons)
        self.parameters_tab.assistance_changed.connect(self._assistance_changed)
        self.parameters_tab.camera_changed.connect(self.video.open_camera)
        self.trajectory.flip_changed.connect(self._on_flip)
        self.replay.view_loaded.connect(self._on_replay)
        self.replay.cursor_moved.connect(self._on_cursor)
        self.tabs.currentChanged.connect(lambda _i: self._show_current())
        self.emg.said.connect(lambda text, problem: self._say(text, problem))
        self.registration_tab.said.connect(lambda text, problem: self._say(text, problem))
        self.emg.mvc_recorded.connect(self._store_session_mvcs)
        self.emg.range_problem.connect(self._note_emg_range)
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

    def _tab_shown(self, _index: int) -> None:
        if self.tabs.currentWidget() is self.parameters_tab:
            self.refresh_learned_models()
        if self.tabs.currentWidget() is self.assessments_tab:
            self.show_assessment()

    def refresh_learned_models(self) -> None:
        """Offer the model files in the data folder's models/ in the controller choice, and
        the approved EMG models in models/emg/ in the Patient's force choice."""
        from app.emg.modelfile import emg_model_names
        from app.learning.library import model_names

        models = self.registry.data_dir.models_dir
        self.parameters_tab.set_learned_models(model_names(models))
        self.parameters_tab.set_emg_models(emg_model_names(models))

    # ------------------------------------------------------------------ other tabs
    def _on_patient(self, patient: Patient) -> None:
        """The patient chosen (their record read and shown by the Registration tab): the
        tabs follow; their pending proposal and trials are read on the job thread (Start
        waits for them, as for the reads after a trial: ui.window.after_trial)."""
        self.patient = patient
        code = patient.code
        self._patient_folders(code)
        self.parameters_tab.apply_patient(patient)
        self.parameters_tab.show_proposal(None)  # a proposal belongs to its patient
        self.progress.set_patient(code)
        self.show_assessment()
        self.read_proposal_and_trials(code)

    def read_proposal_and_trials(self, code: str) -> None:
        """Patient `code`'s pending proposal and the Replay tab's list read on the job
        thread (Start waits for them: ui.window.after_trial), shown once read if they are
        still the patient chosen; the Replay list says "Loading…" meanwhile. A read that
        fails is said with its cause."""
        registry = self.registry
        self.replay.show_loading(code)

        def read() -> tuple[Pending, list] | Exception:
            try:
                return pending_offer(registry, code), registry.trials_for_patient(code)
            except Exception as exc:  # the registry gone: said, the tabs as they were
                return exc

        def show(read: tuple[Pending, list] | Exception) -> None:
            if self.jobs.closed or self.patient is None or self.patient.code != code:
                return
            if isinstance(read, Exception):
                log.error("the proposal and trials of %s could not be read", code,
                          exc_info=read)
                self.replay.set_patient(code, [])
                self._say(f"{code}'s proposal and trials could not be read: {read}. Choose "
                          "the patient again to read them again.", problem=True)
                return
            self._offer_pending_proposal(code, read[0])
            self.replay.set_patient(code, read[1])

        self._read_after(read, show)

    def _patient_folders(self, code: str) -> None:
        """Every file dialog starts in the patient's folder of the data folder (private,
        0700), never in the program's folder (issue 27 #11)."""
        data = self.registry.data_dir
        try:
            trials = data.ensure(data.trials_dir.name, code)
            reports = data.ensure(data.reports_dir.name, code)
        except Exception as exc:  # DataDirError: said, and the dialogs start as before
            self._say(f"The patient's folders could not be made: {exc}", problem=True)
            return
        self.replay.files_folder = self.angles.files_folder = str(trials)
        self.report.pdf_folder = str(reports)

    def _offer_pending_proposal(self, code: str, offer: Pending) -> None:
        """The patient's last proposal the registry still holds as pending (made after a
        trial, not yet decided by the next one's start): offered again after a restart.
        `offer`: as read on the job thread (ui.window.after_trial)."""
        from app.trials.progression import Proposal

        self.parameters_tab.show_proposal(
            None if offer.proposal is None else Proposal.from_dict(offer.proposal),
            after=offer.after)

    def _on_registered(self, patient: Patient, registration: Registration) -> None:
        self.patient = patient
        self.registration = registration
        self.emg.set_session(patient.code, registration.session_number)
        self._refresh_buttons()

    def _on_unconfirmed(self) -> None:
        """Another patient chosen or a number edited on the Registration tab: the patient
        and numbers confirmed before no longer are what the tab shows, so Start waits for
        Confirm (it registered the next trial under the patient chosen since with the
        numbers confirmed for the one before, or under a session the tab no longer
        showed)."""
        self.registration = None
        self._refresh_buttons()

    def _on_flip(self, flip_x: bool, flip_y: bool) -> None:
        self.settings = self.settings.replace(flip_x=flip_x, flip_y=flip_y)
        self.parameters_tab.set_flip(flip_x, flip_y)

    def _on_replay(self, view: TrialView) -> None:
        self.shown_view = view
        for tab in self.view_tabs:
            tab.show_view(view)
        self._show_replay_strip()
        if self.tabs.currentWidget() is self.report:
            self._show_report()
        # the trial's video follows the slider too (the Video tab shows its last frame)
        self.video.show_replay(view.video)
        if view.video is not None and view.n:
            self.video.seek(view.cursor if view.cursor is not None else float(view.time[0]))

    def _on_cursor(self, t: float) -> None:
        for tab in self.view_tabs:
            tab.set_cursor(t)
        self.video.seek(t)
        self._show_replay_strip()

    # ------------------------------------------------------------------ live view
    def _repaint(self) -> None:
        records = self.bridge.take_records()
        if len(records):
            self.loop_health.add(records["lateness"])
            if self.live is not None and self.state == State.RUNNING:
                self.live.append(records[records["phase"] > 0])
        if self.shown_view is self.live and self.live is not None:
            self._show_current()
        self._feed_patient_screen()
        self.force_estimate.poll()

    def _show_current(self) -> None:
        tab = self.tabs.currentWidget()
        if self.shown_view is not None and isinstance(tab, VIEW_TABS):
            tab.show_view(self.shown_view)
        elif tab is self.report:
            self._show_report()
        self._show_replay_strip()

    def _show_report(self) -> None:
        """The Report tab shows the report of the trial on view: a replayed trial's (the
        registry's report, with its comparisons, when it is one of the Replay list's
        trials), else the live trial's. It kept the last live trial's report under a
        replay, so the window showed one trial replayed and another's report."""
        view = self.shown_view
        if view is not None and view is not self.live:
            trial_id = replayed_trial(self.replay, view)
            if trial_id is None:
                self.report.show_view(view)
            elif self.report.registry_trial() != trial_id:
                self.report.load_registry_trial(self.registry, trial_id)
        elif self.live_report is None:
            self.report.show_waiting()
        elif self.report.registry_trial() != self.live_report:
            self.report.load_registry_trial(self.registry, self.live_report)


def replayed_trial(replay: ReplayTab, view: TrialView) -> int | None:
    """The registry's id of the trial `view` replays when it is one of the Replay tab's
    list (its row holds the file's path), else None (a file opened with Open file…)."""
    if view.source is None:
        return None
    for row in range(replay.trials.count()):
        item = replay.trials.item(row)
        here = item.data(PATH_ROLE)
        if here is not None and Path(here) == Path(view.source):
            return item.data(Qt.ItemDataRole.UserRole)
    return None
