"""The Parameters tab's fields: the names each choice shows, the spin boxes and combo
boxes they are made of, and the lists of models the controller and the patient's force
may choose from (the data folder's models/, re-read when the tab is shown)."""

from __future__ import annotations

from PySide6.QtWidgets import QComboBox, QDoubleSpinBox, QSizePolicy

from app.learning.library import learned_label
from core.trial import CONTROLLERS
from ui.fields import ComboBox, DoubleSpinBox

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
ASSIST_NAMES = {"as-needed": "As needed: the patient leads",
                "thesis": "Thesis (Fig. 3.6): fixed clock",
                "transparent": "Transparent: no help, the robot lightened"}
SIDE_NAMES = {"right": "Right arm", "left": "Left arm"}


CENTRE_LABELS = {
    "d": "Centre of the D's straight line",
    "circle": "Centre of the circle",
    "reach": "Start of the reach",
    "targets": "Home, at the centre of the targets",
    "figure8": "Centre of the figure eight",
}
"""The Centre field's label for each shape: the point the path is placed by."""


def spin(low: float, high: float, decimals: int, suffix: str, step: float) -> QDoubleSpinBox:
    box = DoubleSpinBox()
    box.setRange(low, high)
    box.setDecimals(decimals)
    box.setSuffix(suffix)
    box.setSingleStep(step)
    box.setKeyboardTracking(False)  # a number counts when committed, not per keystroke
    box.setAccelerated(True)
    box.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
    return box


def controller_fields(key: str) -> dict:
    """The trial's controller fields for the controller choice's data."""
    if key.startswith(LEARNED):
        return {"controller": "ctpid", "learned_model": key[len(LEARNED):]}
    return {"controller": key}


def combo(names: dict[str, str], keys: tuple[str, ...]) -> QComboBox:
    box = ComboBox()
    for key in keys:
        box.addItem(names.get(key, key), key)
    return box


def offer_controllers(box: QComboBox, names) -> None:
    """The analytic controllers, then "CT-PID (learned: <name>)" for each model name; the
    current choice is kept (added if it is a model no longer among them, so that Build
    can say so)."""
    current = box.currentData()
    keys = [*CONTROLLERS, *(LEARNED + n for n in names)]
    if current is not None and current not in keys:
        keys.append(current)
    box.clear()
    for key in keys:
        label = (learned_label(key[len(LEARNED):]) if key.startswith(LEARNED)
                 else CONTROLLER_NAMES.get(key, key))
        box.addItem(label, key)
    if current is not None:
        box.setCurrentIndex(box.findData(current))


def offer_force_sources(box: QComboBox, names) -> None:
    """The force sensor, then "EMG model: <name>" for each approved EMG model; the
    current choice is kept (added if no longer among them, so that Build says so)."""
    current = box.currentData() or ""
    keys = ["", *names]
    if current not in keys:
        keys.append(current)
    box.clear()
    for key in keys:
        box.addItem(emg_label(key) if key else SENSOR_LABEL, key)
    box.setCurrentIndex(box.findData(current))
