"""The window's words: the event line above the tabs (what just happened, while it
applies), its history (everything said today, with the time) and the status bar (the
robot's state, the robot, the trial, the loop's health).

The event line and the fault banner have a fixed number of lines (`fixed_lines`), so no
message can grow the window and push the emergency stop off the screen; a longer text is
set smaller, and one longer still says that there is more and shows it whole when clicked
(ui.window.message_text); the whole text is also the tooltip and in the history. What
stays current and when it goes is `ui.views.messages`; the loop's health in words is
`ui.views.loop_health`.
"""

from __future__ import annotations

import logging

from PySide6.QtCore import Qt
from PySide6.QtGui import QFont, QFontMetrics
from PySide6.QtWidgets import (
    QDialog,
    QHBoxLayout,
    QLabel,
    QPlainTextEdit,
    QPushButton,
    QSizePolicy,
    QStackedWidget,
    QVBoxLayout,
    QWidget,
)

from app.trials.finalize import finish_interrupted
from ui import theme
from ui.elided_label import ElidedLabel
from ui.tabs.parameters import HARDWARE
from ui.window.message_text import WholeText

log = logging.getLogger("ui.main_window")  # the clinic's day log names the window

MESSAGE_LINES = 2
"""Lines of text the event line and the fault banner have: fixed, so that no message can
grow the window and push the emergency stop off the screen (the full text a click away, the
tooltip and in the history)."""


class MessageLine:
    """The event line, its history and the status bar (a part of MainWindow)."""

    def _build_message_row(self, banner: QWidget) -> QHBoxLayout:
        """The event line and, in its place while something is latched, the fault banner
        (a fault takes the event line under it away): one place of fixed height, so that
        neither moves the tabs or the robot buttons under the mouse, and no blank band
        is kept for a banner that is not there (it took 60 px of a laptop's 768)."""
        self.message = WholeText(bold=False)
        self.message.setObjectName("console_message")
        self.message.clicked.connect(lambda: self.show_whole(self.message.toolTip()))
        self.banner_text.clicked.connect(lambda: self.show_whole(self.banner_text.toolTip()))
        fixed_lines(self.message, MESSAGE_LINES)
        self.message.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self.notices = QStackedWidget()
        self.notices.addWidget(self.message)
        self.notices.addWidget(banner)
        self.notices.setFixedHeight(max(self.message.minimumHeight(), banner.minimumHeight()))
        self.history_button = QPushButton("History…")
        self.history_button.setObjectName("message_history")
        self.history_button.setToolTip("Everything the console said today, with its time")
        self.history_button.clicked.connect(self.show_history)
        message_row = QHBoxLayout()
        message_row.setContentsMargins(0, 0, 0, 0)
        message_row.addWidget(self.notices, 1)
        message_row.addWidget(self.history_button)
        return message_row

    def _build_status_bar(self) -> None:
        self.state_label = QLabel("Idle")
        # the robot's words give way (cut, whole in the tooltip; they are in the Parameters
        # tab too) so that the trial's ("session 12, trial 104: stopped early", short and
        # said nowhere else while it runs) and the warnings at the right, which say what to
        # do, are whole at 1366 px
        self.backend_label = ElidedLabel("")
        self.health_label = QLabel("")
        self.health_label.setObjectName("loop_timing")
        self.trial_label = QLabel("")
        bar = self.statusBar()
        for widget in (self.state_label, self.backend_label, self.trial_label):
            bar.addWidget(widget)
        # the warnings, one above the other at the right: side by side (the loop's timing
        # and the shared registry unreachable, 1060 px together) they left the trial's
        # words "sessi…" at 1366 px. The registry's line (ui.window.station) shows only
        # while it says something, so the bar is one line high otherwise
        self.status_warnings = QWidget()
        column = QVBoxLayout(self.status_warnings)
        column.setContentsMargins(0, 0, 0, 0)
        column.setSpacing(0)
        column.addWidget(self.health_label, 0, Qt.AlignmentFlag.AlignRight)
        bar.addPermanentWidget(self.status_warnings)

    def say(self, text: str, problem: bool = False) -> None:
        """A new line in the message line (and its history)."""
        self._say(text, problem=problem)

    def _say(self, text: str, problem: bool = False, states=None):
        """A new event line; `states`: the robot states it stays current in (it leaves the
        line, not the history, when the robot leaves them; ui.views.messages). Returns the
        event, for a part of the window to withdraw once it no longer holds."""
        event = self.messages.say(text, problem=problem, states=states)
        self._show_message()
        (log.warning if problem else log.info)("%s", text)
        return event

    def _withdraw(self, event) -> None:
        """`event`'s line is no longer true: off the line if it is still shown there."""
        if self.messages.withdraw(event):
            self._show_message()

    def _show_message(self) -> None:
        event = self.messages.last
        problem = event is not None and event.problem
        colour = theme.PROBLEM_TEXT if problem else theme.TEXT
        sign = f"{theme.PROBLEM_SIGN} " if problem else ""
        self.message.setStyleSheet(f"color: {colour};" if problem else "")
        self.message.set_bold(problem)
        self.message.setText("" if event is None else f"{sign}{event.text}")
        self.message.setToolTip("" if event is None else event.text)

    def show_history(self) -> QDialog:
        """Everything said this session, oldest first, in a window of its own."""
        self.history_dialog = self._text_window(
            "What the console said", "\n".join(self.messages.history()) or "Nothing yet.")
        return self.history_dialog

    def show_whole(self, text: str) -> QDialog:
        """The event line's or the banner's text whole, when it was too long for their
        lines (ui.window.message_text: clicked)."""
        self.whole_dialog = self._text_window("The whole message", text)
        return self.whole_dialog

    def _text_window(self, title: str, text: str) -> QDialog:
        dialog = QDialog(self)
        dialog.setWindowTitle(title)
        shown = QPlainTextEdit(text)
        shown.setReadOnly(True)
        # a way to close it that is not Esc: Esc is the emergency stop, in every dialog
        close = QPushButton("Close")
        close.clicked.connect(dialog.close)
        layout = QVBoxLayout(dialog)
        layout.addWidget(shown)
        layout.addWidget(close, 0, Qt.AlignmentFlag.AlignRight)
        dialog.resize(700, 400)
        dialog.show()
        return dialog

    def _show_health(self) -> None:
        robot = self.parameters_tab.backend().name == HARDWARE and self.state.ticking
        text = self.loop_health.text(robot=robot)
        if text is not None:
            self.health_label.setText(text)
            self.health_label.setToolTip(self.loop_health.figures())

    def finish_interrupted_trials(self) -> None:
        """At start-up: trials a crashed console left recording are finished from their
        files (app.trials.finalize.finish_interrupted), and the therapist is told which."""
        def said(lines: list[str]) -> None:
            if lines:
                more = f" (and {len(lines) - 1} more; see the log)" if len(lines) > 1 else ""
                self._say(lines[0][0].upper() + lines[0][1:] + more, problem=True)

        self.jobs.run(lambda: finish_interrupted(self.registry), said)

    def _job_failed(self, error: Exception) -> None:
        log.error("background job failed: %s", error)
        self._say(f"{error}", problem=True)


def fixed_lines(label: QLabel, lines: int) -> int:
    """Make `label` a word-wrapped box of `lines` lines, as tall as they are in bold (a
    fault or a problem is shown bold), filled from the top: a longer text shows its first
    lines whole and the rest stays in its tooltip and the history, instead of half lines
    cut at top and bottom. Returns the height."""
    label.setWordWrap(True)
    label.setAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignTop)
    font = QFont(label.font())
    font.setBold(True)
    height = QFontMetrics(font).lineSpacing() * lines
    label.setFixedHeight(height)
    return height
