"""Start in the window (a part of MainWindow): the trial registered on the job thread, then
run by the loop.

Why on the job thread: a station on the department's shared registry whose network drops
traffic without a word waits for the server's answer up to its bound
(app.records.registry.postgres.deadline, 5 s, and up to 10 s more to connect) before it
records on its own (app.records.station). Registered on the window's thread, that held the
whole window while the robot was connected: no repaint, and no Stop, Disconnect or
emergency-stop click was handled.

One truth: what is registered is what the window showed at the press. Everything the
trial is registered and run with is taken then (`Press`: the confirmed registration, the
built trial, the robot's words), except what the patient's screen shows, which the
registry does not hold and the therapist may change while Start registers: the trial's
file takes it as the trial starts (taken at the press, a change made meanwhile was in no
file while the screen showed it). While the registry answers, Start says "Registering…",
Build waits (ui.views.readiness), and a second Start is refused. When the answer comes
the trial is run only if nothing it was pressed with has gone: the robot still connected
and not held (Disconnect, a fault, the emergency stop), the same registration confirmed
(another patient chosen, other numbers), the same trial built.
Otherwise the registered trial is taken back (app.trials.registered: withdrawn, never left
'recording' with no file), and so it is when the window closes before the answer: the
window does not wait for it (on a silent network, up to the bounded wait), the job thread
takes the trial back as the answer comes (ui.window.awaited), and the process ends after.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

from app.records.registry import BegunTrial, Registration
from core.trial import TrialParameters
from device.loop.states import State
from device.recording.trialfile import SubjectInfo
from device.safewrite import os_reason
from ui.views.readiness import start_needs
from ui.window.awaited import Awaited

log = logging.getLogger("ui.main_window")


@dataclass(eq=False)
class Press:
    """What a Start press registers and runs, taken at the press."""

    registration: Registration
    built: TrialParameters
    backend: str
    subject: SubjectInfo
    begun: Awaited[BegunTrial] = field(default_factory=Awaited)
    """The registry's answer, set on the job thread as it comes; the window closing
    abandons it (then the trial is taken back there)."""


class TrialStart:
    """Start: the trial registered off the window's thread, then run (a part of
    MainWindow)."""

    _press: Press | None = None

    def registering(self) -> bool:
        """A Start's trial is being registered (its answer not yet taken)."""
        return self._press is not None

    def start_trial(self) -> None:
        # a number still being typed is committed first: it is on the screen
        refused = self.parameters_tab.commit_edits()
        if refused:
            self._say(f"Start refused: {refused[0]}", problem=True)
            self.tabs.setCurrentWidget(self.parameters_tab)
            return
        waits = self.latch.holds_robot() or (self.state != State.CONNECTED and
                                             f"the robot is {self.state.label.lower()}")
        if not waits and self.registration is not None:
            waits = start_needs(registered=True, built=self.built is not None,
                                stale=self.stale(), saving=self.saving(),
                                registering=self.registering())
        waits = waits or self.handle_outside
        if waits:
            self._say(f"Start refused: {waits}.", problem=True)
            self._refresh_buttons()
            return
        if (self.patient is None or self.registration is None
                or self.registration.patient_code != self.patient.code):
            self._say("Register the patient first (Registration tab: choose the patient and "
                      "confirm the session and trial numbers).", problem=True)
            self.tabs.setCurrentWidget(self.registration_tab)
            return
        reg = self.registration
        press = self._press = Press(
            reg, self.built, self.backend_label.text() or "simulator",
            SubjectInfo.from_parameters(self.patient.code, self.built))
        registry = self.registry

        def register() -> BegunTrial | Exception:
            try:
                begun = registry.begin_trial(
                    reg.patient_code, press.built, backend=press.backend,
                    session_number=reg.session_number, trial_number=reg.trial_number)
            except Exception as exc:  # RegistryError etc.: the refusal, shown as is
                return exc
            closed = press.begun.answered(begun)
            if closed:  # the window closed meanwhile, without waiting for this answer
                _take_back_unrun(registry, begun, closed)
            return begun

        self._say("Registering the trial…", states=(State.CONNECTED,))
        self.jobs.run(register, lambda answer: self._registered(press, answer))
        self._refresh_buttons()

    def _registered(self, press: Press, answer: BegunTrial | Exception) -> None:
        """The registry's answer to `press`: the trial run, or the refusal said."""
        if self._press is not press:
            return  # the window closed meanwhile and took it back
        self._press = None
        if isinstance(answer, Exception):
            self._say(f"Start refused: {answer}", problem=True)
            if self.registration_tab.selected_patient() is not None and \
                    self.registration_tab.selected_patient().code == \
                    press.registration.patient_code:
                self.registration_tab.show_refusal(answer)
                self.registration_tab.refresh_count()  # the refusal may say why it changed
            self._start_not_run(str(answer))
            self._refresh_buttons()
            return
        self.trial_id = answer.trial_id
        self.trial_fault = ""
        self.trial_path = answer.path
        gone = self._press_gone(press)
        if gone:
            self._say(f"Start refused: {gone}.", problem=True)
            self._take_back(gone)
            self._start_not_run(gone)
            self._refresh_buttons()
            return
        try:
            camera = self.video.camera
            if camera is not None and camera.running:
                camera.start_recording(answer.path.with_suffix(".mp4"))
            # the patient's screen as it is now, the trial starting: the therapist may
            # have opened, closed or changed it while the registry answered
            self.bridge.start_trial(str(answer.path), press.subject, self.shown_to_patient())
        except Exception as exc:  # the video cannot be written, the loop is gone, …
            # what was begun goes back with the refusal (app.trials.registered): the trial
            # stayed 'recording' with no file, and Start waited for it for good
            why = os_reason(exc)  # in words, one line (an OSError without its [Errno])
            self._say(f"Start refused: {why}", problem=True)
            self._take_back(why)
            self._start_not_run(why)
            self._refresh_buttons()
            return
        # the next trial's number now (read on the job thread; Start waits for it): a Start
        # pressed as soon as this trial ends (before it is finished into the registry) was
        # refused as a number already used
        self.read_numbers()
        self._refresh_buttons()

    def _press_gone(self, press: Press) -> str:
        """What the press was made with and no longer holds, in words ('' when all does)."""
        if self.latch.holds_robot():
            return self.latch.holds_robot()
        if self.state != State.CONNECTED:
            return f"the robot is {self.state.label.lower()}"
        if self.registration != press.registration:
            return ("another patient or other numbers were chosen while the trial was being "
                    "registered: confirm them and press Start again")
        if self.built != press.built:
            return "the trial was built again while it was being registered: press Start again"
        return self.handle_outside

    def _start_not_run(self, why: str) -> None:
        """A Start taken (registering) that runs no trial: said to whoever waits for it
        (the plan's runner, ui.window.plan)."""

    def _close_registering(self) -> bool:
        """The window closes: a Start's trial being registered is abandoned, the window not
        waiting for the registry's answer; the trial is taken back on the job thread (by
        the registering job as its answer comes, or after it when the answer came but was
        not taken), never left 'recording'. True when one was (the job thread may still
        wait for the registry then)."""
        press, self._press = self._press, None
        if press is None:
            return False
        why = "the console closed before the trial started"
        begun = press.begun.abandon(why)
        if begun is not None:
            registry = self.registry
            self.jobs.run(lambda: _take_back_unrun(registry, begun, why), lambda _: None)
        return True


def _take_back_unrun(registry, begun: BegunTrial, why: str) -> None:
    """On the job thread: the trial registered for a Start the window closed before it
    ran, taken back (app.trials.registered); a failure is said in the log (the station's
    next start finishes a trial left 'recording', ui.window.message_line)."""
    from app.trials.registered import take_back

    try:
        done = take_back(registry, begun, why)
    except Exception as exc:  # the window has gone: the log is where it is said
        log.error("trial %d registered at Start could not be taken back as the console "
                  "closed: %s", begun.trial_id, exc)
        return
    log.info("trial %d registered at Start as the console closed: %s", begun.trial_id,
             done.words)
