"""The Parameters tab's two device choices: the camera that films the arm (pose
estimation) and the robot the trial runs on (the simulator with a virtual patient, or the
hardware with its settings file).

The robot chosen is part of what Build takes: a change after Build makes the built trial
stale like any field of the form (ui.window.trial.BuiltSetup).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import (
    QButtonGroup,
    QCheckBox,
    QFileDialog,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
    QRadioButton,
    QWidget,
)

from device.sim.patient_parameters import (
    DEFAULT_EFFORT,
    DEFAULT_SELECTIVITY_LOSS,
    PATIENT_KINDS,
    TREMOR_BAND_HZ,
    WrongWay,
)
from device.sim.seeds import SEEDS
from ui import theme
from ui.fields import ComboBox, SpinBox
from ui.tabs.form_rows import FormRows

PATIENT_NAMES = {"healthy": "Healthy", "weak": "Weak", "spastic": "Spastic", "tremor": "Tremor",
                 "passive": "Passive (no effort)", "wrong_way": "Pushes the wrong way at times"}
PATIENT_DESCRIPTIONS = {
    "healthy": "A healthy arm that follows the path and pushes along it.",
    "weak": f"An arm after a stroke: {DEFAULT_EFFORT['weak'] * 100:.0f} % of a healthy arm's "
            f"effort, {DEFAULT_SELECTIVITY_LOSS['weak'] * 100:.0f} % of its selective joint "
            "control lost (the shoulder and the elbow tend to move together), its own "
            "movements made of several smaller ones.",
    "spastic": "A healthy effort against a resistance that grows with the joints' speed.",
    "tremor": f"A healthy effort with a {TREMOR_BAND_HZ[0]:g}–{TREMOR_BAND_HZ[1]:g} Hz tremor "
              "at both joints.",
    "passive": "A relaxed arm that makes no effort: the robot does all the moving.",
    "wrong_way": f"A healthy effort that pushes against the path "
                 f"{WrongWay().fraction * 100:.0f} % of the time.",
}
"""What each virtual patient is (device.sim.patients), as the patient list's tooltips;
its numbers are the simulator's own defaults."""
SIMULATOR = "simulator"
HARDWARE = "hardware"


@dataclass(frozen=True, slots=True)
class BackendChoice:
    """The robot the trial runs on: the simulator with a virtual patient, or the real
    robot with its hardware settings file (device/hardware/settings.py reads it)."""

    name: str  # SIMULATOR or HARDWARE
    patient_kind: str | None = None
    settings_path: Path | None = None
    seed: int | None = None
    """The simulator's seed, fixed for every trial; None draws a new one for each trial
    (device.loop.messages.BackendConfig.seed), so that a course of simulated trials varies
    as people do."""


class CameraChoice(QGroupBox):
    """With or without a camera, and which one (a number or a video file)."""

    changed = Signal(object)  # the camera source, or None without camera

    def __init__(self, rows: FormRows) -> None:
        super().__init__("Pose estimation")
        self.with_camera = QRadioButton("With camera")
        self.without_camera = QRadioButton("Without camera")
        self.without_camera.setChecked(True)
        self._mode = QButtonGroup(self)
        self._mode.addButton(self.with_camera)
        self._mode.addButton(self.without_camera)
        self.source_edit = QLineEdit("0")
        self.source_edit.setPlaceholderText("0 for the first camera, or a video file")
        self.source_edit.setAccessibleName("Camera number or video file")
        form = rows.form(self)
        modes = QHBoxLayout()
        modes.addWidget(self.with_camera)
        modes.addWidget(self.without_camera)
        modes.addStretch(1)
        form.addRow(modes)
        self.error = rows.add(form, "Camera", self.source_edit, "camera")
        self.hint = theme.set_role(QLabel(""), "caption")
        self.hint.setWordWrap(True)
        form.addRow(self.hint)
        self._held = False  # while a trial films (hold)
        self.with_camera.toggled.connect(self._edited)
        self.source_edit.textChanged.connect(self._edited)

    def hold(self, filming: bool) -> None:
        """Keep the choice as it is while a trial is recorded: a camera changed then stopped
        the trial's video in the middle (its file cut short, nothing in the trial saying
        so), and one chosen then filmed on screen what the trial did not record."""
        if filming == self._held:
            return
        self._held = filming
        self.setEnabled(not filming)
        self._show_hint()

    def source(self) -> int | str | None:
        """The camera number or video file in camera mode; None without camera."""
        if not self.with_camera.isChecked():
            return None
        text = self.source_edit.text().strip()
        if text.isdigit():
            return int(text)
        return text or None

    def _show_hint(self) -> None:
        camera = self.with_camera.isChecked()
        self.hint.setText(
            "The camera stays as it is until this trial ends: its video is the trial's."
            if self._held else
            "The camera films the arm; its video is saved beside the trial." if camera else
            "Without a camera the joint angles come from the shoulder position below: "
            "the shoulder must stay still.")

    def _edited(self) -> None:
        camera = self.with_camera.isChecked()
        self.source_edit.setEnabled(camera)
        self._show_hint()
        if camera and self.source() is None:
            self.error.setText(f"{theme.PROBLEM_SIGN} Give the camera's number (0 for the "
                               "first camera) or a video file.")
            self.error.show()
        else:
            self.error.hide()
        self.changed.emit(self.source())


class RobotChoice(QGroupBox):
    """The simulator with a virtual patient, or the robot hardware with its settings
    file."""

    changed = Signal(object)  # BackendChoice

    def __init__(self, rows: FormRows) -> None:
        super().__init__("Robot")
        self.simulator = QRadioButton("Simulator")
        self.hardware = QRadioButton("Robot hardware")
        self.simulator.setChecked(True)
        self._mode = QButtonGroup(self)
        self._mode.addButton(self.simulator)
        self._mode.addButton(self.hardware)
        self.patient_kind = ComboBox()
        for index, kind in enumerate(PATIENT_KINDS):
            self.patient_kind.addItem(PATIENT_NAMES.get(kind, kind), kind)
            self.patient_kind.setItemData(index, PATIENT_DESCRIPTIONS.get(kind, ""),
                                          Qt.ItemDataRole.ToolTipRole)
        # the simulator's seed: a new one each trial unless the therapist fixes one
        self.fix_seed = QCheckBox("Same each trial:")
        self.fix_seed.setToolTip("The virtual patient and the simulated robot vary from trial "
                                 "to trial as people do (a new seed each trial). Tick to run "
                                 "every trial with this seed, e.g. to show one trial again.")
        self.seed = SpinBox()
        self.seed.setRange(0, SEEDS - 1)  # the seeds the simulator draws
        self.seed.setKeyboardTracking(False)
        self.seed.setAccessibleName("Simulator's seed")
        seed_row = QHBoxLayout()
        seed_row.setContentsMargins(0, 0, 0, 0)
        seed_row.addWidget(self.fix_seed)
        seed_row.addWidget(self.seed, 1)
        seed_box = QWidget()
        seed_box.setLayout(seed_row)
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
        form = rows.form(self)
        modes = QHBoxLayout()
        modes.addWidget(self.simulator)
        modes.addWidget(self.hardware)
        modes.addStretch(1)
        form.addRow(modes)
        rows.add(form, "Virtual patient", self.patient_kind, "patient_kind")
        rows.add(form, "Simulator's seed", seed_box, "seed")
        self.error = rows.add(form, "Settings file", path_box, "settings_path")
        self.settings_folder = ""
        """Where the settings file dialog opens (the data folder: ui.main_window)."""
        self.simulator.toggled.connect(self._edited)
        self.patient_kind.currentIndexChanged.connect(self._edited)
        self.fix_seed.toggled.connect(self._edited)
        self.seed.valueChanged.connect(self._edited)
        self.settings_path.textChanged.connect(self._edited)

    def set_choice(self, choice: BackendChoice) -> None:
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
            self.fix_seed.setChecked(choice.seed is not None)
            if choice.seed is not None:
                self.seed.setValue(choice.seed)
        self._edited()

    def choice(self) -> BackendChoice:
        if self.simulator.isChecked():
            return BackendChoice(SIMULATOR, patient_kind=self.patient_kind.currentData(),
                                 seed=self.seed.value() if self.fix_seed.isChecked() else None)
        text = self.settings_path.text().strip()
        return BackendChoice(HARDWARE, settings_path=Path(text) if text else None)

    def problem(self) -> str:
        choice = self.choice()
        if choice.name == HARDWARE and choice.settings_path is None:
            return "Choose the robot's hardware settings file."
        return ""

    def _edited(self) -> None:
        simulator = self.simulator.isChecked()
        self.patient_kind.setEnabled(simulator)
        self.fix_seed.setEnabled(simulator)
        self.seed.setEnabled(simulator and self.fix_seed.isChecked())
        self.settings_path.setEnabled(not simulator)
        self.browse.setEnabled(not simulator)
        problem = self.problem()
        self.error.setText(f"{theme.PROBLEM_SIGN} {problem}")
        self.error.setVisible(bool(problem))
        self.changed.emit(self.choice())

    def _choose_settings(self) -> None:
        current = self.settings_path.text().strip()
        start = str(Path(current).parent) if current else self.settings_folder
        path, _ = QFileDialog.getOpenFileName(self, "Hardware settings file", start,
                                              "Settings (*.toml);;All files (*)")
        if path:
            self.settings_path.setText(path)
