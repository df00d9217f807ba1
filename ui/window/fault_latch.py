"""The emergency stop and the fault banner: Esc, Space or the big button from any tab or
dialog, the banner in vermillion with the fault's cause in plain words, and its Clear
fault.

The e-stop is a shared flag the loop reads every tick (device.loop.client): pressing it
sets the flag and shows the supervisor's own words for it at once; Clear fault releases
the flag and asks the loop to clear, one tick later, once a tick has seen it released.
"""

from __future__ import annotations

import logging

from PySide6.QtCore import Qt, QTimer
from PySide6.QtGui import QKeySequence, QShortcut
from PySide6.QtWidgets import QFrame, QHBoxLayout, QLabel, QPushButton, QSizePolicy

from device.loop.states import State
from device.safety.faults import Fault
from ui import theme
from ui.window.message_line import MESSAGE_LINES, fixed_lines

log = logging.getLogger("ui.main_window")

CLEAR_DELAY_MS = 20  # ten loop ticks


class FaultLatch:
    """The e-stop, the banner and Clear fault (a part of MainWindow)."""

    def _build_banner(self) -> QFrame:
        self.banner = QFrame()
        self.banner.setObjectName("fault_banner")
        self.banner.setStyleSheet(
            f"#fault_banner {{ background: {theme.VERMILLION}; }}"
            " #fault_banner QLabel { color: white; font-weight: bold; }")
        self.banner_text = QLabel()
        lines = fixed_lines(self.banner_text, MESSAGE_LINES)
        self.banner.setFixedHeight(max(lines, 40) + 16)
        # its place is kept while hidden: a fault never pushes the window taller (issue 13 #3)
        policy = self.banner.sizePolicy()
        policy.setRetainSizeWhenHidden(True)
        self.banner.setSizePolicy(policy)
        self.banner_text.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self.clear_button = QPushButton("Clear fault")
        self.clear_button.setObjectName("clear_fault")
        self.clear_button.setMinimumHeight(40)
        row = QHBoxLayout(self.banner)
        row.addWidget(self.banner_text, 1)
        row.addWidget(self.clear_button)
        self.banner.hide()
        return self.banner

    def _bind_estop_keys(self) -> None:
        # The emergency stop works from every tab and every dialog of the application.
        self.estop_keys = [QShortcut(QKeySequence(key), self) for key in ("Esc", "Space")]
        for shortcut in self.estop_keys:
            shortcut.setContext(Qt.ShortcutContext.ApplicationShortcut)
            shortcut.activated.connect(self.emergency_stop)

    def emergency_stop(self) -> None:
        self.bridge.estop(True)
        # the supervisor's own words for it, as the loop will report it (one wording)
        self._show_banner(Fault.ESTOP.banner())

    def clear_fault(self) -> None:
        self.bridge.estop(False)
        # the supervisor clears only once a tick has seen the e-stop released
        QTimer.singleShot(CLEAR_DELAY_MS, self.bridge.clear_fault)

    def _clear_fault_answered(self, ok: bool) -> None:
        """The loop's answer to Clear fault."""
        if not ok:
            if self.fault_code == Fault.ESTOP:
                self.bridge.estop(True)  # keep it latched: clearing was refused
            return
        self.fault_code = 0
        self.banner.hide()
        self.messages.clear_fault()
        self._say("Fault cleared.", states=(State.IDLE, State.BUILT, State.CONNECTED,
                                            State.RUNNING, State.STOPPING))

    def _on_fault(self, code: int, message: str, detail: dict) -> None:
        log.warning("fault %s: %s %s", Fault(code).label, message,
                    {k: v for k, v in detail.items() if k != "monotonic_s"})
        self.fault_code = code
        if self.trial_id is not None:
            self.trial_fault = message  # kept with the trial in the registry (finalize)
        self._show_banner(message)
        if detail.get("cause") == "recorder process stopped" and self.trial_id is not None:
            # no recorder is left to close the file and say so: finish the trial from
            # what reached its file, as a crash's trial is finished at the next start
            from app.trials.finalize import finalize_lost

            trial_id, self.trial_id = self.trial_id, None
            self.jobs.run(lambda: finalize_lost(self.registry, trial_id, message),
                          lambda done: self._finalized(trial_id, done))

    def _on_loop_lost(self, message: str) -> None:
        self._show_banner(message)
        self.clear_button.setEnabled(False)

    def _show_banner(self, text: str) -> None:
        self.banner_text.setText(f"{theme.PROBLEM_SIGN} {text}")
        self.banner_text.setToolTip(text)
        self.banner.show()
        self.clear_button.setEnabled(True)
        self.messages.set_fault(text)
        self._show_message()
