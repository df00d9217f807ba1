"""The emergency stop and the fault banner: Esc, Space or the big button from any tab or
dialog, the banner in vermillion with the fault's cause in plain words, and its Clear
fault.

The banner, the buttons and the loop's latch are one state, `ui.views.latch.Latch`: the
e-stop is a shared flag the loop reads every tick while connected (device.loop.client),
a fault puts the loop in FAULTED; the banner shows exactly what is latched, and Clear
fault releases the flag and, with a robot connected, asks the loop to clear, one tick
later, once a tick has seen it released.
"""

from __future__ import annotations

import logging

from PySide6.QtCore import Qt, QTimer
from PySide6.QtGui import QKeySequence, QShortcut
from PySide6.QtWidgets import QFrame, QHBoxLayout, QPushButton, QSizePolicy

from device.loop.states import State
from device.safety.faults import Fault
from ui import theme
from ui.window.message_line import MESSAGE_LINES, fixed_lines
from ui.window.message_text import WholeText

log = logging.getLogger("ui.main_window")

CLEAR_DELAY_MS = 20  # ten loop ticks


class FaultLatch:
    """The e-stop, the banner and Clear fault (a part of MainWindow)."""

    _cleared_unsaid = False
    """The loop cleared the fault but still showed FAULTED when it answered: "Fault
    cleared." is said when its state leaves FAULTED (the answer and the state arrive in
    either order)."""

    def _build_banner(self) -> QFrame:
        self.banner = QFrame()
        self.banner.setObjectName("fault_banner")
        self.banner.setStyleSheet(
            f"#fault_banner {{ background: {theme.VERMILLION}; }}"
            " #fault_banner QLabel { color: white; font-weight: bold; }")
        self.banner_text = WholeText()
        lines = fixed_lines(self.banner_text, MESSAGE_LINES)
        # in the event line's place (ui.window.message_line): a fault never pushes the
        # window taller (issue 13 #3)
        self.banner.setFixedHeight(max(lines, 40) + 16)
        self.banner_text.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self.clear_button = QPushButton("Clear fault")
        self.clear_button.setObjectName("clear_fault")
        self.clear_button.setMinimumHeight(40)
        row = QHBoxLayout(self.banner)
        row.setContentsMargins(8, 4, 4, 4)
        row.addWidget(self.banner_text, 1)
        row.addWidget(self.clear_button)
        return self.banner

    def _bind_estop_keys(self) -> None:
        # The emergency stop works from every tab and every dialog of the application.
        self.estop_keys = [QShortcut(QKeySequence(key), self) for key in ("Esc", "Space")]
        for shortcut in self.estop_keys:
            shortcut.setContext(Qt.ShortcutContext.ApplicationShortcut)
            shortcut.activated.connect(self.emergency_stop)

    def emergency_stop(self) -> None:
        """The e-stop pressed, in any state: the flag at once, the banner with it. With no
        robot connected it stays held (Build, Connect and Start wait) until Clear fault."""
        self.latch.press()
        self.bridge.estop(True)
        self._show_latch()

    def clear_fault(self) -> None:
        """Clear fault: the e-stop released; with a robot connected the loop is asked to
        clear too, once a tick has seen the release. The banner goes when the latch does
        (ui.views.latch), not before."""
        if not self.latch.clearable:
            return
        ask_loop = self.latch.release()
        self.bridge.estop(False)
        if ask_loop:
            self._clear_asked += 1
            # the supervisor clears only once a tick has seen the e-stop released
            QTimer.singleShot(CLEAR_DELAY_MS, self.bridge.clear_fault)
        else:
            self._say("Emergency stop released.", states=(State.IDLE, State.BUILT))
        self._show_latch()

    def _clear_fault_answered(self, ok: bool, message: str) -> None:
        """The loop's answer to Clear fault. A refusal while the loop holds no fault (the
        e-stop released before a tick latched it) is no news; any other is said."""
        self._clear_asked = max(0, self._clear_asked - 1)
        if ok:
            if self.state != State.FAULTED:
                self._say_cleared()
            else:  # its new state is on its way: said when it comes (_latch_state)
                self._cleared_unsaid = True
        elif self.state == State.FAULTED:
            self._say(message, problem=True)
        self._show_latch()

    def _say_cleared(self) -> None:
        self._cleared_unsaid = False
        self._say("Fault cleared.", states=(State.IDLE, State.BUILT, State.CONNECTED,
                                            State.RUNNING, State.STOPPING))

    def _on_fault(self, code: int, message: str, detail: dict) -> None:
        self._cleared_unsaid = False  # a new fault: the clear it followed is no news
        log.warning("fault %s: %s %s", Fault(code).label, message,
                    {k: v for k, v in detail.items() if k != "monotonic_s"})
        self.latch.on_fault(code, message)
        if self.trial_id is not None:
            self.trial_fault = message  # kept with the trial in the registry (finalize)
        self._show_latch()
        # a dead recorder's trial: the device link finishes its file from the ring and
        # says so as the recorder would have ("closed", or "lost": _on_file_notice)

    def _latch_state(self, state: State, reason: str) -> None:
        """The loop's new state into the latch; leaving FAULTED by Disconnect ends the
        fault with the connection, and the therapist is told."""
        was_faulted = self.latch.state == State.FAULTED
        fault = self.latch.fault_text
        self.latch.on_state(state, reason)
        if self._cleared_unsaid and state != State.FAULTED and not self.latch.latched:
            self._say_cleared()
        if was_faulted and state == State.BUILT and not self.latch.latched:
            self._say(f"Disconnected: the robot is off and the fault ({fault}) went with "
                      "the connection.", states=(State.IDLE, State.BUILT))
        self._show_latch()

    def _on_loop_lost(self, message: str) -> None:
        self.latch.on_lost(message)
        self._show_latch()

    @property
    def fault_code(self) -> int:
        """The fault the loop has latched (0: none)."""
        return self.latch.fault_code

    def _show_latch(self) -> None:
        """The banner and its Clear fault are the latch, always (ui.views.latch)."""
        text = self.latch.banner
        if text:
            self.banner_text.setText(f"{theme.PROBLEM_SIGN} {text}")
            self.banner_text.setToolTip(text)
            self.notices.setCurrentWidget(self.banner)
            self.messages.set_fault(text)
        else:
            self.notices.setCurrentWidget(self.message)
            self.messages.clear_fault()
        self.clear_button.setEnabled(self.latch.clearable)
        self._show_message()
        self._refresh_buttons()
