"""Clinic exploration 2 #3: the workspace fault's banner was cut ("…then clear the") and
gave the handle's place in metres where the rest of the window uses cm: it reads whole, in
cm, on a laptop's screen at the usual and at a large font, the whole text still its
tooltip."""

from __future__ import annotations

import pytest
from PySide6.QtCore import QRect, Qt
from PySide6.QtGui import QFontMetrics
from PySide6.QtWidgets import QApplication

from core.robot import RobotModel
from device.loop.states import State
from device.safety.faults import Fault
from tests.ui.session import open_window
from ui import theme

WORKSPACE = Fault.WORKSPACE.banner({"problem": (
    "it is at (-45.1, 37.2) cm, outside the exercise area x -45 to -15 cm, y 15 to 45 cm")})
LINKS = Fault.WORKSPACE.banner({"problem": RobotModel().limit_problem(0.3, 0.29)})
"""The longest workspace fault: the robot's joints at their limits (core.robot)."""


@pytest.mark.parametrize("text", [WORKSPACE, LINKS])
@pytest.mark.parametrize(("scale", "size"), [(1.0, (1366, 738)), (1.5, (1366, 738)),
                                             (1.5, (1920, 1050))])
def test_the_workspace_fault_reads_whole_in_the_banner(qtbot, tmp_path, monkeypatch, scale,
                                                        size, text):
    theme.apply_theme(QApplication.instance(), scale)
    try:
        win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
        win.resize(*size)
        qtbot.waitExposed(win)
        win._on_fault(int(Fault.WORKSPACE), text, {})
        win._on_state(int(State.FAULTED), text)
        qtbot.wait(20)
        label = win.banner_text
        assert win.notices.currentWidget() is win.banner
        assert label.text().endswith("then clear the fault")
        assert label.toolTip() == text
        box = QFontMetrics(label.font()).boundingRect(
            QRect(0, 0, label.contentsRect().width(), 10_000), Qt.TextFlag.TextWordWrap,
            label.text())
        assert box.height() <= label.contentsRect().height(), (box, label.contentsRect())
        assert label.font().bold()
        win.close()
    finally:
        theme.apply_theme(QApplication.instance(), 1.0)


@pytest.mark.parametrize("answer_first", [True, False])
def test_fault_cleared_is_said_whichever_of_the_answer_and_the_state_comes_first(
        qtbot, tmp_path, monkeypatch, answer_first):
    """After Clear fault with the robot connected, the message line stayed empty: the
    loop's answer came while the window still showed FAULTED, and "Fault cleared." was
    said only when the state had changed first."""
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        win._on_state(int(State.CONNECTED), "connected to the simulator")
        win._on_fault(int(Fault.ESTOP), "emergency stop", {})
        win._on_state(int(State.FAULTED), "emergency stop")
        assert win.notices.currentWidget() is win.banner
        steps = [lambda: win._clear_fault_answered(True, ""),
                 lambda: win._on_state(int(State.CONNECTED), "fault cleared")]
        for step in steps if answer_first else steps[::-1]:
            step()
        assert win.notices.currentWidget() is win.message
        assert win.message.text() == "Fault cleared.", win.message.text()
    finally:
        win.close()
