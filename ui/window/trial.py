"""The robot buttons and a trial's life in the window: Build (the form's parameters,
checked, with the learned or EMG model they name), Connect, Stop, Save data (the PDF
report and the trial's .mat); the loop's answers and states; the trial's start, end and
file; finishing it into the registry on the job thread and showing its report and the
next proposal. Start (the trial registered on the job thread, then run) is
ui.window.start.

The run is the screen: Build keeps what the form showed (`BuiltSetup`: the parameters
and the robot chosen), and any change to the form after it makes the built trial stale,
so Start waits for Build and says so on every tab (ui.views.readiness). Start commits a
field still being typed in first, so a number on the screen is never left out. During a
trial only the assistance level changes live, when the therapist commits it, and the
window says so once the loop has taken it.
"""

from __future__ import annotations

import contextlib
import logging
from dataclasses import dataclass
from pathlib import Path

from core.trial import TrialParameters
from device.loop.messages import BackendConfig
from device.loop.states import State
from ui.tabs import VIEW_TABS
from ui.tabs.parameters import HARDWARE, BackendChoice
from ui.views.moment import STATUS_WORDS
from ui.views.readiness import REGISTERING, readiness, start_needs, start_why
from ui.views.replay_strip import session_and_trial
from ui.views.saved import NotSaved, not_saved_line
from ui.views.trialview import TrialView

log = logging.getLogger("ui.main_window")

CONNECTED_STATES = (State.CONNECTED, State.RUNNING, State.STOPPING)
HANDS_OFF = ("Hands off the handle: the force sensor is taking its zero. Nobody may touch "
             "the handle until the zero is taken.")
ZERO_TAKEN = ("Zero taken: the force sensor read nothing on the handle. The patient may "
              "hold the handle now.")
SIMULATOR_CONNECTING = "Connecting the simulator…"
"""On the simulator nobody holds a handle: its simulated sensor's zero needs no hands off,
and telling the therapist to take them off (or that the patient may now hold it) is false."""


def on_simulator(backend: BackendConfig | None) -> bool:
    """The robot built (or about to be) is the simulator, not the hardware."""
    return backend is not None and backend.kind == "simulator"


@dataclass(frozen=True, slots=True)
class BuiltSetup:
    """What the form showed when the trial was built: its parameters as the form gives
    them and the robot chosen. The built trial is what the form shows while the form
    gives the same again."""

    parameters: TrialParameters
    backend: BackendChoice


class TrialActions:
    """The robot buttons and the trial's life (a part of MainWindow)."""

    # ------------------------------------------------------------------ robot buttons
    def build(self) -> None:
        refused = self.parameters_tab.commit_edits()
        if refused:  # said in the message line as the field refused it (ui.fields)
            self._say(f"Build refused: {refused[0]}", problem=True)
            self.tabs.setCurrentWidget(self.parameters_tab)
            return
        if self.latch.holds_robot():
            self._say(f"Build waits: {self.latch.holds_robot()}.", problem=True)
            return
        if self.registering():  # the trial registered is the one built (ui.window.start)
            self._say(f"Build waits for {REGISTERING}.", problem=True)
            return
        try:
            params = self.parameters_tab.parameters()
        except Exception as exc:  # ParameterError/UnreachableError: shown as is
            self._say(f"Build refused: {exc}", problem=True)
            self.tabs.setCurrentWidget(self.parameters_tab)
            return
        choice = self.parameters_tab.backend()
        setup = BuiltSetup(params, choice)
        model = None
        if params.learned_model:
            # the model file is read and checked here, at each Build: missing, corrupt
            # (hash), another system's or size's model, or on the robot a model not of
            # that robot's own trials, is refused with its reason
            from app.learning.library import inverse_dynamics, robot_model
            from app.learning.modelfile import ModelFileError
            from device.hardware.settings import HardwareSettingsError, load_hardware_settings

            try:
                kind, robot_name = "simulator", ""
                if choice.name == HARDWARE:  # only a model of this robot, by its name
                    kind = "quanser"
                    robot_name = load_hardware_settings(choice.settings_path).robot.name
                checked = robot_model(self.registry.data_dir.models_dir, params.learned_model,
                                      kind, robot_name)
            except (ModelFileError, HardwareSettingsError) as exc:
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
            backend = BackendConfig(patient=choice.patient_kind or "healthy", seed=choice.seed)
        self._pending_build = params  # the last asked (the plan's runner reads it)
        # each Build's answer is the loop's word on that Build: a second Build pressed
        # before the first was answered took the first's "built", and when the loop then
        # refused the second the window held it as built while the loop held the first
        self._builds_asked.append((params, setup, backend))
        # Built while connected, the loop opens the simulator (or a robot of another
        # config) again, and its force sensor takes a new zero (device.loop.process)
        reopens = self.state == State.CONNECTED and (
            on_simulator(backend) or backend != self.built_backend)
        if model is None:
            self.bridge.build(params, backend)
        else:
            self.bridge.build(params, backend, model=model)
        hands_off = reopens and not on_simulator(backend)  # a robot's sensor takes a zero
        self._say(f"Building the trial… {HANDS_OFF}" if hands_off else "Building the trial…",
                  states=(State.CONNECTED,) if hands_off else None)

    def connect_robot(self) -> None:
        """Connect: the force sensor takes its zero in its first quarter second, so nobody
        may touch the handle until the window says the zero is taken (docs/hardware.md,
        Tare); a zero taken under load refuses the Connect in one line. A second press
        (F3 again) while the zero is taken sends nothing: the loop refused it, and its
        "connect refused: already connected" took the place of "Zero taken", the word
        that tells the patient to take the handle."""
        if self._connecting:
            return
        self._connecting = True
        self._say(SIMULATOR_CONNECTING if on_simulator(self.built_backend) else HANDS_OFF,
                  states=(State.BUILT,))
        self.bridge.connect()
        self._refresh_buttons()

    def _on_sensor_zeroed(self, _message: str) -> None:
        if not on_simulator(self.built_backend):  # the simulator's: nobody to tell
            self._say(ZERO_TAKEN, states=(State.BUILT, State.CONNECTED))

    def _on_handle_area(self, line: str) -> None:
        """Between trials, the loop's word on the handle: outside the exercise area and
        where ('' once inside). Start waits until it is inside; the robot bar's line says
        so on every tab (docs/safety.md, H8: at zero torque it is a state, not a fault)."""
        self.handle_outside = line if self.state == State.CONNECTED else ""
        self._refresh_buttons()

    def refuse_build(self, reason: str) -> None:
        self._say(f"Build refused: {reason}", problem=True)
        self.tabs.setCurrentWidget(self.parameters_tab)

    def stale(self) -> bool:
        """The form shows something else than the trial built (a field, the robot, the
        patient's force, a proposal taken): Start would run what is not on the screen."""
        if self.built_setup is None:
            return False
        return BuiltSetup(self.parameters_tab.shown(), self.parameters_tab.backend()) \
            != self.built_setup

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
        """A running trial takes the assistance level the therapist committed (Enter,
        leaving the field, the arrows) at once; the trial's file records it per tick and
        as an event. Outside a trial the level is the form's like any other field: Build
        takes it (a connected robot's live level is its trial's only)."""
        if self.state == State.RUNNING:
            self._live_levels.append(level)
            self.bridge.set_assistance(level)
        self._refresh_buttons()

    def _assistance_answered(self, ok: bool) -> None:
        level = self._live_levels.pop(0) if self._live_levels else None
        if level is None:
            return
        if ok:
            # past tense: still true once the trial is over and the line still shows it
            self._say(f"Assistance set to {level:.0%} during the trial: the robot took it at "
                      "once, and the trial's file records it.", states=CONNECTED_STATES)
        else:
            self._say(f"The trial ended before the robot took {level:.0%}: the trial ran "
                      "without it. Press Build to run the next trial at it.", problem=True)

    _start_needs_said = None
    """(the event line, what it said Start needs) while it says Start needs something."""

    def _refresh_buttons(self) -> None:
        self._start_needs_still()
        tab = self.parameters_tab
        problem = tab.problem() or tab.backend_problem()
        if not problem and tab.check() is None:
            problem = "the parameters are being checked"
        tab.camera.hold(self.trial_id is not None or self.registering())
        self.robot.show_readiness(readiness(
            self.state, form_problem=problem, registered=self.registration is not None,
            built=self.built is not None, stale=self.stale(), held=self.latch.holds_robot(),
            unsaved=self.unsaved_trial is not None, saving=self.saving(),
            connecting=self._connecting, outside=self.handle_outside,
            registering=self.registering(), plan=self.plan_runner is not None))

    def _start_needs_still(self) -> None:
        """The event line that said what Start needs, once that changed, says what it needs
        now ("Start when ready." when nothing): "Start needs a registered patient…" stayed
        after the patient was confirmed, over a green Start."""
        said = self._start_needs_said
        if said is None or self.messages.last is not said[0]:
            self._start_needs_said = None
            return
        needs = self.start_needs()
        if needs != said[1]:
            event = self._say(f"{start_why(needs)}." if needs else "Start when ready.",
                              states=(State.CONNECTED,))
            self._start_needs_said = (event, needs) if needs else None

    def saving(self) -> bool:
        """A trial is begun and not yet finished into the registry: its file still open,
        or being finished (its analysis, the registry's row and the next proposal). The
        next Start waits: started meanwhile, it left the last trial's proposal pending
        for good (undecided by the trial after it, which registered before it was made).
        And the registry's reads after it, on the job thread (ui.window.after_trial): the
        next numbers and the proposal to offer."""
        return self.trial_id is not None or bool(self._finishing) or self.reading_after > 0

    def _finish(self, trial_id: int, which: str, work) -> None:
        """Finish trial `trial_id` (`which`, in words) into the registry on the job thread
        (`work`), then show it; Start waits until it is done, whether it succeeds or not.
        A failure is said naming the trial and what becomes of it (it was said bare: an
        error with no trial, after which the therapist did not know what was saved)."""
        self._finishing.add(trial_id)

        def finish():
            try:
                return work()
            except Exception as exc:
                raise NotSaved(not_saved_line(which, exc)) from exc

        def settled() -> None:
            self._finishing.discard(trial_id)
            self._refresh_buttons()

        self.jobs.run(finish, lambda done: self._finalized(trial_id, done), settled=settled)

    def start_needs(self) -> str:
        """What Start waits for beyond the robot's state, in words ("" when nothing)."""
        return start_needs(registered=self.registration is not None,
                           built=self.built is not None, stale=self.stale(),
                           saving=self.saving(), registering=self.registering())

    # ------------------------------------------------------------------ loop events
    def _on_reply(self, command: str, ok: bool, message: str) -> None:
        if command == "connect":
            self._connecting = False
        if command == "clear_fault":
            self._clear_fault_answered(ok, message)
            return
        if command == "set_assistance":
            self._assistance_answered(ok)
            return
        asked = self._builds_asked.pop(0) if command == "build" and self._builds_asked \
            else None
        if not ok:
            self._say(message, problem=True)
            if command == "start_trial" and self.trial_id is not None:
                self._take_back(message)
            self._refresh_buttons()
            return
        if command == "build" and asked is not None:
            self.built, self.built_setup, self.built_backend = asked
            self.video.pose_side = self.built.side  # the live pose follows the arm in use
            connected = self.state == State.CONNECTED
            if connected:  # the simulator was opened again with the trial just built
                self.backend_label.setText(self._robot_words(self.backend_label.text()))
            self._say("Trial built. Start when ready." if connected
                      else "Trial built. Connect to the robot, then Start.",
                      states=(State.CONNECTED,) if connected else (State.BUILT,))
        self._refresh_buttons()

    def _live_from_file(self, path: Path) -> None:
        """The trial just finished, shown from now on as its file holds it: the live view
        is a display, fed what the window took from the ring while it ran (records the
        ring skipped under load, or that came before the window heard the trial start,
        are not in it). Read off the GUI thread; left as it was when the file cannot be
        read (the Report tab says why) or when another trial has started meanwhile."""
        from app.errors import AppError
        from app.trials.reader import read_trial

        live = self.live
        if live is None:
            return

        def read():
            try:
                return read_trial(path)
            except AppError as exc:
                log.warning("the trial's view stays the live one: %s", exc)
                return None

        def show(data) -> None:
            if data is None or self.live is not live:
                return
            view = TrialView.from_trial(data)
            if data.parameters == live.parameters:
                view.parameters = live.parameters  # the built trial's: the patient's screen
            self.live = view
            if self.shown_view is live:
                self.shown_view = view
                self._show_current()

        self.jobs.run(read, show)

    def _robot_words(self, connected: str) -> str:
        """The robot as the status bar names it: a simulator by its built config (its
        seed, or "a new seed each trial": not the first one drawn, each trial's own is in
        its file and its report), the hardware as the loop named it at Connect."""
        built = self.built_backend
        if on_simulator(built):
            return built.label
        return connected

    def _take_back(self, why: str) -> None:
        """A Start the registry had begun was refused (by the loop, or before it was
        asked): the trial is taken back (withdrawn, or finished as recording lost if
        samples reached its file), never left 'recording' with no file
        (app.trials.registered); the video begun for it stops, and goes with a withdrawn
        trial (it filmed on, beside no trial, until the next Start)."""
        from app.trials.registered import WITHDRAWN, take_back

        trial_id, self.trial_id = self.trial_id, None
        camera = self.video.camera
        filmed = camera.stop_recording() if camera is not None and camera.recording else None

        def taken_back(done) -> None:
            if done.outcome == WITHDRAWN and filmed is not None:
                for path in (filmed.video_path, filmed.timestamps_path):
                    with contextlib.suppress(OSError):
                        path.unlink()
            self._say(f"The refused trial: {done.words}.", problem=True)

        self.jobs.run(lambda: take_back(self.registry, trial_id, why), taken_back)
        if self.registration is not None:
            # read after the take back (the job thread runs in order), and Start waits for
            # them (ui.window.after_trial): pressed at once, it registered the number the
            # withdrawn trial had moved on from, and the registry refused it as a gap
            self.read_numbers()
        else:  # nobody confirmed: the session line's count at least, the row gone from it
            self.registration_tab.refresh_count()

    def _on_state(self, state: int, reason: str) -> None:
        if State(state) != self.state:
            # the clinic's events in the day's log: build, connect, start, stop, faults
            log.info("robot %s → %s%s", self.state.label, State(state).label,
                     f": {reason}" if reason else "")
        self.state = State(state)
        if self.state != State.CONNECTED:
            self.handle_outside = ""  # the loop says it again once connected between trials
        self._latch_state(self.state, reason)
        self.emg.trial_running = self.state in (State.RUNNING, State.STOPPING)
        self._note_emg_range(self.emg.live_problem)  # seen before the trial began
        self.messages.set_state(self.state)
        self._show_message()
        self.state_label.setText(f"<b>{self.state.label}</b>")
        if (self.state == State.CONNECTED and self.built is not None
                and reason.startswith("connected to the ")):
            # only Connect names the robot: other ways back to CONNECTED (a trial's file
            # complete, a fault cleared) give their own reason, not a robot's name. A
            # simulator drawing a seed per trial is named so, not by the first one drawn
            # (each trial's own is in its file and its report)
            self.backend_label.setText(self._robot_words(reason.removeprefix(
                "connected to the ")))
        if self.state == State.CONNECTED and reason.startswith("connected to the "):
            needs = self.start_needs()
            then = f"{start_why(needs)}." if needs else "Start when ready."
            said = None
            if on_simulator(self.built_backend):  # no "Zero taken" said it is done
                said = self._say(f"Connected to the simulator. {then}",
                                 states=(State.CONNECTED,))
            elif needs:
                zero = " (zero taken)" if self.messages.last is not None and \
                    self.messages.last.text == ZERO_TAKEN else ""
                said = self._say(f"Connected{zero}. {then}", states=(State.CONNECTED,))
            self._start_needs_said = (said, needs) if needs else None
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
        self.trial_label.setText(f"recording {session_and_trial(path)}")
        self.trial_label.setToolTip(Path(path).name)
        self._say(f"Trial running: {session_and_trial(path)}. Stop (F6) ends it early.",
                  states=(State.RUNNING,))
        self.force_estimate.trial_started(self.built)
        if not isinstance(self.tabs.currentWidget(), VIEW_TABS) and not self.on_running_plan():
            self.tabs.setCurrentWidget(self.trajectory)

    def _on_trial_ended(self, path: str, status: str, summary: dict) -> None:
        log.info("trial ended: %s, %s", Path(path).name, status)
        self.trial_label.setText(f"{session_and_trial(path)}: {STATUS_WORDS.get(status, status)}")
        self.trial_label.setToolTip(Path(path).name)
        camera = self.video.camera
        if camera is not None and camera.recording:
            camera.stop_recording()

    def _on_file_notice(self, kind: str, path: str, status: str, message: str) -> None:
        if kind in ("error", "lost"):
            self._say(f"Recording problem: {message}", problem=True)
        if kind == "lost" and self.trial_id is not None:
            # the trial's file could not be finished (a write failed, the file could not be
            # made, a dead recorder's file could not be taken over): the trial is finished
            # from what reached its file, its cause the fault the window saw and the words
            # of what happened to the file
            from app.trials.finalize import finalize_lost

            trial_id = self.trial_id
            reason = "; ".join(part for part in (self.trial_fault, message) if part)
            self.trial_id = None
            self._finish(trial_id, session_and_trial(path),
                         lambda: finalize_lost(self.registry, trial_id, reason))
        if kind == "closed" and self.trial_id is not None:
            from app.trials.finalize import finalize_trial

            trial_id, reason = self.trial_id, self.trial_fault
            self.trial_id = None  # Start may run the next trial now (ui.views.readiness)
            self._finish(trial_id, session_and_trial(path),
                         lambda: finalize_trial(self.registry, trial_id, status, reason))
            self._store_trial_emg(path)
            self._refresh_buttons()
        if kind == "closed":
            self.force_estimate.trial_closed(path)
