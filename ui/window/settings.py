"""What the window remembers between sessions (its size and place, the last parameters,
the robot chosen, the axes' flip: app.records.settings) and closing it: asked first while a
trial runs, then the settings saved, the timers, the camera, the loop and the job thread
stopped."""

from __future__ import annotations

import base64
import contextlib
import logging
from pathlib import Path

from PySide6.QtCore import QSize
from PySide6.QtWidgets import QApplication, QMessageBox

from app.records.settings import save_settings
from app.records.store import StationStore
from device.loop.states import State
from ui.tabs.parameters import HARDWARE, SIMULATOR, BackendChoice

log = logging.getLogger("ui.main_window")

FIRST_SIZE = QSize(1400, 900)
"""The window's size at its first start, on a screen large enough."""
TITLE_BAR_PX = 30
"""Left for the window manager's title bar, which Qt's available geometry still counts."""


def first_size(available: QSize) -> QSize:
    """FIRST_SIZE, within a screen's free area less a title bar: at 1400 × 900 on a
    1366 × 768 laptop the robot buttons and the emergency stop were off the screen wherever
    no window manager moved the window (a kiosk session, Xvfb)."""
    return QSize(min(FIRST_SIZE.width(), available.width()),
                 min(FIRST_SIZE.height(), available.height() - TITLE_BAR_PX))


class RememberedSettings:
    """Restore at start, save at close (a part of MainWindow)."""

    def _restore(self) -> None:
        s = self.settings
        if s.window_geometry:
            self.restoreGeometry(base64.b64decode(s.window_geometry))
        else:
            self.resize(first_size(self.screen().availableGeometry().size()))
        params = s.trial_parameters()
        if params is not None:
            self.parameters_tab.set_parameters(params)
        self.parameters_tab.set_backend(BackendChoice(
            HARDWARE if s.robot == "hardware" else SIMULATOR, patient_kind=s.virtual_patient,
            settings_path=Path(s.hardware_settings) if s.hardware_settings else None))
        self.trajectory.set_flip(s.flip_x, s.flip_y)
        self.restore_patient_options(s.patient_screen)

    def closeEvent(self, event) -> None:
        if self.state == State.RUNNING and not self.closing_by_signal:
            answer = QMessageBox.question(
                self, "A trial is running",
                "A trial is running. Stop it, save it and close the console?")
            if answer != QMessageBox.StandardButton.Yes:
                event.ignore()
                return
        geometry = base64.b64encode(bytes(self.saveGeometry())).decode("ascii")
        choice = self.parameters_tab.backend()
        settings = self.settings.replace(
            window_geometry=geometry, patient_screen=self.patient_options.to_dict(),
            robot="hardware" if choice.name == HARDWARE else "simulator",
            virtual_patient=choice.patient_kind or self.settings.virtual_patient,
            hardware_settings=(str(choice.settings_path) if choice.settings_path
                               else self.settings.hardware_settings))
        # invalid parameters are simply not remembered
        with contextlib.suppress(Exception):
            settings = settings.with_trial_parameters(self.parameters_tab.parameters())
        try:
            save_settings(settings, self.settings_path)
        except Exception as exc:  # closing must not fail on settings
            log.warning("settings not saved: %s", exc)
        for timer in (self.repaint_timer, self.heartbeat_timer, self.health_timer,
                      self.station_timer):
            timer.stop()
        # a Start's trial or a plan's run being begun in the registry: the window stops
        # waiting for the answer (on a silent network it waited up to the bounded wait,
        # the window frozen); what was begun is taken back on the job thread
        abandoned = self._close_registering()
        abandoned = self._close_plan_start() or abandoned
        abandoned = self._close_assessment() or abandoned  # a page read: not waited for
        abandoned = self.replay.drop_opening() or abandoned  # a trial found: not waited for
        self.video.close_camera()
        self.close_patient_screen()
        self.bridge.close(self.closing_signal)
        # what the loop and the recorder said as they ended (the trial's fault, its file
        # closed) reaches the window now, so the trial is recorded before it closes
        QApplication.processEvents()
        self.registration_tab.drop_answers()  # not shown in a window that is going
        if isinstance(self.registry, StationStore):
            # after every job: another console may hold its standby now
            self.jobs.run(self.registry.close, lambda _: None)
        # the jobs given run on; the window waits for them unless one waits for an answer
        # it abandoned (then Python waits for the job thread before the process ends)
        self.jobs.shutdown(wait=not abandoned)
        super().closeEvent(event)
