"""The robot buttons (Fig. A.3), shown on every tab: Build, Connect, Disconnect, Start (green),
Stop (red), Save data, and a large emergency stop.

A button is enabled only when the loop's state allows its command, so a tired therapist
cannot press them out of order; the loop refuses out-of-order commands anyway.
"""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QKeySequence
from PySide6.QtWidgets import QHBoxLayout, QPushButton, QSizePolicy, QWidget

from device.loop.states import State

# (name, label, key) in the order of a session
BUTTONS = (
    ("build", "Build", "F2"),
    ("connect", "Connect", "F3"),
    ("disconnect", "Disconnect", "F4"),
    ("start", "Start", "F5"),
    ("stop", "Stop", "F6"),
    ("save", "Save data", "F7"),
)

# A disabled Start or Stop looks like every other disabled button: plain, greyed, not bold.
START_STYLE = ("QPushButton:enabled { background: #009E73; color: white; font-weight: bold; }"
               " QPushButton:disabled { font-weight: normal; }")
STOP_STYLE = ("QPushButton:enabled { background: #D55E00; color: white; font-weight: bold; }"
              " QPushButton:disabled { font-weight: normal; }")
ESTOP_STYLE = (
    "QPushButton { background: #C00000; color: white; font-weight: bold; font-size: 15pt;"
    " border: 3px solid #600000; border-radius: 8px; padding: 6px 18px; }"
    "QPushButton:pressed { background: #800000; }"
)


class RobotBar(QWidget):
    """Emits one signal per button; `update_for(...)` enables what the state allows."""

    build_clicked = Signal()
    connect_clicked = Signal()
    disconnect_clicked = Signal()
    start_clicked = Signal()
    stop_clicked = Signal()
    save_clicked = Signal()
    estop_clicked = Signal()

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        layout = QHBoxLayout(self)
        layout.setContentsMargins(6, 4, 6, 4)
        self.buttons: dict[str, QPushButton] = {}
        for name, label, key in BUTTONS:
            button = QPushButton(f"{label}  ({key})")
            button.setObjectName(f"robot_{name}")
            button.setShortcut(QKeySequence(key))
            button.setMinimumHeight(44)
            button.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
            button.clicked.connect(getattr(self, f"{name}_clicked").emit)
            layout.addWidget(button)
            self.buttons[name] = button
        self.buttons["start"].setStyleSheet(START_STYLE)
        self.buttons["stop"].setStyleSheet(STOP_STYLE)
        layout.addSpacing(24)
        self.estop = QPushButton("EMERGENCY STOP\n(Esc / Space)")
        self.estop.setObjectName("robot_estop")
        self.estop.setStyleSheet(ESTOP_STYLE)
        self.estop.setMinimumHeight(64)
        self.estop.setMinimumWidth(220)
        self.estop.setFocusPolicy(Qt.FocusPolicy.NoFocus)
        self.estop.pressed.connect(self.estop_clicked.emit)
        layout.addWidget(self.estop)
        self.update_for(State.IDLE, can_build=False, can_start=False, can_save=False)

    def update_for(self, state: State, *, can_build: bool, can_start: bool,
                   can_save: bool, start_needs: str = "") -> None:
        """Enable each button only where its command is allowed in `state`; `start_needs`
        says what Start still needs when only that keeps it greyed (its tooltip)."""
        enabled = {
            "build": can_build and state in (State.IDLE, State.BUILT, State.CONNECTED),
            "connect": state == State.BUILT,
            "disconnect": state in (State.CONNECTED, State.FAULTED),
            "start": can_start and state == State.CONNECTED,
            "stop": state == State.RUNNING,
            "save": can_save and state not in (State.RUNNING, State.STOPPING),
        }
        for name, on in enabled.items():
            self.buttons[name].setEnabled(on)
        start = self.buttons["start"]
        start.setToolTip(f"Start needs {start_needs}" if start_needs and not enabled["start"]
                         else "Start the trial (F5)")
