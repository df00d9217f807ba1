"""The session plan in the window (a part of MainWindow): the Plan tab's template copied to
the patient, a block changed for today, and the plan run by its runner
(app.plans.runner.PlanRunner) through the window's own Build and Start, the same path as
the robot buttons (one truth: the form shows each round's trial as it is built, and
Start runs what Build built). Start plan needs the robot connected (Build, Connect, as
for a trial); from then on each round is built, started and finished by itself, the
rests are timed, Pause, Resume and Stop plan act, and the E-STOP or a fault end the plan
at once. Disconnect between rounds pauses it, saying why and what to do, and records it
(ROBOT_GONE); Resume waits for the robot to be connected again. The runner is
`plan_runner` while a plan runs (the patient's screen reads its state); the status line
says block k of n, the movements and the rest's countdown.
The plan's records (its read, a copy, a change, the run's begin and steps) are asked of
the registry on the job thread, never held the window on a silent network, and the tab
waits meanwhile.
"""

from __future__ import annotations

import logging
import time

from PySide6.QtCore import QTimer

from app.games.rounds import staircase_rounds
from app.plans.dose import trial_dose
from app.plans.runner import ENDED, PAUSED, STARTING, PlanRunner
from app.plans.templates import load_template, template_titles
from app.units import SCREEN
from core.plan import check_plan
from device.loop.states import State
from device.safety.faults import Fault
from ui.tabs.parameters import HARDWARE
from ui.tabs.plan import PlanTab
from ui.window.awaited import Awaited
from ui.window.plan_console import WindowConsole
from ui.window.trial import on_simulator

log = logging.getLogger("ui.main_window")
PLAN_TICK_MS = 100
PLACED = ("every block runs at the Parameters tab's centre, for the shoulder and arm it "
          "shows: change them there")
"""Where a plan's blocks are placed (core.plan.Block.parameters over the form's trial), said
with a block the patient cannot reach: the table has no centre to change."""
CONNECT_FIRST = "connect the robot first (Build, then Connect"
ROBOT_GONE = "the robot was disconnected; Connect, then Resume"
"""Why a plan paused itself when the robot was disconnected between its rounds (the
plan's status line, the message line and its record)."""
RESUME_WAITS = "Resume waits for the robot: Connect, then Resume."
HANDS_OFF_AT_CONNECT = "hands off the handle"
"""Said only for the robot: the simulator's sensor takes its zero with nobody at a handle
(ui.window.trial.on_simulator; the Connect says the same)."""


class PlanControl:
    """The Plan tab and the plan's run (a part of MainWindow)."""

    plan_runner: PlanRunner | None = None

    def on_running_plan(self) -> bool:
        """The therapist is on the Plan tab while a plan runs: its trials' start and end
        leave them there (they took them to Trajectory, then Report, at each round, away
        from Pause and Stop plan); any other tab follows a trial as for one trial."""
        return self.plan_runner is not None and self.tabs.currentWidget() is self.plan_tab
    plan_start_waits: tuple[int, int] | None = None
    """(block, round) of a plan's Start waiting for the last trial to be saved
    (WindowConsole.start), or None."""
    _plan_asked: object | None = None
    """The registry call whose answer the Plan tab waits for (`_ask_plan`)."""
    _plan_starting: Awaited | None = None
    """Start plan's run being begun in the registry (the window closing ends it)."""
    plan_records = 0
    """The run's records on the job thread, not yet done (the run ends after them)."""
    stored_plan = None
    plan_ended = None
    """(the ended run's last PlanState, the trial built then): what the patient's screen
    shows once the runner is gone, until another trial is built."""
    plan_form_before: tuple[str, object] | None = None
    """(the patient's code, the Parameters form) as Start plan was pressed: the form goes
    back to it when the plan ends (it kept the last block's trial, and the therapist's
    next trial of their own ran the plan's 5-minute block)."""

    def _build_plan_tab(self) -> PlanTab:
        self.plan_runner = None
        self.stored_plan = None
        self._plan_refusal = None  # the event line of the last Start plan refused
        self.plan_tab = PlanTab(template_titles())
        t = self.plan_tab
        t.copy_requested.connect(self._copy_template)
        t.block_changed.connect(self._change_block)
        t.start_requested.connect(self.start_plan)
        t.pause_requested.connect(lambda: self._plan_command("pause"))
        t.resume_requested.connect(lambda: self._plan_command("resume"))
        t.stop_requested.connect(self.stop_plan)
        return t

    def _connect_plan(self) -> None:
        """The loop's answers to the plan, each after the window has taken it (the
        window's Build sets the built trial the plan's Start then runs)."""
        self.plan_timer = QTimer(self)
        self.plan_timer.setInterval(PLAN_TICK_MS)
        self.plan_timer.timeout.connect(self._plan_tick)
        b = self.bridge
        b.trial_started.connect(self._plan_trial_started)
        b.trial_ended.connect(lambda *_: self._plan_event("trial_ended"))
        b.fault_raised.connect(self._plan_fault)
        b.loop_lost.connect(lambda message: self._plan_event("fault", message))
        b.replied.connect(self._plan_reply)
        b.state_changed.connect(self._plan_robot_state)
        self.registration_tab.patient_selected.connect(lambda p: self.show_plan_of(p.code))

    # ------------------------------------------------------------------ the plan
    # The plan's records are asked of the registry on the job thread, the Plan tab waiting
    # meanwhile (PlanTab.show_waiting): on a shared registry whose network drops everything
    # each call waited its bounded wait (app.records.registry.postgres.deadline) on the
    # window's thread. An answer is shown only if it is the last one asked (another
    # patient chosen meanwhile asks for theirs) and the window is still open.
    def _ask_plan(self, words: str, work, answer, *, dropped=None) -> None:
        """`work()` on the job thread, the tab saying `words` meanwhile; `answer(result)`
        (an exception raised is the result) on the window's thread, or `dropped(result)`
        when a later ask made it stale."""
        asked = self._plan_asked = object()
        self.plan_tab.show_waiting(words)
        self._show_plan_buttons()

        def ask():
            try:
                return work()
            except Exception as exc:  # a refusal or a damaged registry: said on the tab
                return exc

        def answered(result) -> None:
            if self.jobs.closed:
                return  # the window closed: nothing is shown (a run begun is ended there)
            if self._plan_asked is not asked:
                if dropped is not None:
                    dropped(result)
                return
            self._plan_asked = None
            self.plan_tab.show_waiting("")
            answer(result)
            self._show_plan_buttons()

        self.jobs.run(ask, answered)

    def plan_waiting(self) -> bool:
        """The registry is being asked for the plan (read, saved, a run begun)."""
        return self._plan_asked is not None

    def show_plan_of(self, code: str) -> None:
        """Read patient `code`'s plan (on the job thread) and show it; another patient's
        plan shown till then is taken off at once (a patient's choice is read on the job
        thread too: the plan copied for the patient before could be shown as hers)."""
        if self.stored_plan is not None and self.stored_plan.patient_code != code:
            self.stored_plan = None
            self.plan_tab.set_plan(None, "")
        self._ask_plan(f"Reading patient {code}'s plan…",
                       lambda: self.registry.current_plan(code),
                       lambda stored: self._show_plan(code, stored))

    def _show_plan(self, code: str, stored) -> None:
        if isinstance(stored, Exception):  # a plan this console cannot run, a damaged registry
            self.stored_plan = None
            self.plan_tab.set_plan(None, f"Patient {code}'s plan cannot be shown: {stored}")
            return
        self.stored_plan = stored
        # a Start plan refusal was of the plan shown before: it stayed over the new one
        self._withdraw(self._plan_refusal)
        self._plan_refusal = None
        if stored is None:
            self.plan_tab.set_plan(None, f"Patient {code} has no plan yet: copy a template "
                                         "to them.")
        else:
            origin = f", changed from plan {stored.based_on}" if stored.based_on else ""
            self.plan_tab.set_plan(stored.plan, f"Plan {stored.id} of patient {code}: "
                                                f"{stored.plan.name}{origin}")

    def _save_plan(self, words: str, refused: str, save) -> None:
        """`save()` on the job thread, then the patient's plan read again and shown (after
        a refusal too: the table shows what the registry keeps, never the change it
        refused), with the refusal, `refused` first, in one line, or what `save()` says
        (a str: a template fitted to the patient)."""
        code = self.patient.code

        def work():
            try:
                said = save()
            except Exception as exc:  # TemplateError, InvalidRecordError: one line
                return f"{refused}: {exc}", self.registry.current_plan(code)
            # the other saves return what the registry gives back: nothing to say
            return said if isinstance(said, str) else "", self.registry.current_plan(code)

        def answer(result) -> None:
            if isinstance(result, Exception):  # the plan read again could not be
                self._show_plan(code, result)
                return
            refusal, stored = result
            self._show_plan(code, stored)
            self.plan_tab.show_refusal(refusal)

        self._ask_plan(words, work, answer)

    def _copy_template(self, name: str) -> None:
        if self.patient is None:
            self.plan_tab.show_refusal("Choose the patient first (Registration tab).")
            return
        code = self.patient.code
        # fitted to the patient's arm and the robot as the form has them (core.plan.fit_plan):
        # the First session's reach was copied as it is and refused at Start plan for an arm
        # of 57 cm. A form that refuses (a measurement not kept yet) copies it as it is:
        # Start plan checks it against the form then
        try:
            setup = self.parameters_tab.parameters()
        except Exception:  # the form's own refusal, said under its field
            setup = None
        robot = self.parameters_tab.robot

        def copy() -> str:
            template = load_template(name, fit_to=setup, robot=robot, units=SCREEN)
            self.registry.save_plan(code, template.plan, template=name)
            if not template.fitted:
                return ""
            return "Fitted to this patient: " + "; ".join(
                line.rstrip(".") for line in template.fitted) + "."

        self._save_plan(f"Copying the template to patient {code}…", "Not copied", copy)

    def _change_block(self, index: int, block) -> None:
        stored = self.stored_plan
        if stored is None or self.patient is None or self.plan_waiting():
            return  # the table waits while the plan is asked for (PlanTab._edited)
        self._save_plan(f"Saving the change to block {index + 1}…", "Not changed",
                        lambda: self.registry.change_block(stored.id, index, block))

    def start_plan(self) -> None:
        """Start plan: the plan's first round built and started by the runner; the robot
        must be connected (Build, Connect) and the patient registered, as for a trial. The
        run is begun in the registry on the job thread ("Starting the plan…"), and the plan
        runs at the answer only if what it was pressed with still holds."""
        why = ""
        if self.plan_waiting():
            why = (f"the plan is not shown yet ({self.plan_tab.waiting.rstrip('…')}): press "
                   "Start plan once it is")
        elif self.stored_plan is None or self.patient is None:
            why = "choose the patient and give them a plan first"
        elif self.registration is None:
            why = "confirm the patient's session on the Registration tab first"
        else:
            # the plan against the patient before the robot: a block out of reach is said
            # before Build and Connect (it was said only after them, a wasted round trip)
            try:
                base = self.parameters_tab.parameters()
            except Exception as exc:  # the form's own refusal
                why = f"the Parameters tab: {exc}"
            else:
                # in the form's own units (its refusals say cm), never the check's SI
                problems = check_plan(self.stored_plan.plan, base, self.parameters_tab.robot,
                                      units=SCREEN)
                why = f"{problems[0].rstrip('.')} ({PLACED})" if problems else ""
        if not why and self.latch.holds_robot():
            why = self.latch.holds_robot()
        elif not why and self.state != State.CONNECTED:
            why = CONNECT_FIRST + ("" if self._plan_on_simulator() else
                                   f", {HANDS_OFF_AT_CONNECT}") + ")"
        if why:
            self._refuse_plan(why)
            return
        stored, registration, registry = self.stored_plan, self.registration, self.registry
        awaited = self._plan_starting = Awaited()

        def begin() -> int:
            run_id = registry.begin_plan_run(stored.id)
            abandoned = awaited.answered(run_id)
            if abandoned:  # the window closed meanwhile: the run ends here, not 'running'
                _end_unrun(registry, run_id, abandoned)
            return run_id

        def begun(run_id) -> None:
            self._plan_starting = None
            if isinstance(run_id, Exception):
                self._refuse_plan(f"{run_id}")
                return
            gone = self._plan_gone(stored, registration, base)
            if gone:
                self._end_unrun(run_id, gone)
                self._refuse_plan(gone)
                return
            self.plan_runner = PlanRunner(stored.plan, base, WindowConsole(self, run_id),
                                          next_round=staircase_rounds())
            self.plan_form_before = (registration.patient_code, base)
            self.plan_tab.show_refusal("")
            self.plan_start_waits = None
            self.plan_timer.start()
            self.plan_runner.start(time.monotonic())
            self._refresh_buttons()  # Build and Start are the plan's now (ui.views.readiness)

        def dropped(run_id) -> None:  # another patient chosen while it was begun
            self._plan_starting = None
            if not isinstance(run_id, Exception):
                self._end_unrun(run_id, "another patient was chosen before the plan started")

        self._ask_plan("Starting the plan…", begin, begun, dropped=dropped)

    def _plan_on_simulator(self) -> bool:
        """The robot the next Connect connects is the simulator: the one built, or before
        a Build the one the Parameters tab's Build would build."""
        if self.state == State.BUILT:
            return on_simulator(self.built_backend)
        return self.parameters_tab.backend().name != HARDWARE

    def _refuse_plan(self, why: str) -> None:
        why = why.rstrip(".")  # a check's sentence ends in its own full stop
        self._plan_refusal = self._say(f"Start plan refused: {why}.", problem=True)
        self.plan_tab.show_refusal(f"Start plan refused: {why}.")

    def _plan_gone(self, stored, registration, base) -> str:
        """What Start plan was pressed with and no longer holds, in words ('' when all
        does): the robot connected and not held, the same patient's session confirmed, the
        same plan and form."""
        if self.latch.holds_robot():
            return self.latch.holds_robot()
        if self.state != State.CONNECTED:
            return f"the robot is {self.state.label.lower()}"
        if self.registration != registration or self.stored_plan is not stored:
            return ("another patient, session or plan was chosen while the plan was being "
                    "started: press Start plan again")
        try:
            same = self.parameters_tab.parameters() == base
        except Exception:  # the form refuses what it shows now
            same = False
        return "" if same else ("the Parameters tab changed while the plan was being "
                                "started: press Start plan again")

    def _end_unrun(self, run_id: int, why: str) -> None:
        """A run begun for a Start plan that runs nothing: ended (stopped, with why) on
        the job thread, never left 'running'."""
        registry = self.registry
        self.jobs.run(lambda: _end_unrun(registry, run_id, why), lambda _: None)

    def _close_plan_start(self) -> bool:
        """The window closes: a run being begun for Start plan is ended on the job thread
        (by the job itself when its answer has not come yet), never left 'running'. True
        when one was being begun."""
        awaited, self._plan_starting = self._plan_starting, None
        if awaited is None:
            return False
        run_id = awaited.abandon("the console closed before the plan's first round")
        if run_id is not None:
            self._end_unrun(run_id, awaited.abandoned)
        return True

    def stop_plan(self) -> None:
        if self.plan_runner is not None:
            self.plan_runner.stop(time.monotonic())
            self._plan_tick()

    def _plan_command(self, what: str) -> None:
        if what == "resume" and self.plan_runner is not None and self.state != State.CONNECTED:
            # the next round needs the robot: resumed without it, its Start was refused and
            # the plan ended 'faulted'
            self._say(RESUME_WAITS, problem=True)
            self.plan_tab.show_refusal(RESUME_WAITS)
            return
        if what == "resume":
            self.plan_tab.show_refusal("")
        if self.plan_runner is not None:
            getattr(self.plan_runner, what)(time.monotonic())
            self._plan_tick()

    def emergency_stop(self) -> None:
        super().emergency_stop()
        self._plan_event("emergency_stop", "emergency stop pressed")

    # ------------------------------------------------------------------ the loop's answers
    def _plan_event(self, what: str, *args) -> None:
        runner = self.plan_runner
        if runner is not None:
            getattr(runner, what)(time.monotonic(), *args)
            self._plan_tick()

    def _plan_robot_state(self, state: int, _reason: str) -> None:
        """The robot disconnected while the plan runs (Disconnect between rounds: in a
        rest, or as a round is built): the plan pauses and says why (ROBOT_GONE). Only
        Disconnect leads to BUILT from a connected robot (device.loop.states); IDLE is the
        loop's shutdown, as the window closes, which is no pause."""
        runner = self.plan_runner
        if runner is None or State(state) != State.BUILT or runner.held \
                or runner.phase == ENDED:
            return
        self._plan_event("robot_gone", ROBOT_GONE)
        self._say_held()

    def _plan_reply(self, command: str, ok: bool, message: str) -> None:
        if command == "build":
            self._plan_event("built", ok, message)
        elif command == "start_trial" and not ok:
            self._plan_event("refused", message)

    def _start_not_run(self, why: str) -> None:
        super()._start_not_run(why)
        self._plan_event("refused", why)

    def _plan_trial_started(self, *_args) -> None:
        if self.trial_id is not None:
            self._plan_event("started", self.trial_id)

    def _plan_fault(self, code: int, message: str, *_args) -> None:
        if int(code) == int(Fault.ESTOP):
            self._plan_event("emergency_stop", message)
        else:
            self._plan_event("fault", message)

    def _finalized(self, trial_id: int, done) -> None:
        super()._finalized(trial_id, done)
        runner = self.plan_runner
        if runner is None:
            return
        try:
            dose = trial_dose(done.path)
            movements, active = dose.movements, dose.active_s
        except Exception as exc:  # said, never silently zero
            self._say(f"Trial {trial_id} counts no movement in the plan: {exc}", problem=True)
            movements, active = 0, 0.0
        figures = done.analysis.to_metrics() if done.analysis is not None else None
        runner.finished(time.monotonic(), trial_id, done.status, movements, active, figures,
                        done.proposal)
        self._plan_tick()

    def _after_trial(self, done, answers) -> None:
        """The trial's saved line (ui.window.after_trial) comes after its registry reads,
        when the plan has already moved on: a plan paused meanwhile for the robot says so
        again, so the event line shows what holds the plan, not the saved trial."""
        super()._after_trial(done, answers)
        runner = self.plan_runner
        if runner is not None and runner.held and runner.phase != ENDED:
            self._say_held()

    def _say_held(self) -> None:
        self._say(f"Plan paused: {self.plan_runner.held}.", problem=True)

    def _plan_tick(self) -> None:
        runner = self.plan_runner
        if runner is None:
            return
        now = time.monotonic()
        runner.tick(now)
        waits = self.plan_start_waits
        if waits is not None and not self.saving():
            self.plan_start_waits = None
            if runner.phase == STARTING:  # not stopped or ended meanwhile
                runner.console.start(*waits)
        state = runner.state(now)
        self.plan_tab.status.setText(state.line())
        # the blocks as the robot runs them, a proposal taken included
        self.plan_tab.show_run(runner.plan, runner.blocks)
        if state.phase == ENDED and self.trial_id is None and runner.trial_id is None \
                and not self.plan_records:
            self.plan_timer.stop()
            line = state.line()  # "Plan complete (…)": a sentence before the next
            self._say(line + ("" if line.endswith(".") else ".") + self._form_back(),
                      problem=state.outcome not in ("complete",))
            self.plan_runner = None
            self.plan_start_waits = None  # a Start the run's end made moot
            self._refresh_buttons()  # Build and Start are the therapist's again
            # the patient's screen keeps the session's end until the next Build
            self.plan_ended = (state, self.built)
            if self.patient is not None:
                self.show_plan_of(self.patient.code)
                self.progress.set_patient(self.patient.code)  # the run's dose, as it ended
            self.plan_tab.status.setText(state.line())
        self._show_plan_buttons()

    def _form_back(self) -> str:
        """The Parameters form back to what it showed as Start plan was pressed, for the
        same patient (another's form is theirs); the words that say so ('' when not)."""
        before, self.plan_form_before = self.plan_form_before, None
        registration = self.registration
        if before is None or registration is None or registration.patient_code != before[0]:
            return ""
        self.parameters_tab.set_parameters(before[1])
        return (" The Parameters tab is back to the trial it showed before the plan: press "
                "Build to run it.")

    def _show_plan_buttons(self) -> None:
        runner = self.plan_runner
        self.plan_tab.show_running(runner is not None, runner is not None and
                                   runner.phase == PAUSED)


def _end_unrun(registry, run_id: int, why: str) -> None:
    """On the job thread: the run of a Start plan that ran nothing ended as stopped."""
    try:
        registry.end_plan_run(run_id, "stopped", why)
    except Exception as exc:  # said in the log; the next start marks it interrupted
        log.error("plan run %d, begun for a Start plan that ran nothing, could not be "
                  "ended: %s", run_id, exc)
        return
    log.info("plan run %d ended before its first round: %s", run_id, why)
