"""The Parameters tab (thesis Figs. A.6–A.7): the exercise, the patient's arm, the
controller and the robot backend, with a live picture of what can be reached.

Fields show the units a therapist reads best (cm for positions and lengths, s,
kg, °, %) and convert to SI at once; each spin box's limits are the range
`core.trial.TrialParameters` accepts, so out-of-range values cannot be typed.
What the limits cannot catch (a path the arm or the robot cannot reach, a path
too fast) comes from `core.trial_check.check_trial` and is written under the field to
change, in its own words with the distances.

Numbers count when the therapist commits them (Enter, leaving the field, the
arrows), never per keystroke: typing 60 into the assistance level during a trial set
6 % and then 60 % (issue 27 #4). The window commits a field still being typed in
before Build and Start (`commit_edits`), so what is on the screen is what is built.

The picture is `ui.reach_preview.ReachPreview`, and what the check says (the
picture's geometry, the summary, which field a problem goes under) is
`ui.views.reach`, computed without Qt. The camera and the robot choices are
`ui.tabs.parameters_devices`, the proposal above the form `ui.tabs.proposal_box`,
the level's words in each mode `ui.views.assist_words`. The form itself (the
exercise, the patient and the control, each field built, converted to SI and back, and
given a place for its problem) is `ui.tabs.parameters_form`. What is left here is the
tab: its layout and signals, the check of what the form holds and where its problems
are shown.
"""

from __future__ import annotations

from PySide6.QtCore import QTimer, Signal
from PySide6.QtWidgets import (
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from app.games.names import GAME_TITLES
from app.units import SCREEN
from core.errors import CoreError, ParameterError, UnreachableError
from core.robot import RobotModel
from core.trial import TrialParameters
from core.trial_check import TrialCheck, check_trial
from ui import plots, theme
from ui.reach_preview import ReachPreview
from ui.tabs.form_rows import FormRows
from ui.tabs.parameters_devices import HARDWARE, SIMULATOR, BackendChoice
from ui.tabs.parameters_form import ParametersForm
from ui.tabs.patient_words import MEASUREMENT_WORDS, PATIENT_MEASUREMENTS
from ui.tabs.proposal_box import ProposalBox
from ui.views.reach import check_summary, field_key, problem_fields, reach_picture

DEBOUNCE_MS = 120
KEEP = "Keep these values in the patient's record"
SAVING = "Saving…"
GAME_WORDS = {game: f"the {title.lower()}" for game, title in GAME_TITLES.items()}
"""A game the form holds (a session plan's round: ui.tabs.parameters_form.HIDDEN_FIELDS),
said in the status line, since no field shows it."""
__all__ = ["HARDWARE", "SIMULATOR", "BackendChoice", "ParametersTab"]


class ParametersTab(ParametersForm, QWidget):
    """Signals:
    parameters_changed(TrialParameters | None, problem): after every edit (debounced);
        None with the reason when the values are refused or cannot be reached.
    edited(): at once after every committed change of anything Build takes (a field,
        the robot, the patient's force): the window's built trial may now be stale.
    assistance_changed(level): the level (0–1) the therapist committed, at once.
    camera_changed(camera source or None): int index or file path; None without camera.
    backend_changed(BackendChoice).
    keep_asked(code, {field: (SI value, reason)}, who): the measurements the chosen
        patient's record lacks, as the form holds them, to be kept in it (the registry's
        audited correction, Registry.correct_patient); answered with `keep_answered`.
    """

    parameters_changed = Signal(object, str)
    edited = Signal()
    assistance_changed = Signal(float)
    """The assistance level (0–1) the therapist committed (Enter, leaving the field, the
    arrows), at once (not debounced): a running trial takes it live."""
    camera_changed = Signal(object)
    backend_changed = Signal(object)
    keep_asked = Signal(str, object, str)

    def __init__(self, robot: RobotModel | None = None, parent=None) -> None:
        super().__init__(parent)
        self.robot = robot or RobotModel()
        self._check: TrialCheck | None = None
        self._parameters: TrialParameters | None = None
        self._error: CoreError | None = None
        self._problem = ""
        self._loading = False
        # One truth in the patient's record: the rows the patient chosen has not stored
        # refuse Build until their values are kept in the record (keep_asked); `_given`,
        # the ones of them typed for this patient (the others hold values not theirs)
        self._missing: set[str] = set()
        self._given: set[str] = set()
        # whose measurements the form holds: None for the defaults or the settings' last
        # trial's (which may be another patient's: refused too)
        self._measured_for: str | None = None
        self._debounce = QTimer(self)
        self._debounce.setSingleShot(True)
        self._debounce.setInterval(DEBOUNCE_MS)
        self._debounce.timeout.connect(self.refresh)

        self.rows = FormRows()
        self.errors, self.labels = self.rows.errors, self.rows.labels
        self._build_fields()
        self.preview = ReachPreview(self.robot)
        self.summary = theme.set_role(QLabel(""), "caption")
        self.summary.setWordWrap(True)
        self.status = QLabel("")
        self.status.setWordWrap(True)
        self.keep_measurements = QPushButton(KEEP)
        self.keep_measurements.setToolTip(
            "The patient chosen has not stored them. Enter theirs (the values shown are "
            "another patient's or the last trial's), or check the ones shown against this "
            "patient; then press: they are kept in the patient's record, with your name, "
            "as a correction of the Registration tab's clinical record is.")
        self.keep_measurements.clicked.connect(self._keep_measurements)
        self.checked_by = QLineEdit()
        self.checked_by.setPlaceholderText("your name")
        self.checked_by.setToolTip("Kept in the patient's record with the values, as who "
                                   "checked them")
        self.checked_by.setAccessibleName("Checked by")
        self.checked_by.returnPressed.connect(self._keep_measurements)
        self._keep_row = QWidget()
        keep_row = QHBoxLayout(self._keep_row)
        keep_row.setContentsMargins(0, 0, 0, 0)
        keep_row.addWidget(QLabel("Checked by"))
        keep_row.addWidget(self.checked_by, 1)
        keep_row.addWidget(self.keep_measurements)
        self._keep_row.hide()
        self._keeping = False  # kept values wait for the registry's answer
        # the console's proposal for the next trial (app.trials.progression): above the
        # picture, where it stays in view however the form is scrolled
        self.proposal = ProposalBox()
        self.proposal.taken.connect(self._use_proposal)
        form = QWidget()
        column = QVBoxLayout(form)
        for group in (self.camera, self._exercise_group, self._patient_group,
                      self._control_group, self.robot_choice):
            column.addWidget(group)
        column.addStretch(1)
        scroll = self._form_scroll = plots.vertical_scroll(form, 460)
        # the patient's rows refused are below the fold on a laptop: shown once the tab is
        # (a therapist read "not stored" and saw only the exercise's fields)
        self._bring_patient_rows = False

        right = QVBoxLayout()
        right.addWidget(self.proposal)
        right.addWidget(theme.set_role(QLabel("What can be reached"), "heading"))
        right.addWidget(self.preview, 1)
        right.addWidget(self.summary)
        right.addWidget(self.status)
        right.addWidget(self._keep_row)
        layout = QHBoxLayout(self)
        layout.addWidget(scroll, 5)
        layout.addLayout(right, 6)

        # the window starts in the as-needed mode; TrialParameters' defaults are the
        # thesis's experiment
        self.set_parameters(TrialParameters(assist="as-needed"))
        self._connect_edits()
        self._show_level_words()
        self.camera._edited()
        self.robot_choice._edited()

    # the proposal's parts, by the names the window and the tests know
    @property
    def _proposal_group(self) -> ProposalBox:
        return self.proposal

    @property
    def proposal_text(self) -> QLabel:
        return self.proposal.text

    @property
    def use_proposal(self):
        return self.proposal.use

    def _connect_edits(self) -> None:
        for box in self._spin_boxes():
            box.setKeyboardTracking(False)  # a number counts when committed
            box.valueChanged.connect(self._edited)
        for choice in (self.shape, self.timing, self.side, self.controller, self.assist,
                       self.force_source):
            choice.currentIndexChanged.connect(self._edited)
        self.assist.currentIndexChanged.connect(self._show_level_words)
        self.assistance.valueChanged.connect(self._assistance_edited)
        self.gains.textChanged.connect(self._edited)
        self.clockwise.toggled.connect(self._edited)
        for key, boxes in self._measurement_boxes().items():
            for box in boxes:  # a value given for the patient chosen counts as theirs
                box.valueChanged.connect(lambda _v, key=key: self._measurement_given(key))

    def _measurement_boxes(self) -> dict:
        return {"body_mass": (self.body_mass,), "upper_arm": (self.upper_arm,),
                "forearm": (self.forearm,), "shoulder": (self.shoulder_x, self.shoulder_y)}

    def _measurement_given(self, key: str) -> None:
        if not self._loading and key in self._missing:
            self._given.add(key)

    def _keep_measurements(self) -> None:
        """The measurements the patient's record lacks, as the form shows them, asked to be
        kept in it (the window writes them: keep_asked), saying who checked them."""
        if not self._missing or self._keeping or self._measured_for is None:
            return
        # a number still being typed is what the therapist sees, and keeps (as Build does)
        if refused := self.commit_edits():
            self._say_keep(f"Not kept: {refused[0]}")
            return
        by = self.checked_by.text().strip()
        if not by:
            self._say_keep("Not kept: give your name in 'Checked by'; the patient's record "
                           "keeps who confirmed their measurements")
            self.checked_by.setFocus()
            return
        values = self._values()
        kept = {}
        for key in PATIENT_MEASUREMENTS:
            if key in self._missing:
                field = PATIENT_MEASUREMENTS[key]  # the Patient's and the trial's name
                how = ("typed for this patient" if key in self._given
                       else "the value shown, checked against this patient")
                kept[field] = (values[field], f"confirmed on the Parameters tab: {how}")
        self._keeping = True
        self.keep_measurements.setEnabled(False)
        self.keep_measurements.setText(SAVING)
        self.keep_asked.emit(self._measured_for, kept, by)

    def keep_answered(self, refusal: str = "") -> None:
        """The registry answered `keep_asked`: the button back; `refusal`, why nothing (or
        not all) was kept, said under it. What was kept comes as the patient's record
        changed (apply_patient)."""
        self._keeping = False
        self.keep_measurements.setEnabled(True)
        self.keep_measurements.setText(KEEP)
        self.refresh()
        if refusal:
            self._say_keep(f"Not kept: {refusal}")

    def _say_keep(self, words: str) -> None:
        self.status.setText(f"{theme.PROBLEM_SIGN} {words}")
        theme.switch_role(self.status, "problem")

    # -- preview ------------------------------------------------------------------
    @property
    def path_bad(self):
        """The preview's crosses on the points that cannot be reached."""
        return self.preview.path_bad

    @property
    def shoulder_mark(self):
        """The preview's mark of the shoulder."""
        return self.preview.shoulder_mark

    def set_flip(self, flip_x: bool, flip_y: bool) -> None:
        """Mirror the preview like the trajectory tab (display only)."""
        self.preview.set_flip(flip_x, flip_y)

    def show_proposal(self, proposal, *, after: str = "") -> None:
        """Show the console's proposal for the next trial (app.trials.progression.Proposal),
        or hide it (None); `after` names the trial it follows when not the one just run."""
        self.proposal.show_proposal(proposal, after=after)

    def _use_proposal(self, proposal) -> None:
        current = self._parameters or self._lenient()
        self.set_parameters(proposal.applied_to(current))
        self.edited.emit()

    def apply_patient(self, patient) -> None:
        """Take a registered patient's measurements (app.records.registry.Patient)."""
        # one truth: a trial never runs with another patient's arm, nor with values the
        # patient's record does not have. What the patient has not stored is refused (under
        # its field, Build refused) until kept in their record: typed, or the value shown
        # checked against them (the values typed for them stay while they are chosen)
        if self._measured_for != patient.code:
            self._given = set()
        self._missing = {key for key, attribute in PATIENT_MEASUREMENTS.items()
                         if getattr(patient, attribute) is None}
        self._given &= self._missing
        self._bring_patient_rows = bool(self._missing - self._given)
        self._measured_for = patient.code
        current = self._parameters or self._lenient()
        self.set_parameters(current.replace(**patient.trial_overrides()))
        self.refresh()
        self.edited.emit()  # a trial built for the previous patient is stale
        if self.isVisible():
            self._show_patient_rows()

    def showEvent(self, event) -> None:  # Qt calls it when the tab is shown
        super().showEvent(event)
        self._show_patient_rows()

    def _show_patient_rows(self) -> None:
        """The form scrolled to the patient's rows when some are refused as not stored, once
        per patient chosen (after the layout has placed them)."""
        if self._bring_patient_rows:
            self._bring_patient_rows = False
            QTimer.singleShot(0, lambda: self._form_scroll.ensureWidgetVisible(
                self._patient_group, 0, 0))

    def _lenient(self) -> TrialParameters:
        try:
            return TrialParameters(**self._values())
        except CoreError:
            return TrialParameters(assist="as-needed")

    def parameters(self) -> TrialParameters:
        """The validated parameters; raises ParameterError or UnreachableError with the
        reason when they are refused."""
        self.refresh()
        if self._parameters is None:
            raise self._error
        return self._parameters

    def problem(self) -> str:
        return self._problem

    def check(self) -> TrialCheck | None:
        return self._check

    def _assistance_edited(self, percent: int) -> None:
        # the transparent mode has no level (a value set there is kept for the next mode,
        # the field shows 0 %: parameters_form._level_follows_mode)
        if self.assist.currentData() == "transparent":
            self._level_follows_mode()
        elif not self._loading:
            self.assistance_changed.emit(percent / 100.0)

    def _edited(self) -> None:
        if self._loading:
            return
        self._enable_for_shape()
        self._debounce.start()
        self.edited.emit()

    def shown(self) -> TrialParameters | None:
        """The parameters the form shows now, as Build would take them before its reach
        check (None when the values themselves are refused); cheap, for comparing with
        the trial built."""
        if self._missing:
            return None
        try:
            return TrialParameters(**self._values())
        except CoreError:
            return None

    def refresh(self) -> None:
        """Validate and check the current values now, redraw, and emit the outcome."""
        self._debounce.stop()
        self._enable_for_shape()
        values = self._values()
        self.proposal.hold_for_task(values.get("assessment", ""))
        for label in self.errors.values():
            label.hide()
        self._check = None
        self._parameters = None
        self._error: CoreError | None = None
        self._keep_row.setVisible(bool(self._missing))
        try:
            parameters = TrialParameters(**values)
        except ParameterError as exc:
            self._error = exc
            self._show_error(field_key(exc.field), str(exc))
            self._problem = str(exc)
        else:
            check = check_trial(parameters, self.robot, units=SCREEN)
            self._check = check
            for key, message in problem_fields(check):
                self._show_error(key, message)
            if check.ok:
                self._parameters = parameters
                self._problem = ""
            else:
                self._problem = check.problems[0]
                self._error = UnreachableError(self._problem)
            self._refuse_missing()
        picture = None if self._check is None else reach_picture(self._check, values["shoulder_m"])
        self.preview.show_picture(picture, values["shoulder_m"])
        self._show_summary()
        self.parameters_changed.emit(self._parameters, self._problem)

    def _refuse_missing(self) -> None:
        """The patient chosen has not stored these measurements: the form's values are not
        theirs (another patient's, the last trial's) unless typed for them, and a trial
        runs only with what their record holds: refused under their rows until kept."""
        if not self._missing:
            return
        keys = [key for key in PATIENT_MEASUREMENTS if key in self._missing]
        for key in keys:
            self._show_error(key, "typed for this patient, not in their record yet"
                             if key in self._given else "not stored for this patient: the "
                             "value shown is not theirs; enter theirs")
        shown = [key for key in keys if key not in self._given]
        named = shown or keys
        words = ", ".join(MEASUREMENT_WORDS[key] for key in named)
        verb = "is" if len(named) == 1 else "are"
        if shown:
            self._problem = (f"this patient's {words} {verb} not stored, and the values shown "
                             "are not theirs (another patient's or the last trial's): enter "
                             f"them, or check them, then press '{KEEP}'"
                             + (" (it keeps the ones typed too)" if shown != keys else ""))
        else:  # every one typed for them
            self._problem = (f"this patient's {words} typed here {verb} not in their record "
                             f"yet: press '{KEEP}'")
        self._parameters = None
        self._error = CoreError(self._problem)

    def _show_error(self, key: str, message: str) -> None:
        label = self.errors.get(key) or self.errors["shape"]
        text = f"{theme.PROBLEM_SIGN} {message}"
        label.setText(text if label.isHidden() else f"{label.text()}\n{text}")
        label.show()

    def _show_summary(self) -> None:
        self.summary.setText("" if self._check is None else check_summary(self._check))
        if self._parameters is not None:
            game = GAME_WORDS.get(self._parameters.game, "")
            self.status.setText("Ready: every point of the path can be reached." + (
                f" Played as {game}; a field changed here makes it a plain exercise."
                if game else ""))
            theme.switch_role(self.status, "ok")
        else:
            self.status.setText(f"{theme.PROBLEM_SIGN} Not ready: {self._problem}")
            theme.switch_role(self.status, "problem")

    # -- camera and backend ----------------------------------------------------------
    def camera_source(self) -> int | str | None:
        """The camera number or video file in camera mode; None without camera."""
        return self.camera.source()

    def set_backend(self, choice: BackendChoice) -> None:
        """Show this robot choice (the one the settings remember)."""
        self.robot_choice.set_choice(choice)

    def backend(self) -> BackendChoice:
        return self.robot_choice.choice()

    def backend_problem(self) -> str:
        return self.robot_choice.problem()

    def _backend_edited(self, choice: BackendChoice) -> None:
        self.backend_changed.emit(choice)
        if not self._loading:
            self.edited.emit()
