"""The therapist's control of the patient's screen, a part of the console's window (a
mixin of ui.main_window.MainWindow, like the modules of ui.window): the *Patient's
screen* button and its menu (which screen, full screen, the options), F11, feeding the
screen from the window's 16 ms repaint, and closing it with the console.

The patient's window shows the live trial while one runs and after it ends, until the
next Build (a plan's next round: as soon as the plan asks for its Build); otherwise the
built exercise (or nothing) waiting to start. While a session plan runs (the window's
`plan_runner`, app.plans.runner.PlanRunner), its state too: the block, the session's
progress, the rest's countdown; once it has ended, its end in the patient's words until
the next trial is built. Replays on the
therapist's tabs never reach it: the patient sees only what they are doing.
"""

from __future__ import annotations

import time

from PySide6.QtCore import Qt
from PySide6.QtGui import QActionGroup, QGuiApplication, QKeySequence, QShortcut
from PySide6.QtWidgets import QMenu, QToolButton

from app.plans.runner import BUILDING
from device.loop.messages import ShownToPatient
from device.loop.pipeline import PERIOD_S
from device.loop.states import State
from ui.patient.sound import find_player
from ui.patient.window import PatientWindow
from ui.views.patient_plan import laps_passed
from ui.views.patient_screen import PatientOptions

FULL_SCREEN_KEY = "F11"


class PatientScreenControl:
    """Needs from the window: live, built, state, latch, _say."""

    patient_window: PatientWindow | None = None
    patient_options: PatientOptions = PatientOptions()
    _patient_size_warned = False
    _patient_exercise_start_s: float | None = None  # the running trial's, from the loop
    _patient_trial_end: str = ""
    """The live trial's status once the loop ended it ("complete", "stopped_early", …),
    '' while it runs."""
    _plan_bar: tuple = (None, 0.0)
    """(the plan's run the patient's bar was shown for: its runner, or the ended run's
    plan_ended; the bar shown), so that the bar never goes back within a run."""

    def _build_patient_button(self) -> QToolButton:
        self.patient_button = QToolButton()
        self.patient_button.setObjectName("patient_screen_button")
        self.patient_button.setText("Patient's screen")
        self.patient_button.setToolTip(
            "A window for the patient: the exercise, the hand, when to go, the repetitions and "
            f"the time left. Open it on a second monitor; {FULL_SCREEN_KEY} puts it full screen")
        self.patient_button.setPopupMode(QToolButton.ToolButtonPopupMode.InstantPopup)
        self.patient_menu = QMenu(self.patient_button)
        self.patient_menu.setToolTipsVisible(True)
        self.patient_menu.aboutToShow.connect(self._fill_patient_menu)
        self.patient_button.setMenu(self.patient_menu)
        self.patient_full_screen_key = QShortcut(QKeySequence(FULL_SCREEN_KEY), self)
        self.patient_full_screen_key.setContext(Qt.ShortcutContext.ApplicationShortcut)
        self.patient_full_screen_key.activated.connect(self.toggle_patient_full_screen)
        # the exercise starts at the tick the approach ends (device.loop.pipeline); the live
        # view may miss the first records, the screen's clock must not
        self.bridge.trial_started.connect(self._patient_trial_started)
        self.bridge.trial_ended.connect(self._patient_trial_ended)
        return self.patient_button

    def _fill_patient_menu(self) -> None:
        menu = self.patient_menu
        menu.clear()
        for index, screen in enumerate(QGuiApplication.screens()):
            size = screen.size()
            action = menu.addAction(f"Show on screen {index + 1}: {screen.name()} "
                                    f"({size.width()} × {size.height()})")
            action.triggered.connect(lambda _=False, i=index: self.open_patient_screen(i))
        full = menu.addAction(f"Full screen\t{FULL_SCREEN_KEY}")
        full.setCheckable(True)
        full.setChecked(self.patient_window is not None and self.patient_window.isFullScreen())
        full.triggered.connect(lambda _=False: self.toggle_patient_full_screen())
        close = menu.addAction("Close the patient's screen")
        close.setEnabled(self.patient_window is not None)
        close.triggered.connect(self.close_patient_screen)
        menu.addSeparator()
        o = self.patient_options
        for name, words in (("mirror", "Mirror left–right"),
                            ("previous_path", "Show the last repetition's path"),
                            ("show_numbers", "Show figures to the patient"),
                            ("sound", "Tone at Go and on a hit")):
            action = menu.addAction(words)
            action.setCheckable(True)
            action.setChecked(getattr(o, name))
            action.toggled.connect(lambda on, n=name: self.set_patient_options(**{n: on}))
            if name == "sound":
                _, why_not = find_player()
                action.setEnabled(not why_not or o.sound)
                action.setToolTip(why_not or "A short tone with Go!, a higher one on a hit")
        turn = menu.addMenu("Turn the picture")
        group = QActionGroup(turn)
        for degrees in (0, 90, 180, 270):
            action = turn.addAction("As the patient sees the table" if degrees == 0
                                    else f"{degrees}° anticlockwise")
            action.setCheckable(True)
            action.setChecked(o.rotation_deg == degrees)
            group.addAction(action)
            action.triggered.connect(
                lambda _=False, d=degrees: self.set_patient_options(rotation_deg=d))

    # -- opening and closing --------------------------------------------------------
    def open_patient_screen(self, screen_index: int | None = None) -> PatientWindow:
        """Show the patient's window (made once) on the screen of that index (the
        therapist's own when None), without taking the keyboard from this window."""
        if self.patient_window is None:
            self.patient_window = PatientWindow(self.patient_options)
            self.patient_window.closed.connect(self._patient_screen_closed)
            self.patient_window.size_said.connect(self._patient_screen_size)
        window = self.patient_window
        screens = QGuiApplication.screens()
        if screen_index is not None and 0 <= screen_index < len(screens):
            screen = screens[screen_index]
        else:
            screen = self.screen() or QGuiApplication.primaryScreen()
        full = window.isFullScreen()
        if full:
            window.showNormal()
        window.setScreen(screen)
        area = screen.availableGeometry()
        window.setGeometry(area.adjusted(area.width() // 8, area.height() // 8,
                                         -area.width() // 8, -area.height() // 8))
        shown = window.isVisible()
        if full:
            window.showFullScreen()
        else:
            window.show()
        self._feed_patient_screen()
        if not shown:
            self._tell_patient_screen()
        return window

    def _patient_trial_started(self, _path: str, approach: int, _total: int) -> None:
        self._patient_exercise_start_s = approach * PERIOD_S
        self._patient_trial_end = ""

    def _patient_trial_ended(self, _path: str, status: str, _summary: dict) -> None:
        self._patient_trial_end = status

    def _patient_screen_size(self, words: str, too_small: bool) -> None:
        """Said once each way: the first time the letters are too small, and when they are
        readable again (not the first time they are readable)."""
        if too_small or self._patient_size_warned:
            self._patient_size_warned = too_small
            self._say(words, problem=too_small)

    def toggle_patient_full_screen(self) -> None:
        window = self.patient_window or self.open_patient_screen()
        if window.isFullScreen():
            window.showNormal()
        else:
            window.showFullScreen()

    def close_patient_screen(self) -> None:
        if self.patient_window is not None:
            self.patient_window.close()

    def _patient_screen_closed(self) -> None:
        window, self.patient_window = self.patient_window, None
        if window is not None:
            window.deleteLater()
            self._tell_patient_screen()

    def restore_patient_options(self, saved: dict | None) -> None:
        """The options the settings kept (Settings.patient_screen); options that no longer
        read are said in one line and the defaults used."""
        if saved is None:
            return
        try:
            self.patient_options = PatientOptions.from_dict(saved)
        except ValueError as exc:
            self.patient_options = PatientOptions()
            self._say(f"The patient's screen's saved options were not used ({exc}); it "
                      "starts as the patient sees the table. Set them again in its menu.",
                      problem=True)

    def set_patient_options(self, **changes) -> None:
        before = self.patient_options
        self.patient_options = before.replace(**changes)
        if self.patient_window is not None:
            self.patient_window.set_options(self.patient_options)
        if self.patient_options != before:
            self._tell_patient_screen()

    # -- the record ------------------------------------------------------------------
    def shown_to_patient(self) -> ShownToPatient:
        """What the patient's screen shows now, for the trial file (device.loop.messages.
        ShownToPatient): whether it is open, and its options either way."""
        window = self.patient_window
        is_open = window is not None and window.isVisible()
        options = self.patient_options
        words = (f"patient's screen open: {options.words()}" if is_open
                 else "patient's screen closed")
        return ShownToPatient(words, {"open": is_open, **options.to_dict()})

    def _tell_patient_screen(self) -> None:
        """A change while a trial runs goes into its file at the tick the loop takes it;
        the trial's start carries the screen as it is when the window asks the loop to
        start it, after the registry's answer (ui.window.start: a change made while Start
        registers is in it). From then on (a trial begun in the registry) a change is sent
        after the Start: the loop drops what comes while no trial runs."""
        if self.state == State.RUNNING or getattr(self, "trial_id", None) is not None:
            self.bridge.show_to_patient(self.shown_to_patient())

    # -- content ---------------------------------------------------------------------
    def _feed_patient_screen(self) -> None:
        """From the window's repaint: the live trial, or the exercise built (the live
        view is the last built trial's until the next Build makes new parameters)."""
        window = self.patient_window
        if window is None or not window.isVisible():
            return
        live = self.live
        building = self._plan_building()
        stopped = self.latch.latched  # the e-stop or a fault: said as the banner is
        if self.state != State.RUNNING and building is not None:
            # a plan's next round (or block) is being built: its exercise waiting, not the
            # last trial's end ("Lap 2 of 2", "0:00 left") until the loop answers
            window.show_parameters(building, stopped)
        elif live is not None and (self.state == State.RUNNING or live.parameters is self.built):
            # a trial Stop (or a plan's Pause) ended early: "Stopped", not its last lap's
            # result and time left, frozen until the next Build
            ended_early = self._patient_trial_end not in ("", "complete")
            window.show_view(live, self._patient_exercise_start_s, stopped or ended_early)
        else:
            window.show_parameters(self.built, stopped)
        self._feed_patient_plan(window)

    def _plan_building(self):
        """The parameters a running plan is building its next trial with (the window's
        Build in flight), or None."""
        runner = getattr(self, "plan_runner", None)
        if runner is None or runner.phase != BUILDING:
            return None
        return getattr(self, "_pending_build", None)

    def _feed_patient_plan(self, window: PatientWindow) -> None:
        """The plan's state while it runs, with the running trial's laps passed on the
        screen's clock (the bar moves within a block); once it has ended, its end ("Session
        complete") until the next trial is built. The bar never goes back within a run,
        nor as it ends."""
        runner = getattr(self, "plan_runner", None)  # the plan's runner while a plan runs
        ended = getattr(self, "plan_ended", None)
        run, floor = self._plan_bar
        if runner is not None:
            key, state = runner, runner.state(now=time.monotonic())
        elif ended is not None and self.built is ended[1]:
            key, state = ended, ended[0]
            if run is not None and not isinstance(run, tuple):
                run = ended  # the run that has just ended: its bar goes on
        else:
            key, state = None, None
        scene = window.scene
        laps = laps_passed(window.frame, scene.parameters.duration_s) if scene else 0.0
        window.show_plan(state, laps, floor if run is key else 0.0)
        plan = window.plan
        self._plan_bar = (key, plan.progress if plan is not None else 0.0)
