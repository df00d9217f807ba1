"""The Parameters tab (thesis Figs. A.6–A.7): the exercise, the patient's arm, the
controller and the robot backend, with a live picture of what can be reached.

Fields show the units a therapist reads best (cm for positions and lengths, s,
kg, °, %) and convert to SI at once; each spin box's limits are the range
`core.trial.TrialParameters` accepts, so out-of-range values cannot be typed.
What the limits cannot catch (a path the arm or the robot cannot reach, a path
too fast) comes from `core.trial.check_trial` and is written under the field to
change, in its own words with the distances.

Numbers count when the therapist commits them (Enter, leaving the field, the
arrows), never per keystroke: typing 60 into the assistance level during a trial set
6 % and then 60 % (issue 27 #4). The window commits a field still being typed in
before Build and Start (`commit_edits`), so what is on the screen is what is built.

The picture is `ui.reach_preview.ReachPreview`, and what the check says (the
picture's geometry, the summary, which field a problem goes under) is
`ui.views.reach`, computed without Qt. The camera and the robot choices are
`ui.tabs.parameters_devices`, the proposal above the form `ui.tabs.proposal_box`,
the level's words in each mode `ui.views.assist_words`. What is left here is the
form itself: the exercise, the patient and the control, each field built,
converted to SI and back, and given a place for its problem.
"""

from __future__ import annotations

import math

from PySide6.QtCore import QTimer, Signal
from PySide6.QtWidgets import (
    QAbstractSpinBox,
    QCheckBox,
    QDoubleSpinBox,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QVBoxLayout,
    QWidget,
)

from app.learning.library import learned_label
from app.units import SCREEN
from core.arm import BODY_MASS_RANGE_KG, FOREARM_RANGE_M, UPPER_ARM_RANGE_M
from core.errors import CoreError, ParameterError, UnreachableError
from core.robot import RobotModel
from core.trajectory import SHAPES, TIMINGS
from core.trial import (
    ASSIST_MODES,
    CONTROLLERS,
    DURATION_RANGE_S,
    POSITION_RANGE_M,
    RADIUS_RANGE_M,
    REPETITIONS_RANGE,
    SIDES,
    TARGETS_RANGE,
    TOLERANCE_RANGE_RAD,
    TrialCheck,
    TrialParameters,
    check_trial,
)
from ui import plots, theme
from ui.fields import ComboBox, SpinBox
from ui.reach_preview import ReachPreview
from ui.tabs.form_rows import FormRows
from ui.tabs.parameters_devices import (
    HARDWARE,
    SIMULATOR,
    BackendChoice,
    CameraChoice,
    RobotChoice,
)
from ui.tabs.parameters_fields import (
    ASSIST_NAMES,
    CENTRE_LABELS,
    CONTROLLER_NAMES,
    LEARNED,
    SENSOR_LABEL,
    SHAPE_NAMES,
    SIDE_NAMES,
    TIMING_NAMES,
    combo,
    controller_fields,
    emg_label,
    offer_controllers,
    offer_force_sources,
    spin,
)
from ui.tabs.proposal_box import ProposalBox
from ui.views.assist_words import level_words
from ui.views.reach import (
    CM,
    check_summary,
    field_key,
    problem_fields,
    reach_picture,
)

DEBOUNCE_MS = 120
__all__ = ["HARDWARE", "SIMULATOR", "BackendChoice", "ParametersTab"]


TASK_FIELDS = ("shape", "radius_m", "n_targets", "duration_s", "repetitions", "timing",
               "clockwise", "assist", "controller", "gains")
"""The fields an assessment task's protocol fixes (core.assessment.protocol.Protocol)."""


class ParametersTab(QWidget):
    """Signals:
    parameters_changed(TrialParameters | None, problem): after every edit (debounced);
        None with the reason when the values are refused or cannot be reached.
    edited(): at once after every committed change of anything Build takes (a field,
        the robot, the patient's force): the window's built trial may now be stale.
    assistance_changed(level): the level (0–1) the therapist committed, at once.
    camera_changed(camera source or None): int index or file path; None without camera.
    backend_changed(BackendChoice).
    """

    parameters_changed = Signal(object, str)
    edited = Signal()
    assistance_changed = Signal(float)
    """The assistance level (0–1) the therapist committed (Enter, leaving the field, the
    arrows), at once (not debounced): a running trial takes it live."""
    camera_changed = Signal(object)
    backend_changed = Signal(object)

    def __init__(self, robot: RobotModel | None = None, parent=None) -> None:
        super().__init__(parent)
        self.robot = robot or RobotModel()
        self._check: TrialCheck | None = None
        self._parameters: TrialParameters | None = None
        self._error: CoreError | None = None
        self._problem = ""
        self._loading = False
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
        scroll = plots.vertical_scroll(form, 460)

        right = QVBoxLayout()
        right.addWidget(self.proposal)
        right.addWidget(theme.set_role(QLabel("What can be reached"), "heading"))
        right.addWidget(self.preview, 1)
        right.addWidget(self.summary)
        right.addWidget(self.status)
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

    # -- fields -------------------------------------------------------------------
    def _build_fields(self) -> None:
        self.camera = CameraChoice(self.rows)
        self.with_camera = self.camera.with_camera
        self.without_camera = self.camera.without_camera
        self.camera_source_edit = self.camera.source_edit
        self.camera.changed.connect(self.camera_changed.emit)

        pos_lo, pos_hi = (v * CM for v in POSITION_RANGE_M)
        self.shape = combo(SHAPE_NAMES, SHAPES)
        self.radius = spin(RADIUS_RANGE_M[0] * CM, RADIUS_RANGE_M[1] * CM, 2, " cm", 0.5)
        self.duration = spin(*DURATION_RANGE_S, 1, " s", 0.5)
        self.centre_x = spin(pos_lo, pos_hi, 2, " cm", 1.0)
        self.centre_y = spin(pos_lo, pos_hi, 2, " cm", 1.0)
        self.clockwise = QCheckBox("Clockwise")
        self.n_targets = SpinBox()
        self.n_targets.setRange(*TARGETS_RANGE)
        self.repetitions = SpinBox()
        self.repetitions.setRange(*REPETITIONS_RANGE)
        self.timing = combo(TIMING_NAMES, TIMINGS)
        self._exercise_group = QGroupBox("Exercise")
        form = self.rows.form(self._exercise_group)
        self.rows.add(form, "Shape", self.shape, "shape")
        self.rows.add(form, "Radius", self.radius, "radius")
        self.rows.add(form, "Time per traversal", self.duration, "duration")
        self.rows.add(form, "Centre", self._pair(self.centre_x, self.centre_y), "centre")
        self.rows.add(form, "Direction", self.clockwise, "clockwise")
        self.rows.add(form, "Targets", self.n_targets, "n_targets")
        self.rows.add(form, "Repetitions", self.repetitions, "repetitions")
        self.rows.add(form, "Timing", self.timing, "timing")

        self.body_mass = spin(*BODY_MASS_RANGE_KG, 1, " kg", 1.0)
        self.upper_arm = spin(UPPER_ARM_RANGE_M[0] * CM, UPPER_ARM_RANGE_M[1] * CM, 2, " cm", 0.5)
        self.forearm = spin(FOREARM_RANGE_M[0] * CM, FOREARM_RANGE_M[1] * CM, 2, " cm", 0.5)
        self.side = combo(SIDE_NAMES, SIDES)
        self.shoulder_x = spin(pos_lo, pos_hi, 2, " cm", 1.0)
        self.shoulder_y = spin(pos_lo, pos_hi, 2, " cm", 1.0)
        self._patient_group = QGroupBox("Patient")
        form = self.rows.form(self._patient_group)
        self.rows.add(form, "Body mass", self.body_mass, "body_mass")
        self.rows.add(form, "Upper arm", self.upper_arm, "upper_arm")
        self.rows.add(form, "Forearm", self.forearm, "forearm")
        self.rows.add(form, "Side trained", self.side, "side")
        self.rows.add(form, "Shoulder", self._pair(self.shoulder_x, self.shoulder_y), "shoulder")

        tol_lo, tol_hi = (math.degrees(v) for v in TOLERANCE_RANGE_RAD)
        self.controller = combo(CONTROLLER_NAMES, CONTROLLERS)
        self.assist = combo(ASSIST_NAMES, ASSIST_MODES)
        self.tolerance = spin(tol_lo, tol_hi, 1, "°", 1.0)
        self.assistance = SpinBox()
        self.assistance.setRange(0, 100)
        self.assistance.setSuffix(" %")
        self.assistance.setSingleStep(5)
        # it drives a running trial: a level counts when committed, never per keystroke
        self.assistance.setKeyboardTracking(False)
        self._control_group = QGroupBox("Control")
        form = self.rows.form(self._control_group)
        self.rows.add(form, "Assistance mode", self.assist, "assist")
        self.rows.add(form, "Controller", self.controller, "controller")
        self.rows.add(form, "Tolerance angle", self.tolerance, "tolerance")
        self.rows.add(form, "Assistance", self.assistance, "assistance")
        # what the assistance judges the patient's push by: the handle's force sensor, or
        # an approved EMG model's estimate (models/emg, `rehab emg model --save`)
        self.force_source = ComboBox()
        self.force_source.addItem(SENSOR_LABEL, "")
        self.force_source.setToolTip("What the assistance judges the patient's push by. An "
                                     "EMG model needs the EMG source connected and each of "
                                     "its muscles' MVCs recorded on the EMG tab.")
        self.rows.add(form, "Patient's force", self.force_source, "force_estimate")
        self.gains = QLineEdit()
        self.gains.setPlaceholderText("defaults; e.g. smc.lambda_1_s=25; guidance.delay_s=0.5")
        self.gains.setToolTip("For researchers: changes to the controller's and the "
                              "guidance's gains, saved with the trial; a gain out of its "
                              "range is refused under the field with the range.")
        self.rows.add(form, "Gains (advanced)", self.gains, "gains")

        self.robot_choice = RobotChoice(self.rows)
        self.simulator = self.robot_choice.simulator
        self.hardware = self.robot_choice.hardware
        self.patient_kind = self.robot_choice.patient_kind
        self.settings_path = self.robot_choice.settings_path
        self.robot_choice.changed.connect(self._backend_edited)

    def _pair(self, x: QDoubleSpinBox, y: QDoubleSpinBox) -> QWidget:
        box = QWidget()
        row = QHBoxLayout(box)
        row.setContentsMargins(0, 0, 0, 0)
        for name, field in (("x", x), ("y", y)):
            row.addWidget(QLabel(name))
            row.addWidget(field, 1)
        return box

    def _spin_boxes(self) -> tuple[QAbstractSpinBox, ...]:
        return (self.radius, self.duration, self.centre_x, self.centre_y, self.body_mass,
                self.upper_arm, self.forearm, self.shoulder_x, self.shoulder_y,
                self.tolerance, self.n_targets, self.repetitions, self.assistance)

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

    def commit_edits(self) -> None:
        """Take a number still being typed (the field shows it, its value is not yet
        changed): Build and Start call this first, so what is on the screen counts."""
        for box in self._spin_boxes():
            if box.text() != box.textFromValue(box.value()) + box.suffix() \
                    and box.hasAcceptableInput():
                box.interpretText()

    def _show_level_words(self) -> None:
        """The level's label and tooltip say what it means in the mode chosen."""
        words = level_words(self.assist.currentData())
        label = self.labels.get("assistance")
        if label is not None:
            label.setText(words.label)
            label.setToolTip(words.tooltip)
        self.assistance.setToolTip(words.tooltip)
        self.assistance.setAccessibleName(words.label)
        # the transparent mode has no level (core.control.transparent): greyed, and the
        # trial built runs at 0 %
        self.assistance.setEnabled(self.assist.currentData() != "transparent")

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

    # -- values -------------------------------------------------------------------
    def _values(self) -> dict:
        def metres(box: QDoubleSpinBox) -> float:
            # Rounded to the field's resolution, so 30.48 cm is 0.3048 m and not
            # 0.30479999999999996 m: equal parameters must compare equal.
            return round(box.value() / CM, box.decimals() + 2)

        values = {
            "shape": self.shape.currentData(),
            "centre_m": (metres(self.centre_x), metres(self.centre_y)),
            "radius_m": metres(self.radius),
            "duration_s": self.duration.value(),
            "repetitions": self.repetitions.value(),
            "timing": self.timing.currentData(),
            "clockwise": self.clockwise.isChecked(),
            "n_targets": self.n_targets.value(),
            "shoulder_m": (metres(self.shoulder_x), metres(self.shoulder_y)),
            "body_mass_kg": self.body_mass.value(),
            "upper_arm_m": metres(self.upper_arm),
            "forearm_m": metres(self.forearm),
            "side": self.side.currentData(),
            "tolerance_rad": math.radians(self.tolerance.value()),
            **controller_fields(self.controller.currentData()),
            "assistance_level": self.assistance.value() / 100.0,
            "assist": self.assist.currentData(),
            "gains": self.gains.text(),
            "force_estimate": self.force_source.currentData() or "",
        }
        values["assessment"] = self._assessment_of(values)
        return values

    def _assessment_of(self, values: dict) -> str:
        """The assessment task the form holds: the one last set (Assessments tab) while
        every field its protocol fixes is as it set it; a changed field makes the trial an
        exercise again (core.assessment.protocol)."""
        task = getattr(self, "_task", None)
        if task is None:
            return ""
        if any(values.get(name) != getattr(task, name) for name in TASK_FIELDS):
            return ""
        return task.assessment

    def set_parameters(self, parameters: TrialParameters) -> None:
        """Show these parameters (the last trial's, a patient's, an assessment task's);
        checks them at once."""
        self._task = parameters if parameters.assessment else None
        self._loading = True
        try:
            self.shape.setCurrentIndex(self.shape.findData(parameters.shape))
            self.centre_x.setValue(parameters.centre_m[0] * CM)
            self.centre_y.setValue(parameters.centre_m[1] * CM)
            self.radius.setValue(parameters.radius_m * CM)
            self.duration.setValue(parameters.duration_s)
            self.repetitions.setValue(parameters.repetitions)
            self.timing.setCurrentIndex(self.timing.findData(parameters.timing))
            self.clockwise.setChecked(parameters.clockwise)
            self.n_targets.setValue(parameters.n_targets)
            self.shoulder_x.setValue(parameters.shoulder_m[0] * CM)
            self.shoulder_y.setValue(parameters.shoulder_m[1] * CM)
            self.body_mass.setValue(parameters.body_mass_kg)
            self.upper_arm.setValue(parameters.upper_arm_m * CM)
            self.forearm.setValue(parameters.forearm_m * CM)
            self.side.setCurrentIndex(self.side.findData(parameters.side))
            self.tolerance.setValue(math.degrees(parameters.tolerance_rad))
            key = (LEARNED + parameters.learned_model if parameters.learned_model
                   else parameters.controller)
            if self.controller.findData(key) < 0:
                # a trial's model no longer in the folder: shown, so Build says it is missing
                self.controller.addItem(learned_label(parameters.learned_model), key)
            self.controller.setCurrentIndex(self.controller.findData(key))
            self.assistance.setValue(round(parameters.assistance_level * 100))
            self.assist.setCurrentIndex(self.assist.findData(parameters.assist))
            self.gains.setText(parameters.gains)
            if self.force_source.findData(parameters.force_estimate) < 0:
                # a trial's EMG model no longer in the folder: shown, so Build says so
                self.force_source.addItem(emg_label(parameters.force_estimate),
                                          parameters.force_estimate)
            self.force_source.setCurrentIndex(
                self.force_source.findData(parameters.force_estimate))
        finally:
            self._loading = False
        self.refresh()

    def set_learned_models(self, names) -> None:
        """Offer "CT-PID (learned: <name>)" for each of these model names, after the
        analytic controllers; the current choice is kept (added if it is a model no longer
        among them, so that Build can say so)."""
        self._loading = True
        try:
            offer_controllers(self.controller, names)
        finally:
            self._loading = False

    def set_emg_models(self, names) -> None:
        """Offer "EMG model: <name>" for each approved EMG model after the force sensor;
        the current choice is kept (added if no longer among them, so that Build says so)."""
        self._loading = True
        try:
            offer_force_sources(self.force_source, names)
        finally:
            self._loading = False

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
        current = self._parameters or self._lenient()
        self.set_parameters(current.replace(**patient.trial_overrides()))

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
        if not self._loading:
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
        try:
            return TrialParameters(**self._values())
        except CoreError:
            return None

    def _enable_for_shape(self) -> None:
        shape = self.shape.currentData()
        self.n_targets.setEnabled(shape == "targets")
        self.clockwise.setEnabled(shape in ("d", "circle"))
        # what "centre" means depends on the shape: the thesis's form names the D's
        # straight line (Appendix A)
        label = self.labels.get("centre")
        if label is not None:
            label.setText(CENTRE_LABELS.get(shape, "Centre"))

    def refresh(self) -> None:
        """Validate and check the current values now, redraw, and emit the outcome."""
        self._debounce.stop()
        self._enable_for_shape()
        values = self._values()
        for label in self.errors.values():
            label.hide()
        self._check = None
        self._parameters = None
        self._error: CoreError | None = None
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
        picture = None if self._check is None else reach_picture(self._check, values["shoulder_m"])
        self.preview.show_picture(picture, values["shoulder_m"])
        self._show_summary()
        self.parameters_changed.emit(self._parameters, self._problem)

    def _show_error(self, key: str, message: str) -> None:
        label = self.errors.get(key) or self.errors["shape"]
        text = f"{theme.PROBLEM_SIGN} {message}"
        label.setText(text if label.isHidden() else f"{label.text()}\n{text}")
        label.show()

    def _show_summary(self) -> None:
        self.summary.setText("" if self._check is None else check_summary(self._check))
        if self._parameters is not None:
            self.status.setText("Ready: every point of the path can be reached.")
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
