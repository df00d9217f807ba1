"""What the window reads from the registry after each trial, read on its job thread (a part
of MainWindow): the next trial's numbers after Start's answer, and after a trial is finished
its row read back with its file checked against it (the line that says it is saved, or why
not: ui.views.saved), its patient, the proposal to offer, the Replay tab's list and the
numbers again.

Why: read on the window's thread, each read on a station whose network went silent waited
the registry's bounded wait (app.records.registry.postgres.deadline, 5 s) before the
station answered from its standby (docs/stations.md, A silent network), the window frozen
meanwhile. Start waits until they are read and shown (`reading_after`, in `saving()`): a
Start pressed right after a trial ran with the numbers confirmed before it and was refused
as a number already used, or left the proposal being read undecided.
"""

from __future__ import annotations

import dataclasses

from app.records.registry import Trial
from app.records.store import RecordStore
from ui.tabs.registration_numbers import Numbers
from ui.views.saved import saved_line


@dataclasses.dataclass(frozen=True)
class Pending:
    """A patient's pending proposal as the Parameters tab offers it (None: none)."""

    proposal: dict | None
    after: str = ""


def pending_offer(registry: RecordStore, code: str) -> Pending:
    """Patient `code`'s last proposal the registry still holds as pending (made after a
    trial, not yet decided by the next one's start), with the words naming its trial."""
    pending = registry.pending_proposal(code)
    if pending is None:
        return Pending(None)
    trial = registry.trial(pending.trial_id)
    return Pending(pending.proposal, f"After trial {trial.number} of session "
                                     f"{trial.session_number} ({trial.session_date:%d %b %Y}):")


@dataclasses.dataclass(frozen=True)
class Read:
    """The registry's answers after trial `trial_id` for patient `code` (the window's then)."""

    code: str | None
    trial: Trial
    """The trial as the registry holds it once finished (read back)."""
    file_problem: str | None
    """Why its file is not the one registered (Registry.verify_trial_file), None when it is."""
    pending: Pending | None
    trials: list[Trial] | None
    numbers: Numbers | None


class AfterTrial:
    """The registry's reads after a trial, on the job thread (a part of MainWindow)."""

    reading_after = 0
    """Reads given to the job thread and not yet shown: Start waits for them."""

    def read_numbers(self) -> None:
        """The Registration tab's numbers read again on the job thread (a trial was
        registered, or taken back) and shown once read; Start waits meanwhile."""
        reader = self.registration_tab.numbers_reader()
        if reader is not None:
            self._read_after(reader, self.registration_tab.refresh_numbers)

    def _read_after(self, read, show, then=None) -> None:
        """`read` on the job thread, `show(answers)` once read; `then()` either way (the
        answers shown, or the read's failure said)."""
        def settled() -> None:
            self.reading_after -= 1
            if then is not None:
                then()
            self._refresh_buttons()

        self.reading_after += 1
        self.jobs.run(read, show, settled=settled)
        self._refresh_buttons()

    def _finalized(self, trial_id: int, done) -> None:
        """Trial `trial_id` finished into the registry (`done`): its file in the live tabs,
        its report prepared (on the report's own thread), and the rest read on the job
        thread, then shown (`_after_trial`); then its report can be saved (`unsaved_trial`:
        what waits for a trial to be done waits for all of it)."""
        self._live_from_file(done.path)
        self.live_report = trial_id
        self.report.load_registry_trial(self.registry, trial_id)
        if self.patient is not None:
            self.progress.set_patient(self.patient.code)  # read on the tab's own threads
        if not self.on_running_plan():
            self.tabs.setCurrentWidget(self.report)
        registry, code = self.registry, self.patient.code if self.patient is not None else None
        numbers = self.registration_tab.numbers_reader() \
            if self.registration is not None else None

        def read() -> Read:
            trial = registry.trial(trial_id)
            return Read(code, trial, registry.verify_trial_file(trial),
                        pending_offer(registry, code) if code is not None else None,
                        registry.trials_for_patient(code) if code is not None else None,
                        numbers() if numbers is not None else None)

        def then() -> None:
            self.unsaved_trial = trial_id

        self._read_after(read, lambda answers: self._after_trial(done, answers), then)
        self.store_trials()  # a copy in the department's trial store, when it has one

    def _after_trial(self, done, answers: Read) -> None:
        self._say(*saved_line(answers.trial, answers.file_problem))
        if answers.code is None or self.patient is None or self.patient.code != answers.code:
            return  # another patient chosen meanwhile: choosing showed their own
        if done.proposal is None or answers.trial.patient_code != answers.code:
            # a trial that proposes nothing (an assessment) leaves the exercise's pending
            # proposal where it was: offered still, as after a restart; and a patient
            # chosen while the trial ran is offered their own, never the trial's patient's
            self._offer_pending_proposal(answers.code, answers.pending)
        else:
            self.parameters_tab.show_proposal(done.proposal)
        if answers.numbers is not None:
            self.registration_tab.refresh_numbers(answers.numbers)
        else:  # nobody confirmed (a number edited meanwhile): the session line's count
            self.registration_tab.refresh_count()
        self.replay.set_patient(answers.code, answers.trials)
