"""What happened during a plan's run besides its trials and rests (the console paused it
when the robot was disconnected, then the therapist resumed it), kept in the registry with
its time: a note on the session the run's trials are in, written by the console and naming
the run and the block (app.records.registry.clinical.add_note; its `written_at` is the
event's time).

Why a note: the run's steps (app.records.registry.plans: a trial or a rest) have no kind
for an event, and a new kind is a schema change; the session's notes are where the
Clinical record shows the therapist what happened, with the time.
"""

from __future__ import annotations

from app.errors import RegistryError

AUTHOR = "the console"
"""Who the note says wrote it: the console, not a therapist."""


def record_plan_event(registry, run_id: int, block: int, words: str):
    """A note on the session of plan run `run_id`'s last trial: 'Plan run 4, block 1:
    paused: the robot was disconnected; …'. Returns the note (app.records.registry.Note).
    Raises RegistryError when the run has no trial yet (no session to note it on)."""
    run = registry.plan_run(run_id)
    trials = run.trial_steps()
    if not trials:
        raise RegistryError(f"plan run {run_id} has no trial yet: '{words}' has no session "
                            "to be noted on")
    trial = registry.trial(trials[-1].trial_id)
    return registry.add_note(trial.patient_code, trial.session_number,
                             f"Plan run {run_id}, block {block}: {words}", author=AUTHOR)
