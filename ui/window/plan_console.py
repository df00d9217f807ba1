"""What a session plan's runner (app.plans.runner.PlanRunner) asks of the window: its Build
and Start, the robot buttons' own methods (one truth: the form shows each round's trial as
it is built, and Start runs what Build built), the loop's Stop, and the registry's record
of the run, on the job thread. A part of ui.window.plan, which keeps the runner."""

from __future__ import annotations

import logging
import time

from app.plans.record import record_plan_event
from device.loop.states import State

log = logging.getLogger("ui.main_window")


class WindowConsole:
    """What the runner asks of the window: its Build and Start (the robot buttons' own
    methods), the loop's Stop, and the registry's record of the run."""

    def __init__(self, window, run_id: int) -> None:
        self.window = window
        self.run_id = run_id

    def build(self, parameters) -> None:
        w = self.window
        w.parameters_tab.set_parameters(parameters)
        w._pending_build = None
        w.build()  # the Build button's path: the form, checked, to the loop
        if w._pending_build is None:  # refused before the loop was asked
            last = w.messages.last
            w.plan_runner.built(time.monotonic(), False, last.text if last else "refused")

    def start(self, block: int, round_: int) -> None:
        w = self.window
        if w.trial_id is None and w.saving():
            # the last trial still being finished, or the registry's reads after it on the
            # job thread: Start would be refused ("the last trial to be saved: a moment")
            # and the plan end as faulted when a round's Build came back first (a game
            # block's next round, no rest between). The Start waits for them instead:
            # PlanControl._plan_tick starts it once they are done.
            w.plan_start_waits = (block, round_)
            return
        w.plan_start_waits = None
        w.start_trial()  # the Start button's path: registered, then started
        # refused at once; a Start being registered says a refusal later (_start_not_run)
        if w.trial_id is None and not w.registering():
            last = w.messages.last
            w.plan_runner.refused(time.monotonic(), last.text if last else "refused")

    def stop(self) -> None:
        if self.window.state == State.RUNNING:
            self.window.bridge.stop()

    # The run's records go to the registry on the job thread, in order after the trial's
    # registration and before its finish: a trial's record is made as it starts, the
    # robot running, and a shared registry on a silent network held the window for its
    # bounded wait (app.records.registry.postgres.deadline). A failure is said as the
    # job thread's are (MessageLine._job_failed).
    def record_trial(self, block, round_, trial_id, planned_s) -> None:
        self._record(self.window.registry.record_plan_trial, block, round_, trial_id,
                     planned_s)

    def record_rest(self, block, planned_s, taken_s) -> None:
        self._record(self.window.registry.record_plan_rest, block, planned_s, taken_s)

    def record_event(self, block, words) -> None:
        registry = self.window.registry
        self._record(lambda *args: record_plan_event(registry, *args), block, words)

    def end(self, status: str, reason: str) -> None:
        self._record(self.window.registry.end_plan_run, status, reason)
        log.info("plan run %d ended: %s %s", self.run_id, status, reason)

    def _record(self, record, *args) -> None:
        """`record(run id, *args)` on the job thread."""
        w, run_id = self.window, self.run_id
        w.plan_records += 1

        def settled() -> None:
            w.plan_records -= 1
            w._plan_tick()  # the run ends once its records are done

        w.jobs.run(lambda: record(run_id, *args), lambda _: None, settled=settled)
