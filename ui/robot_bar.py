"""The robot buttons (Fig. A.3), shown on every tab: Build, Connect, Disconnect, Start (green),
Stop (red), Save data, and a large emergency stop; under the buttons, a line saying what
holds the next step (a greyed Build or Start says why on every tab, not only in its
tooltip), whole: it takes a second line when its words need one.

A button is enabled only when the loop's state and the window allow its command
(ui.views.readiness), so a tired therapist cannot press them out of order; the loop
refuses out-of-order commands anyway.

Each button's key is on a second line, so the bar fits a 1366-pixel screen at font scale
1.5; the emergency stop is at least as wide as its words in its own font (at scale 1.5
it read "MERGENCY STO").
"""

from __future__ import annotations

from PySide6.QtCore import QRect, Qt, Signal
from PySide6.QtGui import QFont, QFontMetrics, QKeySequence
from PySide6.QtWidgets import (
    QHBoxLayout,
    QPushButton,
    QSizePolicy,
    QVBoxLayout,
    QWidget,
)

from device.loop.states import State
from ui import theme
from ui.fitting_label import FittingLabel
from ui.views.readiness import Readiness, readiness

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
REGISTERING_WORDS = "Registering…"
"""Start's words while its trial is being registered (ui.window.start)."""
ESTOP_WORDS = ("EMERGENCY STOP", "(Esc / Space)")
ESTOP_POINTS = 15.0
"""The e-stop's words at font scale 1 (pt); they grow with the scale."""
ESTOP_PADDING_PX = 18


def _estop_style(point_size: float) -> str:
    return (
        "QPushButton { background: #C00000; color: white; font-weight: bold;"
        f" font-size: {point_size:.1f}pt;"
        f" border: 3px solid #600000; border-radius: 8px; padding: 6px {ESTOP_PADDING_PX}px; }}"
        "QPushButton:pressed { background: #800000; }"
    )


class RobotBar(QWidget):
    """Emits one signal per button; `show_readiness(...)` enables what is allowed and says
    why the rest waits."""

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
        buttons_row = QHBoxLayout()
        buttons_row.setContentsMargins(0, 0, 0, 0)
        self.buttons: dict[str, QPushButton] = {}
        self._labels: dict[str, str] = {}
        self._keys: dict[str, str] = {}
        for name, label, key in BUTTONS:
            self._keys[name] = key
            button = QPushButton(f"{label}\n{key}")
            button.setObjectName(f"robot_{name}")
            button.setShortcut(QKeySequence(key))
            button.setMinimumHeight(44)
            button.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
            button.clicked.connect(getattr(self, f"{name}_clicked").emit)
            buttons_row.addWidget(button)
            self.buttons[name] = button
            self._labels[name] = f"{label} ({key})"
        self.buttons["start"].setStyleSheet(START_STYLE)
        self.buttons["stop"].setStyleSheet(STOP_STYLE)
        # what holds the next step, on every tab, whole (a reach problem's words at font
        # scale 1.5 need two lines: cut with "…", they lost what to do)
        self.why = theme.set_role(WholeLine(), "problem")
        self.why.setObjectName("robot_why")
        column = QVBoxLayout()
        column.setContentsMargins(0, 0, 0, 0)
        column.setSpacing(2)
        column.addLayout(buttons_row)
        column.addWidget(self.why)
        layout.addLayout(column, 1)
        layout.addSpacing(24)
        self.estop = QPushButton("\n".join(ESTOP_WORDS))
        self.estop.setObjectName("robot_estop")
        self.estop.setMinimumHeight(64)
        self.estop.setFocusPolicy(Qt.FocusPolicy.NoFocus)
        self.estop.pressed.connect(self.estop_clicked.emit)
        self.fit_estop()
        layout.addWidget(self.estop)
        self.readiness: Readiness | None = None
        self.show_readiness(readiness(State.IDLE, form_problem="", registered=False,
                                      built=False, stale=False, held="", unsaved=False))

    def fit_estop(self) -> None:
        """The e-stop's words in its font at the current font scale, never cut: its
        minimum width is theirs plus its padding and border."""
        points = ESTOP_POINTS * theme.font_scale()
        self.estop.setStyleSheet(_estop_style(points))
        font = QFont(self.estop.font())
        font.setPointSizeF(points)
        font.setBold(True)
        metrics = QFontMetrics(font)
        words = max(metrics.horizontalAdvance(line) for line in ESTOP_WORDS)
        self.estop.setMinimumWidth(words + 2 * ESTOP_PADDING_PX + 6 + 8)
        self.estop.setMinimumHeight(max(64, 2 * metrics.lineSpacing() + 12 + 6))

    def show_readiness(self, ready: Readiness) -> None:
        """Enable the buttons `ready` allows; a greyed one's tooltip says why, and the line
        under them says what holds the next step."""
        self.readiness = ready
        for name, button in self.buttons.items():
            on = ready.enabled[name]
            button.setEnabled(on)
            button.setToolTip(ready.tooltips.get(name) or self._labels[name])
        start, key = self.buttons["start"], self._keys["start"]
        words = f"{REGISTERING_WORDS if ready.registering else 'Start'}\n{key}"
        if start.text() != words:
            start.setText(words)
            start.setShortcut(QKeySequence(key))  # setText sets the text's own (none)
        self.why.set_whole(f"{theme.PROBLEM_SIGN} {ready.line}" if ready.line else "")
        self.why.setToolTip(ready.line)


class WholeLine(FittingLabel):
    """Words that are never cut: one line tall while they fit in one (or say nothing, so
    the bar does not jump as they come and go), as many lines as they need when they do
    not. `whole` is the text shown."""

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.whole = ""
        self.setWordWrap(True)
        # as wide as the buttons above it, never wider: the words wrap instead
        self.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self._fit()

    def set_whole(self, text: str) -> None:
        self.whole = text
        self.setText(text)
        self._fit()

    def lines_needed(self) -> int:
        """Lines the words take at the label's width (the problem role is bold)."""
        metrics = QFontMetrics(_bold(self.font()))
        if not self.whole:
            return 1
        width = max(self.contentsRect().width(), 1)
        box = metrics.boundingRect(QRect(0, 0, width, 100_000),
                                   int(Qt.TextFlag.TextWordWrap), self.whole)
        return max(1, round(box.height() / metrics.lineSpacing()))

    def _fit(self) -> None:
        metrics = QFontMetrics(_bold(self.font()))
        margins = self.contentsMargins()
        height = self.lines_needed() * metrics.lineSpacing() + 2 + margins.top() \
            + margins.bottom()
        if self.height() != height or self.minimumHeight() != height:
            self.setFixedHeight(height)


def _bold(font: QFont) -> QFont:
    font = QFont(font)
    font.setBold(True)
    return font
