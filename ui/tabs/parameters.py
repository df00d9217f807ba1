"""The Parameters tab (thesis Figs. A.6–A.7): the exercise, the patient's arm, the
controller and the robot backend, with a live picture of what can be reached.

Fields show the units a therapist reads best (cm for positions and lengths, s,
kg, °, %) and convert to SI at once; each spin box's limits are the range
`core.trial.TrialParameters` accepts, so out-of-range values cannot be typed.
What the limits cannot catch (a path the arm or the robot cannot reach, a path
too fast) comes from `core.trial.check_trial` and is written under the field to
change, in its own words with the distances.

The picture is `ui.reach_preview.ReachPreview`, and what the check says (the
picture's geometry, the summary, which field a problem goes under) is
`ui.views.reach`, computed without Qt. What is left here is one job, the form
itself, and it is a little over 500 lines because the form is large: five groups
(camera, exercise, patient, control, robot) of some twenty fields, each built,
converted to SI and back, and given a place for its problem.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from PySide6.QtCore import QTimer, Signal
from PySide6.QtWidgets import (
    QButtonGroup,
    QCheckBox,
    QComboBox,
    QDoubleSpinBox,
    QFileDialog,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
    QRadioButton,
    QSizePolicy,
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
from device.sim.patients import PATIENT_KINDS
from ui import plots, theme
from ui.fields import ComboBox, DoubleSpinBox, SpinBox
from ui.reach_preview import ReachPreview
from ui.views.reach import (
    CM,
    check_summary,
    field_key,
    problem_fields,
    reach_picture,
)

SHAPE_NAMES = {"d": "D shape", "circle": "Circle", "reach": "Reach out and back",
               "targets": "Targets (centre-out)", "figure8": "Figure eight"}
TIMING_NAMES = {"constant_speed": "Steady speed", "minimum_jerk": "Smooth start and stop"}
CONTROLLER_NAMES = {"smc": "Sliding mode (SMC)", "ctpid": "Computed-torque PID"}
SENSOR_LABEL = "Force sensor"


def emg_label(name: str) -> str:
    """How the Patient's force choice names an EMG model."""
    return f"EMG model: {name}"


LEARNED = "learned:"
"""The controller choice's data for "CT-PID (learned: <name>)": LEARNED + the model's name
(a file in the data folder's models/, app.learning.library)."""
ASSIST_NAMES = {"as-needed": "As needed: gives way as the patient does more",
                "thesis": "Thesis (Fig. 3.6): fixed clock, reduce-only"}
SIDE_NAMES = {"right": "Right arm", "left": "Left arm"}
PATIENT_NAMES = {"healthy": "Healthy", "weak": "Weak", "spastic": "Spastic", "tremor": "Tremor",
                 "passive": "Passive (no effort)", "wrong_way": "Pushes the wrong way at times"}
DEBOUNCE_MS = 120
SIMULATOR = "simulator"
HARDWARE = "hardware"


CENTRE_LABELS = {
    "d": "Centre of the D's straight line",
    "circle": "Centre of the circle",
    "reach": "Start of the reach",
    "targets": "Home, at the centre of the targets",
    "figure8": "Centre of the figure eight",
}
"""The Centre field's label for each shape: the point the path is placed by."""


@dataclass(frozen=True, slots=True)
class BackendChoice:
    """The robot the trial runs on: the simulator with a virtual patient, or the real
    robot with its hardware settings file (device/hardware/settings.py reads it)."""

    name: str  # SIMULATOR or HARDWARE
    patient_kind: str | None = None
    settings_path: Path | None = None


def _spin(low: float, high: float, decimals: int, suffix: str, step: float) -> QDoubleSpinBox:
    box = DoubleSpinBox()
    box.setRange(low, high)
    box.setDecimals(decimals)
    box.setSuffix(suffix)
    box.setSingleStep(step)
    box.setKeyboardTracking(True)
    box.setAccelerated(True)
    box.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
    return box


def _controller_fields(key: str) -> dict:
    """The trial's controller fields for the controller choice's data."""
    if key.startswith(LEARNED):
        return {"controller": "ctpid", "learned_model": key[len(LEARNED):]}
    return {"controller": key}


def _combo(names: dict[str, str], keys: tuple[str, ...]) -> QComboBox:
    box = ComboBox()
    for key in keys:
        box.addItem(names.get(key, key), key)
    return box


class ParametersTab(QWidget):
    """Signals:
    parameters_changed(TrialParameters | None, problem): after every edit (debounced);
        None with the reason when the values are refused or cannot be reached.
    camera_changed(camera source or None): int index or file path; None without camera.
    backend_changed(BackendChoice).
    """

    parameters_changed = Signal(object, str)
    assistance_changed = Signal(float)
    """The assistance level (0–1) the therapist set, at once (not debounced): a running
    trial takes it live."""
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

        self._build_fields()
        self.preview = ReachPreview(self.robot)
        self.summary = theme.set_role(QLabel(""), "caption")
        self.summary.setWordWrap(True)
        self.status = QLabel("")
        self.status.setWordWrap(True)
        # the console's proposal for the next trial (app.trials.progression), shown after a
        # trial until the therapist uses it or changes anything
        self.proposal_text = QLabel("")
        self.proposal_text.setWordWrap(True)
        self.use_proposal = QPushButton("Use the proposal")
        self.use_proposal.clicked.connect(self._use_proposal)
        self._proposal = None
        self._proposal_group = QGroupBox("Proposed for the next trial")
        row = QHBoxLayout(self._proposal_group)
        row.addWidget(self.proposal_text, 1)
        row.addWidget(self.use_proposal)
        self._proposal_group.hide()
        form = QWidget()
        column = QVBoxLayout(form)
        column.addWidget(self._proposal_group)
        for group in (self._video_group, self._exercise_group, self._patient_group,
                      self._control_group, self._backend_group):
            column.addWidget(group)
        column.addStretch(1)
        scroll = plots.vertical_scroll(form, 460)

        right = QVBoxLayout()
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
        self._camera_edited()
        self._backend_edited()

    # -- fields -------------------------------------------------------------------
    def _build_fields(self) -> None:
        self.errors: dict[str, QLabel] = {}
        self.labels: dict[str, QLabel] = {}

        self.with_camera = QRadioButton("With camera")
        self.without_camera = QRadioButton("Without camera")
        self.without_camera.setChecked(True)
        self._camera_mode = QButtonGroup(self)
        self._camera_mode.addButton(self.with_camera)
        self._camera_mode.addButton(self.without_camera)
        self.camera_source_edit = QLineEdit("0")
        self.camera_source_edit.setPlaceholderText("0 for the first camera, or a video file")
        self.camera_source_edit.setAccessibleName("Camera number or video file")
        self._video_group = QGroupBox("Pose estimation")
        form = self._form(self._video_group)
        modes = QHBoxLayout()
        modes.addWidget(self.with_camera)
        modes.addWidget(self.without_camera)
        modes.addStretch(1)
        form.addRow(modes)
        self._add(form, "Camera", self.camera_source_edit, "camera")
        self.camera_hint = theme.set_role(QLabel(
            "Without a camera the joint angles come from the shoulder position below: "
            "the shoulder must stay still."), "caption")
        self.camera_hint.setWordWrap(True)
        form.addRow(self.camera_hint)

        pos_lo, pos_hi = (v * CM for v in POSITION_RANGE_M)
        self.shape = _combo(SHAPE_NAMES, SHAPES)
        self.radius = _spin(RADIUS_RANGE_M[0] * CM, RADIUS_RANGE_M[1] * CM, 2, " cm", 0.5)
        self.duration = _spin(*DURATION_RANGE_S, 1, " s", 0.5)
        self.centre_x = _spin(pos_lo, pos_hi, 2, " cm", 1.0)
        self.centre_y = _spin(pos_lo, pos_hi, 2, " cm", 1.0)
        self.clockwise = QCheckBox("Clockwise")
        self.n_targets = SpinBox()
        self.n_targets.setRange(*TARGETS_RANGE)
        self.repetitions = SpinBox()
        self.repetitions.setRange(*REPETITIONS_RANGE)
        self.timing = _combo(TIMING_NAMES, TIMINGS)
        self._exercise_group = QGroupBox("Exercise")
        form = self._form(self._exercise_group)
        self._add(form, "Shape", self.shape, "shape")
        self._add(form, "Radius", self.radius, "radius")
        self._add(form, "Time per traversal", self.duration, "duration")
        self._add(form, "Centre", self._pair(self.centre_x, self.centre_y), "centre")
        self._add(form, "Direction", self.clockwise, "clockwise")
        self._add(form, "Targets", self.n_targets, "n_targets")
        self._add(form, "Repetitions", self.repetitions, "repetitions")
        self._add(form, "Timing", self.timing, "timing")

        self.body_mass = _spin(*BODY_MASS_RANGE_KG, 1, " kg", 1.0)
        self.upper_arm = _spin(UPPER_ARM_RANGE_M[0] * CM, UPPER_ARM_RANGE_M[1] * CM, 2, " cm", 0.5)
        self.forearm = _spin(FOREARM_RANGE_M[0] * CM, FOREARM_RANGE_M[1] * CM, 2, " cm", 0.5)
        self.side = _combo(SIDE_NAMES, SIDES)
        self.shoulder_x = _spin(pos_lo, pos_hi, 2, " cm", 1.0)
        self.shoulder_y = _spin(pos_lo, pos_hi, 2, " cm", 1.0)
        self._patient_group = QGroupBox("Patient")
        form = self._form(self._patient_group)
        self._add(form, "Body mass", self.body_mass, "body_mass")
        self._add(form, "Upper arm", self.upper_arm, "upper_arm")
        self._add(form, "Forearm", self.forearm, "forearm")
        self._add(form, "Side trained", self.side, "side")
        self._add(form, "Shoulder", self._pair(self.shoulder_x, self.shoulder_y), "shoulder")

        tol_lo, tol_hi = (math.degrees(v) for v in TOLERANCE_RANGE_RAD)
        self.controller = _combo(CONTROLLER_NAMES, CONTROLLERS)
        self.assist = _combo(ASSIST_NAMES, ASSIST_MODES)
        self.tolerance = _spin(tol_lo, tol_hi, 1, "°", 1.0)
        self.assistance = SpinBox()
        self.assistance.setRange(0, 100)
        self.assistance.setSuffix(" %")
        self.assistance.setSingleStep(5)
        self._control_group = QGroupBox("Control")
        form = self._form(self._control_group)
        self._add(form, "Assistance mode", self.assist, "assist")
        self._add(form, "Controller", self.controller, "controller")
        self._add(form, "Tolerance angle", self.tolerance, "tolerance")
        self._add(form, "Assistance", self.assistance, "assistance")
        # what the assistance judges the patient's push by: the handle's force sensor, or
        # an approved EMG model's estimate (models/emg, `rehab emg model --save`)
        self.force_source = ComboBox()
        self.force_source.addItem(SENSOR_LABEL, "")
        self.force_source.setToolTip("What the assistance judges the patient's push by. An "
                                     "EMG model needs the EMG source connected and each of "
                                     "its muscles' MVCs recorded on the EMG tab.")
        self._add(form, "Patient's force", self.force_source, "force_estimate")
        self.gains = QLineEdit()
        self.gains.setPlaceholderText("defaults; e.g. smc.lambda_1_s=25; guidance.delay_s=0.5")
        self.gains.setToolTip("For researchers: changes to the controller's and the "
                              "guidance's gains, saved with the trial. `rehab gains` lists "
                              "every gain with its default and range.")
        self._add(form, "Gains (advanced)", self.gains, "gains")

        self.simulator = QRadioButton("Simulator")
        self.hardware = QRadioButton("Robot hardware")
        self.simulator.setChecked(True)
        self._backend_mode = QButtonGroup(self)
        self._backend_mode.addButton(self.simulator)
        self._backend_mode.addButton(self.hardware)
        self.patient_kind = _combo(PATIENT_NAMES, PATIENT_KINDS)
        self.settings_path = QLineEdit()
        self.settings_path.setPlaceholderText("hardware settings file (.toml)")
        self.settings_path.setAccessibleName("Hardware settings file")
        self.browse = QPushButton("Choose…")
        self.browse.clicked.connect(self._choose_settings)
        path_row = QHBoxLayout()
        path_row.setContentsMargins(0, 0, 0, 0)
        path_row.addWidget(self.settings_path, 1)
        path_row.addWidget(self.browse)
        path_box = QWidget()
        path_box.setLayout(path_row)
        self._backend_group = QGroupBox("Robot")
        form = self._form(self._backend_group)
        modes = QHBoxLayout()
        modes.addWidget(self.simulator)
        modes.addWidget(self.hardware)
        modes.addStretch(1)
        form.addRow(modes)
        self._add(form, "Virtual patient", self.patient_kind, "patient_kind")
        self._add(form, "Settings file", path_box, "settings_path")

    def _form(self, group: QGroupBox) -> QFormLayout:
        form = QFormLayout(group)
        form.setFieldGrowthPolicy(QFormLayout.FieldGrowthPolicy.AllNonFixedFieldsGrow)
        form.setRowWrapPolicy(QFormLayout.RowWrapPolicy.DontWrapRows)
        return form

    def _pair(self, x: QDoubleSpinBox, y: QDoubleSpinBox) -> QWidget:
        box = QWidget()
        row = QHBoxLayout(box)
        row.setContentsMargins(0, 0, 0, 0)
        for name, spin in (("x", x), ("y", y)):
            row.addWidget(QLabel(name))
            row.addWidget(spin, 1)
        return box

    def _add(self, form: QFormLayout, label: str, field: QWidget, key: str) -> None:
        error = theme.set_role(QLabel(""), "problem")
        error.setWordWrap(True)
        error.hide()
        error.setAccessibleName(f"{label}: problem")
        self.errors[key] = error
        holder = QWidget()
        column = QVBoxLayout(holder)
        column.setContentsMargins(0, 0, 0, 0)
        column.setSpacing(2)
        column.addWidget(field)
        column.addWidget(error)
        form.addRow(label, holder)
        self.labels[key] = form.labelForField(holder)
        field.setAccessibleName(field.accessibleName() or label)

    def _connect_edits(self) -> None:
        for spin in (self.radius, self.duration, self.centre_x, self.centre_y, self.body_mass,
                     self.upper_arm, self.forearm, self.shoulder_x, self.shoulder_y,
                     self.tolerance, self.n_targets, self.repetitions, self.assistance):
            spin.valueChanged.connect(self._edited)
        for combo in (self.shape, self.timing, self.side, self.controller, self.assist,
                      self.force_source):
            combo.currentIndexChanged.connect(self._edited)
        self.assistance.valueChanged.connect(self._assistance_edited)
        self.gains.textChanged.connect(self._edited)
        self.clockwise.toggled.connect(self._edited)
        self.with_camera.toggled.connect(self._camera_edited)
        self.camera_source_edit.textChanged.connect(self._camera_edited)
        self.simulator.toggled.connect(self._backend_edited)
        self.patient_kind.currentIndexChanged.connect(self._backend_edited)
        self.settings_path.textChanged.connect(self._backend_edited)

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

        return {
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
            **_controller_fields(self.controller.currentData()),
            "assistance_level": self.assistance.value() / 100.0,
            "assist": self.assist.currentData(),
            "gains": self.gains.text(),
            "force_estimate": self.force_source.currentData() or "",
        }

    def set_parameters(self, parameters: TrialParameters) -> None:
        """Show these parameters (the last trial's, a patient's); checks them at once."""
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
        current = self.controller.currentData()
        keys = [*CONTROLLERS, *(LEARNED + n for n in names)]
        if current is not None and current not in keys:
            keys.append(current)
        self._loading = True
        try:
            self.controller.clear()
            for key in keys:
                label = (learned_label(key[len(LEARNED):]) if key.startswith(LEARNED)
                         else CONTROLLER_NAMES.get(key, key))
                self.controller.addItem(label, key)
            if current is not None:
                self.controller.setCurrentIndex(self.controller.findData(current))
        finally:
            self._loading = False

    def set_emg_models(self, names) -> None:
        """Offer "EMG model: <name>" for each approved EMG model after the force sensor;
        the current choice is kept (added if no longer among them, so that Build says so)."""
        current = self.force_source.currentData() or ""
        keys = ["", *names]
        if current not in keys:
            keys.append(current)
        self._loading = True
        try:
            self.force_source.clear()
            for key in keys:
                self.force_source.addItem(emg_label(key) if key else SENSOR_LABEL, key)
            self.force_source.setCurrentIndex(self.force_source.findData(current))
        finally:
            self._loading = False

    def show_proposal(self, proposal) -> None:
        """Show the console's proposal for the next trial (app.trials.progression.Proposal),
        or hide it (None); a proposal that changes nothing is shown without the button."""
        self._proposal = proposal
        if proposal is None:
            self._proposal_group.hide()
            return
        self.proposal_text.setText(proposal.reason[:1].upper() + proposal.reason[1:] + ".")
        self.use_proposal.setVisible(proposal.change != "none")
        self._proposal_group.show()

    def _use_proposal(self) -> None:
        if self._proposal is None:
            return
        current = self._parameters or self._lenient()
        self.set_parameters(self._proposal.applied_to(current))
        self.proposal_text.setText(self.proposal_text.text() + " Taken: press Build.")
        self.use_proposal.hide()

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
        if not self.with_camera.isChecked():
            return None
        text = self.camera_source_edit.text().strip()
        if text.isdigit():
            return int(text)
        return text or None

    def _camera_edited(self) -> None:
        camera = self.with_camera.isChecked()
        self.camera_source_edit.setEnabled(camera)
        self.camera_hint.setText(
            "The camera films the arm; its video is saved beside the trial." if camera else
            "Without a camera the joint angles come from the shoulder position below: "
            "the shoulder must stay still.")
        error = self.errors["camera"]
        if camera and self.camera_source() is None:
            error.setText(f"{theme.PROBLEM_SIGN} Give the camera's number (0 for the first "
                          "camera) or a video file.")
            error.show()
        else:
            error.hide()
        self.camera_changed.emit(self.camera_source())

    def set_backend(self, choice: BackendChoice) -> None:
        """Show this robot choice (the one the settings remember); an unknown virtual
        patient's kind leaves the list as it is."""
        if choice.name == HARDWARE:
            self.hardware.setChecked(True)
            if choice.settings_path is not None:
                self.settings_path.setText(str(choice.settings_path))
        else:
            self.simulator.setChecked(True)
            index = self.patient_kind.findData(choice.patient_kind)
            if index >= 0:
                self.patient_kind.setCurrentIndex(index)
        self._backend_edited()

    def backend(self) -> BackendChoice:
        if self.simulator.isChecked():
            return BackendChoice(SIMULATOR, patient_kind=self.patient_kind.currentData())
        text = self.settings_path.text().strip()
        return BackendChoice(HARDWARE, settings_path=Path(text) if text else None)

    def backend_problem(self) -> str:
        choice = self.backend()
        if choice.name == HARDWARE and choice.settings_path is None:
            return "Choose the robot's hardware settings file."
        return ""

    def _backend_edited(self) -> None:
        simulator = self.simulator.isChecked()
        self.patient_kind.setEnabled(simulator)
        self.settings_path.setEnabled(not simulator)
        self.browse.setEnabled(not simulator)
        problem = self.backend_problem()
        error = self.errors["settings_path"]
        error.setText(f"{theme.PROBLEM_SIGN} {problem}")
        error.setVisible(bool(problem))
        self.backend_changed.emit(self.backend())

    def _choose_settings(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Hardware settings file", "",
                                              "Settings (*.toml);;All files (*)")
        if path:
            self.settings_path.setText(path)
