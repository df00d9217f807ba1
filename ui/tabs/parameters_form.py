"""The Parameters tab's form (a part of ui.tabs.parameters.ParametersTab): the exercise,
the patient and the control, each field built in the units a therapist reads (cm, s, kg,
°, %) with the limits core.trial.TrialParameters accepts, given a place for its problem,
and converted to SI and back; the numbers still being typed taken before Build and Start
(`commit_edits`), and the fields each shape and mode uses.
"""

from __future__ import annotations

import math

from PySide6.QtCore import QSignalBlocker
from PySide6.QtWidgets import (
    QAbstractSpinBox,
    QCheckBox,
    QDoubleSpinBox,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QWidget,
)

from app.learning.library import learned_label
from core.arm import BODY_MASS_RANGE_KG, FOREARM_RANGE_M, UPPER_ARM_RANGE_M
from core.trajectory import SHAPES, TIMINGS
from core.trial import (
    ASSIST_MODES,
    CONTROLLERS,
    DURATION_DECIMALS,
    DURATION_RANGE_S,
    POSITION_RANGE_M,
    RADIUS_RANGE_M,
    REPETITIONS_RANGE,
    SIDES,
    TARGETS_RANGE,
    TOLERANCE_RANGE_RAD,
    TrialParameters,
)
from ui.fields import ComboBox, SpinBox, commit_all
from ui.tabs.parameters_devices import CameraChoice, RobotChoice
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
from ui.views.assist_words import level_words
from ui.views.reach import CM

TASK_FIELDS = ("shape", "radius_m", "n_targets", "duration_s", "repetitions", "timing",
               "clockwise", "assist", "controller", "gains")
"""The fields an assessment task's protocol fixes (core.assessment.protocol.Protocol)."""
HIDDEN_FIELDS = ("game", "target_radius_m", "channel_half_width_m", "time_allowed_s",
                 "n_distractors", "staircase", "neglect_side")
"""The trial's fields the form has no place for: a game and its difficulty (a session
plan's game round, its rung from the staircase: ui.window.plan sets it here, then Build)
and the neglect layout. Kept from the parameters set while every field the form shows is
as they came (so a round runs as the game it is), dropped at the first field changed by
hand: nothing is played that the form does not show."""


class ParametersForm:
    """The form's fields and their values (a part of ParametersTab: the same widget)."""

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
        self.duration = spin(*DURATION_RANGE_S, DURATION_DECIMALS, " s", 0.5)
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
        self.rows.add(form, "Centre", self._pair("Centre", self.centre_x, self.centre_y), "centre")
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
        self.rows.add(form, "Shoulder", self._pair("Shoulder", self.shoulder_x,
                                                             self.shoulder_y), "shoulder")

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

    def _pair(self, label: str, x: QDoubleSpinBox, y: QDoubleSpinBox) -> QWidget:
        box = QWidget()
        row = QHBoxLayout(box)
        row.setContentsMargins(0, 0, 0, 0)
        for name, field in (("x", x), ("y", y)):
            field.setAccessibleName(f"{label} {name}")  # names it in a refusal
            row.addWidget(QLabel(name))
            row.addWidget(field, 1)
        return box

    def _spin_boxes(self) -> tuple[QAbstractSpinBox, ...]:
        return (self.radius, self.duration, self.centre_x, self.centre_y, self.body_mass,
                self.upper_arm, self.forearm, self.shoulder_x, self.shoulder_y,
                self.tolerance, self.n_targets, self.repetitions, self.assistance)

    def commit_edits(self) -> list[str]:
        """Take a number still being typed (the field shows it, its value is not yet
        changed): Build and Start call this first, so what is on the screen counts. A
        number the field cannot take is refused in words (ui.fields): the refusals are
        returned, and Build and Start do not go on with the field's old value unseen."""
        return commit_all(self._spin_boxes())

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
        self._level_follows_mode()

    def _level_follows_mode(self) -> None:
        """In the transparent mode the field shows 0 %, the level that runs (TrialParameters
        makes it 0 whatever the field holds): a greyed "60 %" beside "No help in this mode"
        was what the therapist read while the robot, its file and the registry said 0. The
        level the field held, or one set while transparent (a proposal, a plan's block), is
        kept and shown again when another mode is chosen. Quietly: the level that runs does
        not change (no live change is sent, no Build is asked)."""
        kept = getattr(self, "_level_kept", None)
        with QSignalBlocker(self.assistance):
            if self.assist.currentData() == "transparent":
                if self.assistance.value() != 0:
                    self._level_kept = self.assistance.value()
                    self.assistance.setValue(0)
            elif kept is not None:
                self._level_kept = None
                self.assistance.setValue(kept)

    # -- values -------------------------------------------------------------------
    def _values(self) -> dict:
        values = self._shown_values()
        kept, as_set = getattr(self, "_hidden", ({}, None))
        if values == as_set:
            values.update(kept)
        return values

    def _shown_values(self) -> dict:
        """The fields the form shows, and the assessment task they hold."""
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
        shown = self._shown_values()
        self._hidden = ({name: getattr(parameters, name) for name in HIDDEN_FIELDS}, shown)
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

    def _enable_for_shape(self) -> None:
        shape = self.shape.currentData()
        self.n_targets.setEnabled(shape == "targets")
        self.clockwise.setEnabled(shape in ("d", "circle"))
        # what "centre" means depends on the shape: the thesis's form names the D's
        # straight line (Appendix A)
        label = self.labels.get("centre")
        if label is not None:
            label.setText(CENTRE_LABELS.get(shape, "Centre"))
