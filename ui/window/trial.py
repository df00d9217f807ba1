"""The robot buttons and a trial's life in the window: Build (the form's parameters,
checked, with the learned or EMG model they name), Connect, Start (the trial registered,
then run), Stop, Save data (the PDF report and the trial's .mat); the loop's answers and
states; the trial's start, end and file; finishing it into the registry on the job thread
and showing its report and the next proposal.
"""

from __future__ import annotations

import logging
from pathlib import Path

from device.loop.messages import BackendConfig
from device.loop.states import State
from device.recording.trialfile import SubjectInfo
from ui.tabs import VIEW_TABS
from ui.tabs.parameters import HARDWARE
from ui.views.trialview import TrialView

log = logging.getLogger("ui.main_window")

CONNECTED_STATES = (State.CONNECTED, State.RUNNING, State.STOPPING)


class TrialActions:
    """The robot buttons and the trial's life (a part of MainWindow)."""

    # ------------------------------------------------------------------ robot buttons
    def build(self) -> None:
        try:
            params = self.parameters_tab.parameters()
        except Exception as exc:  # ParameterError/UnreachableError: shown as is
            self._say(f"Build refused: {exc}", problem=True)
            self.tabs.setCurrentWidget(self.parameters_tab)
            return
        choice = self.parameters_tab.backend()
        model = None
        if params.learned_model:
            # the model file is read and checked here, at each Build: missing, corrupt
            # (hash), another system's or size's model, or on the robot a model not of
            # that robot's own trials, is refused with its reason
            from app.learning.library import inverse_dynamics, robot_model
            from app.learning.modelfile import ModelFileError

            try:
                checked = robot_model(self.registry.data_dir.models_dir, params.learned_model,
                                      "quanser" if choice.name == HARDWARE else "simulator")
            except ModelFileError as exc:
                self._say(f"Build refused: {exc}", problem=True)
                self.tabs.setCurrentWidget(self.parameters_tab)
                return
            params = params.replace(learned_model_sha256=checked.content_sha256)
            model = inverse_dynamics(checked)
        # an EMG model for the patient's force: read and checked, with the EMG tab's source
        # and MVCs, at each Build
        params = self.force_estimate.checked(params)
        if params is None:
            return
        if choice.name == HARDWARE:
            backend = BackendConfig(kind="quanser", hardware_settings=str(choice.settings_path))
        else:
            backend = BackendConfig(patient=choice.patient_kind or "healthy")
        self._pending_build = params
        if model is None:
            self.bridge.build(params, backend)
        else:
            self.bridge.build(params, backend, model=model)
        self._say("Building the trial…")

    def refuse_build(self, reason: str) -> None:
        self._say(f"Build refused: {reason}", problem=True)
        self.tabs.setCurrentWidget(self.parameters_tab)

    def start_trial(self) -> None:
        if self.patient is None or self.registration is None:
            self._say("Register the patient first (Registration tab: choose the patient and "
                      "confirm the session and trial numbers).", problem=True)
            self.tabs.setCurrentWidget(self.registration_tab)
            return
        reg = self.registration
        try:
            begun = self.registry.begin_trial(
                self.patient.code, self.built, backend=self.backend_label.text() or "simulator",
                session_number=reg.session_number, trial_number=reg.trial_number)
        except Exception as exc:  # RegistryError etc., shown as is
            self._say(f"Start refused: {exc}", problem=True)
            self.registration_tab.show_refusal(exc)
            return
        self.trial_id = begun.trial_id
        self.trial_fault = ""
        self.trial_path = begun.path
        subject = SubjectInfo.from_parameters(self.patient.code, self.built)
        camera = self.video.camera
        if camera is not None and camera.running:
            camera.start_recording(begun.path.with_suffix(".mp4"))
        self.bridge.start_trial(str(begun.path), subject)

    def save_data(self) -> None:
        trial_id = self.unsaved_trial
        if trial_id is None:
            return
        self._say("Saving the report and the MATLAB file…")
        from app.exports.run import export_trial
        from app.reports.build import report_for_registry_trial

        def save() -> tuple[Path, Path]:
            # the thesis window's Save data wrote MATLAB data (A.3): the trial's .mat goes
            # beside its report, named as its trial file; saving again replaces both
            pdf = report_for_registry_trial(self.registry, trial_id)
            source = self.registry.trial_path(self.registry.trial(trial_id))
            mat = export_trial(source, pdf.parent, format="mat", overwrite=True)[0]
            return pdf, mat

        self.jobs.run(save, self._saved)

    def _saved(self, paths: tuple[Path, Path]) -> None:
        pdf, mat = paths
        self.unsaved_trial = None
        self._refresh_buttons()
        self._say(f"Saved: the report {pdf.name} and the MATLAB file {mat.name}, in "
                  f"{pdf.parent}")

    def _assistance_changed(self, level: float) -> None:
        """A connected robot takes the new assistance level at once, mid-trial too (the
        trial file keeps an event of the change)."""
        if self.state in (State.CONNECTED, State.RUNNING):
            self.bridge.set_assistance(level)
            self._say(f"Assistance set to {level:.0%}; the robot uses it from now on.",
                      states=CONNECTED_STATES)

    def _refresh_buttons(self) -> None:
        tab = self.parameters_tab
        params_ok = tab.check() is not None and not tab.problem() and not tab.backend_problem()
        self.robot.update_for(
            self.state, can_build=params_ok,
            can_start=self.built is not None and self.registration is not None,
            can_save=self.unsaved_trial is not None, start_needs=self.start_needs())
        self.clear_button.setEnabled(self.state == State.FAULTED or self.fault_code != 0)

    def start_needs(self) -> str:
        """What Start waits for beyond the robot's state, in words ("" when nothing)."""
        if self.registration is None:
            return ("a registered patient: Registration tab, choose the patient and press "
                    "Confirm")
        if self.built is None:
            return "a built trial: press Build"
        return ""

    # ------------------------------------------------------------------ loop events
    def _on_reply(self, command: str, ok: bool, message: str) -> None:
        if not ok:
            self._say(message, problem=True)
            if command == "clear_fault":
                self._clear_fault_answered(False)
            return
        if command == "build":
            self.built = self._pending_build
            self.video.pose_side = self.built.side  # the live pose follows the arm in use
            self._say("Trial built. Connect to the robot, then Start.", states=(State.BUILT,))
        elif command == "clear_fault":
            self._clear_fault_answered(True)
        self._refresh_buttons()

    def _on_state(self, state: int, reason: str) -> None:
        if State(state) != self.state:
            # the clinic's events in the day's log: build, connect, start, stop, faults
            log.info("robot %s → %s%s", self.state.label, State(state).label,
                     f": {reason}" if reason else "")
        self.state = State(state)
        self.emg.trial_running = self.state in (State.RUNNING, State.STOPPING)
        self.messages.set_state(self.state)
        self._show_message()
        self.state_label.setText(f"<b>{self.state.label}</b>")
        if (self.state == State.CONNECTED and self.built is not None
                and reason.startswith("connected to the ")):
            # only Connect names the robot: other ways back to CONNECTED (a trial's file
            # complete, a fault cleared) give their own reason, not a robot's name
            self.backend_label.setText(reason.removeprefix("connected to the "))
        if self.state == State.CONNECTED and self.start_needs():
            self._say(f"Connected. Start needs {self.start_needs()}.",
                      states=(State.CONNECTED,))
        self._refresh_buttons()

    def _on_trial_started(self, path: str, approach: int, total: int) -> None:
        log.info("trial started: %s (%d ticks)", Path(path).name, total)
        self.live = TrialView(self.built)
        self.shown_view = self.live
        self.video.close_replay()  # the live camera again, not a past trial's video
        if self.emg.capture is not None:
            # the EMG before this trial's margin was stored with the trials before it
            import time

            from app.emg.importing import LIVE_MARGIN_S

            self.emg.capture.forget_before(time.monotonic() - 2 * LIVE_MARGIN_S)
        self.trial_label.setText(f"recording {Path(path).name}")
        self._say(f"Trial running: {Path(path).name}. Stop (F6) ends it early.",
                  states=(State.RUNNING,))
        self.force_estimate.trial_started(self.built)
        if not isinstance(self.tabs.currentWidget(), VIEW_TABS):
            self.tabs.setCurrentWidget(self.trajectory)

    def _on_trial_ended(self, path: str, status: str, summary: dict) -> None:
        log.info("trial ended: %s, %s", Path(path).name, status)
        self.trial_label.setText(f"{Path(path).name}: {status.replace('_', ' ')}")
        camera = self.video.camera
        if camera is not None and camera.recording:
            camera.stop_recording()

    def _on_file_notice(self, kind: str, path: str, status: str, message: str) -> None:
        if kind == "error":
            self._say(f"Recording problem: {message}", problem=True)
        if kind == "closed" and self.trial_id is not None:
            from app.trials.finalize import finalize_trial

            trial_id, reason = self.trial_id, self.trial_fault
            self.trial_id = None
            self.jobs.run(lambda: finalize_trial(self.registry, trial_id, status, reason),
                          lambda done: self._finalized(trial_id, done))
            self._store_trial_emg(path)
        if kind == "closed":
            self.force_estimate.trial_closed(path)

    def _finalized(self, trial_id: int, done) -> None:
        self.unsaved_trial = trial_id
        self.parameters_tab.show_proposal(done.proposal)
        if self.registration is not None:
            self.registration_tab.refresh_numbers()
        self.report.load_registry_trial(self.registry, trial_id)
        if self.patient is not None:
            self.progress.set_patient(self.patient.code)
            self.replay.set_patient(self.patient.code)
        self.tabs.setCurrentWidget(self.report)
        self._refresh_buttons()
