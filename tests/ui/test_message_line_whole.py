"""Trying the window as a newcomer: a plan's refusal naming a block out of reach (with
where the blocks are placed) was cut at the event line's two lines, its last line and what
to do not on screen, with nothing saying so. The whole reason is reachable: on screen
whole (set smaller), or its beginning with a word that there is more, and a click shows it
all; the tooltip is the whole text either way."""

from __future__ import annotations

import pytest
from PySide6.QtCore import QRect, Qt
from PySide6.QtGui import QFontMetrics
from PySide6.QtWidgets import QApplication, QPlainTextEdit, QPushButton

from tests.ui.session import click, open_window, register_patient
from ui import theme
from ui.window.message_text import MORE


def _painted_fits(label) -> bool:
    """What the label paints fits its fixed lines and their width, in its font."""
    shown = label.shown_text() if hasattr(label, "shown_text") else label.text()
    box = QFontMetrics(label.font()).boundingRect(
        QRect(0, 0, label.contentsRect().width(), 100_000), int(Qt.TextFlag.TextWordWrap),
        shown)
    return (box.height() <= label.contentsRect().height()
            and box.width() <= label.contentsRect().width())


@pytest.fixture
def scale():
    yield
    theme.apply_theme(QApplication.instance(), 1.0)


@pytest.mark.parametrize("font_scale", [1.0, 1.5])
def test_a_plans_refusal_reads_whole_in_the_event_line(qtbot, tmp_path, monkeypatch, scale,
                                                       font_scale):
    theme.apply_theme(QApplication.instance(), font_scale)
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        win.resize(1366, 738)
        qtbot.waitExposed(win)
        register_patient(qtbot, win)
        # the patient's plan is read on the job thread, Copy greyed meanwhile (ui.window.plan)
        qtbot.waitUntil(lambda: not win.plan_waiting(), timeout=20000)
        win.tabs.setCurrentWidget(win.plan_tab)
        index = win.plan_tab.templates.findData("endurance")
        win.plan_tab.templates.setCurrentIndex(index)
        click(qtbot, win.plan_tab.copy_button)
        qtbot.waitUntil(lambda: win.stored_plan is not None and not win.plan_waiting(),
                        timeout=20000)
        p = win.parameters_tab
        p.shoulder_x.setValue(-3.0)  # the form's D reachable, the plan's figure eight not
        p.shoulder_y.setValue(68.0)
        p.refresh()
        assert not p.problem()
        win.start_plan()
        whole = win.messages.last.text
        assert whole.startswith("Start plan refused: block 3")
        assert len(whole) > 300
        label = win.message
        assert label.toolTip() == whole
        assert _painted_fits(label)
        if label.is_cut():  # its beginning and how to read the rest
            assert label.shown_text().endswith(MORE)
            qtbot.mouseClick(label, Qt.MouseButton.LeftButton)
            shown = win.whole_dialog.findChild(QPlainTextEdit).toPlainText()
            assert shown == whole
        else:  # whole on screen, in a font no smaller than the banner's smallest
            assert label.shown_text().endswith(whole)
    finally:
        win.close()


def test_a_text_too_long_even_set_small_says_there_is_more_and_shows_it_all_on_a_click(
        qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        win.resize(1366, 738)
        qtbot.waitExposed(win)
        path = "/srv/clinic/" + "/".join(f"folder{k}" for k in range(90)) + "/trial.h5"
        whole = (f"Recording problem: the trial's file {path} could not be written: the "
                 "disk is full. Free space on the data folder's disk, then press Build and "
                 "Start again; the trial so far is kept in the registry as recording lost.")
        win.say(whole, problem=True)
        label = win.message
        assert label.toolTip() == whole
        assert label.is_cut()
        assert label.shown_text().endswith(MORE)
        assert label.shown_text().startswith("⚠ Recording problem: the trial's file")
        assert "/srv/clinic/folder0/" in label.shown_text()  # a long path cut inside it
        # cut anyway: as large as the window's words, not in the smallest type
        assert label.font().pointSizeF() == win.notices.font().pointSizeF()
        assert _painted_fits(label)
        qtbot.mouseClick(label, Qt.MouseButton.LeftButton)
        qtbot.waitUntil(lambda: win.whole_dialog.isVisible(), timeout=5000)
        assert win.whole_dialog.findChild(QPlainTextEdit).toPlainText() == whole
        # closed by a button: Esc, the way out of a dialog elsewhere, is the emergency stop
        close = win.whole_dialog.findChild(QPushButton)
        assert close.text() == "Close"
        qtbot.mouseClick(close, Qt.MouseButton.LeftButton)
        assert not win.whole_dialog.isVisible()
        # a short text after it: whole again, nothing to click
        win.say("Trial built. Start when ready.")
        assert not label.is_cut()
        assert label.shown_text() == "Trial built. Start when ready."
        assert _painted_fits(label)
    finally:
        win.close()


def test_a_fault_too_long_for_the_banner_shows_it_all_on_a_click(qtbot, tmp_path,
                                                                 monkeypatch):
    from device.loop.states import State
    from device.safety.faults import Fault

    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        win.resize(1366, 738)
        qtbot.waitExposed(win)
        problem = "it is at " + ", ".join(f"({k}.0, {k}.5) cm" for k in range(60))
        text = Fault.WORKSPACE.banner({"problem": problem})
        win._on_fault(int(Fault.WORKSPACE), text, {})
        win._on_state(int(State.FAULTED), text)
        label = win.banner_text
        assert label.toolTip() == text
        assert label.is_cut()
        assert _painted_fits(label)
        qtbot.mouseClick(label, Qt.MouseButton.LeftButton)
        assert win.whole_dialog.findChild(QPlainTextEdit).toPlainText() == text
    finally:
        win.close()
