"""A plan run on the live loop without a window: the runner (app.plans.runner) driven
through the device link (device.loop.client.DeviceClient), the registry keeping each
trial, rest and the run's end. `rehab plan run` and the end-to-end tests use it; the
window drives the same runner through its own buttons (ui.window.plan).

Each round is what the window's Build and Start do: Build with the round's parameters
(connected, the simulator is opened again for the new exercise, as at a Build in the
window), the trial registered then started, its file finished by the recorder and the
trial finalized into the registry (metrics, levels, the next proposal); then its dose is
read from its file. A fault, the emergency stop (`press_estop`) or the therapist's Stop
(`press_stop`) end the plan at once; the loop has made the robot safe.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

from app.errors import AppError
from app.games.rounds import staircase_rounds
from app.plans.dose import trial_dose
from app.plans.record import record_plan_event
from app.plans.runner import ENDED, PlanRunner, PlanState
from app.records.registry import StoredPlan
from app.trials.finalize import finalize_lost, finalize_trial
from app.trials.registered import take_back
from core.plan import check_plan
from core.trial import TrialParameters
from device.errors import DeviceError
from device.loop.client import LOOP_START_S, DeviceClient, LoopLost
from device.loop.messages import BackendConfig, FaultRaised, TrialEnded, TrialStarted
from device.loop.states import State
from device.recording.messages import RecorderNotice
from device.recording.trialfile import SubjectInfo
from device.safety.faults import Fault

log = logging.getLogger(__name__)

Watch = Callable[["LivePlan", PlanState], None]
"""Called after every turn of the driver's loop with the plan's state: where a caller
(a test, the command line's display) presses Stop, E-STOP, Pause or Resume."""


class PlanRefused(AppError):
    """A plan that cannot run for this patient (a block out of reach): nothing ran."""


@dataclass(frozen=True, slots=True)
class LiveResult:
    run_id: int
    outcome: str
    reason: str
    trial_ids: tuple[int, ...]
    elapsed_s: float


class LivePlan:
    """One run of a stored plan for patient `code` on `client` (started, not connected)."""

    def __init__(self, registry, stored: StoredPlan, client: DeviceClient,
                 backend: BackendConfig, *, base: TrialParameters | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.registry = registry
        self.stored = stored
        self.code = stored.patient_code
        self.client = client
        self.backend = backend
        self.clock = clock
        patient = registry.patient(self.code)
        self.base = base or TrialParameters().replace(**patient.trial_overrides())
        problems = check_plan(stored.plan, self.base)
        if problems:  # refused before anything runs or is registered
            raise PlanRefused(f"plan {stored.id} cannot run for patient {self.code}: "
                              f"{problems[0]}" + (f" (and {len(problems) - 1} more block(s))"
                                                  if len(problems) > 1 else ""))
        self.run_id = registry.begin_plan_run(stored.id)
        # a game block's rounds: the games' staircase between them (app.games.rounds)
        self.runner = PlanRunner(stored.plan, self.base, self, next_round=staircase_rounds())
        self._todo: list[tuple] = []
        self._params: TrialParameters | None = None
        self._trial: tuple[int, str] | None = None  # (trial id, file path) being run
        self._files: dict[str, int] = {}
        self._unfinished: set[int] = set()
        self._estop_held = False

    # ------------------------------------------------------------------ the console port
    def build(self, parameters: TrialParameters) -> None:
        self._todo.append(("build", parameters))

    def start(self, block: int, round_: int) -> None:
        self._todo.append(("start", block, round_))

    def stop(self) -> None:
        self._todo.append(("stop",))

    def record_trial(self, block: int, round_: int, trial_id: int, planned_s: float) -> None:
        self.registry.record_plan_trial(self.run_id, block, round_, trial_id, planned_s)

    def record_rest(self, block: int, planned_s: float, taken_s: float) -> None:
        self.registry.record_plan_rest(self.run_id, block, planned_s, taken_s)

    def record_event(self, block: int, words: str) -> None:
        record_plan_event(self.registry, self.run_id, block, words)

    def end(self, status: str, reason: str) -> None:
        self.registry.end_plan_run(self.run_id, status, reason)
        log.info("plan run %d ended: %s %s", self.run_id, status, reason)

    # ------------------------------------------------------------------ the therapist
    def press_stop(self) -> None:
        self.runner.stop(self.clock())

    def press_estop(self) -> None:
        """The emergency stop: the loop zeroes the torque at its next tick; the plan ends."""
        self._estop_held = True
        self.client.estop(True)
        self.runner.emergency_stop(self.clock(), "emergency stop pressed")

    def press_pause(self) -> None:
        self.runner.pause(self.clock())

    def press_resume(self) -> None:
        self.runner.resume(self.clock())

    # ------------------------------------------------------------------ the run
    def run(self, watch: Watch | None = None, timeout_s: float = 3600.0) -> LiveResult:
        """Run the plan to its end (and every trial it started to its registry row);
        returns how it ended."""
        began = self.clock()
        self.runner.start(began)
        while self.runner.phase != ENDED or self._unfinished or self._todo:
            if self.clock() - began > timeout_s:
                self.runner.fault(self.clock(), f"the plan did not end within {timeout_s:g} s")
                if not self._unfinished:
                    break
            self._act()
            for event in self.client.events(0.02):
                self._heard(event)
            self.runner.tick(self.clock())
            if watch is not None:
                watch(self, self.runner.state(self.clock()))
        trials = tuple(t for c in self.runner.counts for t in c.trials)
        return LiveResult(self.run_id, self.runner.outcome, self.runner.reason, trials,
                          self.clock() - began)

    def _act(self) -> None:
        while self._todo:
            action = self._todo.pop(0)
            try:
                self._do(action)
            except DeviceError as exc:  # the loop is gone or did not answer
                self.runner.fault(self.clock(), str(exc))
                self._unfinished_lost(str(exc))

    def _do(self, action: tuple) -> None:
        now = self.clock()
        if action[0] == "stop":
            if self.client.state == State.RUNNING:
                self.client.stop()  # refused when the trial just ended: nothing to do
            return
        if self.runner.phase == ENDED:
            return  # nothing is built or started after the plan's end
        if action[0] == "start":
            self._start()
            return
        self._params = action[1]
        reply = self.client.build(action[1], self.backend)
        if reply.ok and self.client.state == State.BUILT:
            reply = self.client.connect()
            if reply.ok:
                # a first reading, so Start finds one; the loop's first ticks after
                # Connect load its kernels, slow on a busy machine (LOOP_START_S)
                self.client.wait_for_samples(1, timeout=LOOP_START_S)
        self.runner.built(now, reply.ok, reply.message)

    def _start(self) -> None:
        params = self._params
        begun = self.registry.begin_trial(self.code, params, backend=self.backend.label,
                                          patient_kind=self.backend.patient
                                          if self.backend.kind == "simulator" else None)
        try:
            reply = self.client.start_trial(str(begun.path),
                                            SubjectInfo.from_parameters(self.code, params))
        except Exception as exc:  # the loop is gone
            take_back(self.registry, begun.trial_id, str(exc))
            self.runner.refused(self.clock(), str(exc))
            return
        if not reply.ok:
            take_back(self.registry, begun.trial_id, reply.message)
            self.runner.refused(self.clock(), reply.message)
            return
        self._files[str(begun.path)] = begun.trial_id
        self._unfinished.add(begun.trial_id)

    def _heard(self, event) -> None:
        now = self.clock()
        if isinstance(event, TrialStarted):
            trial_id = self._files.get(event.path)
            if trial_id is not None:
                self.runner.started(now, trial_id)
        elif isinstance(event, TrialEnded):
            self.runner.trial_ended(now)
        elif isinstance(event, FaultRaised):
            if event.code == Fault.ESTOP:
                self.runner.emergency_stop(now, event.message)
            else:
                self.runner.fault(now, event.message)
        elif isinstance(event, LoopLost):
            self.runner.fault(now, event.message)
            self._unfinished_lost(event.message)
        elif isinstance(event, RecorderNotice) and event.kind in ("closed", "lost"):
            trial_id = self._files.get(event.path)
            if trial_id is None or trial_id not in self._unfinished:
                return
            self._unfinished.discard(trial_id)
            if event.kind == "lost":
                done = finalize_lost(self.registry, trial_id, event.message)
            else:
                done = finalize_trial(self.registry, trial_id, event.status)
            self._count(trial_id, done)

    def _count(self, trial_id: int, done) -> None:
        try:
            dose = trial_dose(done.path)
            movements, active = dose.movements, dose.active_s
        except Exception as exc:  # an unreadable file counts nothing, said in the log
            log.warning("plan run %d: trial %d counts nothing: %s", self.run_id, trial_id, exc)
            movements, active = 0, 0.0
        # the movement's and a game's figures (game_hits, game_misses: the staircase's)
        figures = done.analysis.to_metrics() if done.analysis is not None else None
        self.runner.finished(self.clock(), trial_id, done.status, movements, active,
                             figures, done.proposal)

    def _unfinished_lost(self, message: str) -> None:
        for trial_id in sorted(self._unfinished):
            self._unfinished.discard(trial_id)
            self._count(trial_id, finalize_lost(self.registry, trial_id, message))
