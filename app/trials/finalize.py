"""After a trial's file is closed: its metrics, stored in the file and in the registry.

The recorder closes the trial file the moment the trial ends (complete, stopped or
faulted); this step runs afterwards, off the loop and off the window's thread. A trial
too short to measure (a fault in the first instants) is still registered, with no metrics
and a note saying why.
"""

from __future__ import annotations

import datetime
import logging
import time
from dataclasses import dataclass
from pathlib import Path

from app.errors import AppError
from app.records.assistance import AssistanceInEffect
from app.records.registry.provenance import file_checksum
from app.records.store import RecordStore
from app.trials.analysis import CHANNELS_USED, Analysis, analyse_data
from app.trials.assistance_timeline import CHANNELS_NEEDED
from app.trials.progression import Proposal, propose
from app.trials.reader import TrialData, read_trial
from device.errors import RecordingError
from device.recording.trialfile import write_metrics
from device.recording.trialfile.recover import clear_open_flags

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class Finalized:
    trial_id: int
    path: Path
    status: str
    analysis: Analysis | None
    notes: tuple[str, ...]
    proposal: Proposal | None = None
    """What the console proposes for the patient's next trial (app.trials.progression);
    None after an assessment, which takes no part in the exercise's progression."""


def finalize_trial(registry: RecordStore, trial_id: int, status: str | None = None,
                   reason: str = "", analysis: Analysis | None = None) -> Finalized:
    """Analyse the trial's file, write its metrics into it and into the registry, with the
    assistance levels it ran (its file's, never the form's), and propose the next trial
    from what it ran: the level in effect at the end of its exercise (no proposal after an
    assessment trial: its task's protocol is fixed, and the next exercise follows on from
    the exercise before).

    `status` defaults to the one the file records (complete, stopped_early, faulted,
    recording_lost); `reason`, why it ended so, to the file's last fault (the registry
    keeps it: issue 13 #18). `analysis`, when the caller has just analysed the trial and
    written its metrics into the file (a headless run), is taken as is instead of
    reading the samples back and analysing them again. Raises AppError when the file
    cannot be read at all.
    """
    trial = registry.trial(trial_id)
    path = registry.trial_path(trial)
    # only what the metrics and the levels need (a long trial)
    data = read_trial(path, CHANNELS_NEEDED if analysis is not None
                      else (*CHANNELS_USED, *CHANNELS_NEEDED))
    status = status or data.status
    if status == "recording":
        status = "recording_lost"  # never closed: the recorder died with it
    notes = list(data.notes)
    metrics: dict[str, float] = {}
    if analysis is not None:
        metrics = analysis.to_metrics()
        notes.extend(analysis.notes)
    else:
        analysis, metrics = _analyse_into(path, data, notes)
    # a complete trial needs no reason; any other keeps the one given or the file's
    reason = "" if status == "complete" else reason or last_fault(data.events)
    ran = _levels(data, notes)
    registry.finish_trial(trial_id, status, metrics, datetime.datetime.now(datetime.UTC),
                          reason, ran, data.backend or None, checksum=_checksum(path, notes))
    parameters = data.parameters
    proposal = None
    if _is_assessment(parameters, trial):
        # an assessment runs its task's fixed protocol, outside the exercise's progression:
        # no proposal, which the next exercise trial would otherwise be offered and take
        log.info("trial %s: an assessment: no proposal for the next trial", trial_id)
    else:
        if parameters is not None and ran is not None:
            # the next trial starts from where this one ended, not from how it was built
            parameters = parameters.replace(assistance_level=ran.at_end)
        proposal = propose(parameters, metrics, status, _ran_with(registry, trial))
        registry.record_proposal(trial_id, proposal.to_dict())
        log.info("trial %s: proposed for the next trial: %s", trial_id, proposal.reason)
    for note in notes:
        log.info("trial %s: %s", trial_id, note)
    return Finalized(trial_id, path, status, analysis, tuple(notes), proposal)


def _checksum(path: Path, notes: list[str]) -> str | None:
    """The file as finished (its metrics written into it): what the registry keeps, so a
    copy read later can be proven to be it (app.records.registry.provenance)."""
    try:
        return file_checksum(path)
    except OSError as exc:
        notes.append(f"its file could not be read for its checksum ({exc.strerror or exc}); "
                     "the registry keeps none")
        return None


def _is_assessment(parameters, trial) -> bool:
    """Whether the trial is a run of an assessment task (TrialParameters.assessment), by
    its file's parameters or, when the file holds none, the registry's."""
    if parameters is not None:
        return bool(parameters.assessment)
    return bool(trial.parameters.get("assessment"))


def _levels(data: TrialData, notes: list[str]) -> AssistanceInEffect | None:
    """The levels the trial ran with, None (and a note) when its file cannot say."""
    ran = data.assistance_in_effect()
    if all(0.0 <= level <= 1.0 for _, level in ran.timeline):
        return ran
    notes.append("the assistance levels it ran with are not known: the file holds neither "
                 "its parameters nor the per-tick level")
    return None


def _ran_with(registry: RecordStore, trial) -> Proposal | None:
    """The proposal this trial ran with (accepted at its Start), which sets the next
    proposal's step (app.trials.progression), or None."""
    for stored in registry.proposals_for_patient(trial.patient_code):
        if stored.next_trial_id == trial.id and stored.decision == "accepted":
            return Proposal.from_dict(stored.proposal)
    return None


def _analyse_into(path: Path, data, notes: list[str]) -> tuple[Analysis | None, dict]:
    """The trial's analysis and metrics, written into its file when it was closed; a
    trial that cannot be measured gets a note instead."""
    try:
        analysis = analyse_data(data)  # on the robot model the file says it ran
    except (AppError, ValueError) as exc:  # core refuses data it cannot measure, naming it
        notes.append(f"no metrics: {exc}")
        return None, {}
    metrics = analysis.to_metrics()
    notes.extend(analysis.notes)
    if data.status != "recording":
        try:
            write_metrics(path, metrics)
        except RecordingError as exc:
            notes.append(f"metrics not stored in the file: {exc}")
    return analysis, metrics


def unflag(path: Path) -> None:
    """Clear the "open for writing" flags a dead writer left in the trial file at `path`
    (device.recording.trialfile.recover), so that it reads again; only for a trial whose
    writer is known to be dead. A file that cannot be cleared is left as it is, for the
    reader to say what is wrong with it."""
    try:
        if clear_open_flags(path):
            log.warning("%s: its writer died with it open; its open-for-writing flags were "
                        "cleared so that it reads again", path.name)
    except (OSError, RecordingError) as exc:
        log.warning("%s: its open-for-writing flags could not be cleared: %s", path.name, exc)


def last_fault(events: list[dict]) -> str:
    """The message of the file's last fault event, '' when it has none."""
    faults = [event["message"] for event in events if event["kind"] == "fault"]
    return faults[-1] if faults else ""


def finalize_lost(registry: RecordStore, trial_id: int, reason: str = "") -> Finalized:
    """Finish a trial whose recording was lost mid-way (its recorder died): from what
    reached its file when that can be read, else as recording_lost with no metrics and a
    note saying why. Never leaves it 'recording'; `reason` (the fault the window saw) is
    kept in the registry, since the file cannot have it."""
    unflag(registry.trial_path(trial_id))
    try:
        return finalize_trial(registry, trial_id, "recording_lost", reason)
    except AppError as exc:
        registry.finish_trial(trial_id, "recording_lost", {},
                              datetime.datetime.now(datetime.UTC), reason)
        note = f"the file could not be read ({exc}); the trial is listed as recording lost"
        log.warning("trial %s: %s", trial_id, note)
        return Finalized(trial_id, registry.trial_path(trial_id), "recording_lost", None,
                         (note,))


STILL_WRITTEN_S = 10.0
"""A trial file modified this recently may be a live trial of another console on the same
data folder (the recorder flushes every 0.5 s): it is left alone."""


def finish_interrupted(registry: RecordStore, *, now: float | None = None,
                       still_written_s: float = STILL_WRITTEN_S) -> list[str]:
    """Finish the trials the registry still lists as recording: a console that closed
    abnormally during a trial (a crash, a power cut) leaves them so, although the
    recorder closed the file or it holds all but the last half second.

    Each is finalized from its file (its status, else recording_lost, and its
    metrics); a missing or unreadable file finishes it as recording_lost. The plan runs
    left running are marked interrupted (Registry.interrupt_runs). Only this station's
    (the registry's `station`): another station may be recording now. Returns one line per
    trial and run for the therapist, and logs them."""
    now = time.time() if now is None else now
    lines = []
    for trial in registry.unfinished_trials():
        path = registry.trial_path(trial)
        label = f"trial {trial.id} ({path.name})"
        try:
            if now - path.stat().st_mtime < still_written_s:
                continue
        except OSError:
            registry.finish_trial(trial.id, "recording_lost", {},
                                  datetime.datetime.now(datetime.UTC))
            lines.append(f"{label} was interrupted and its file is missing; "
                         "it is listed as recording lost")
            continue
        unflag(path)
        try:
            done = finalize_trial(registry, trial.id)
        except AppError as exc:
            registry.finish_trial(trial.id, "recording_lost", {},
                                  datetime.datetime.now(datetime.UTC))
            lines.append(f"{label} was interrupted and its file cannot be read ({exc}); "
                         "it is listed as recording lost")
            continue
        lines.append(f"{label} was interrupted; its file was kept and it is now listed "
                     f"as {done.status.replace('_', ' ')}")
    # and the plan runs it was carrying out (this station's only: another's may be going)
    for run_id in registry.interrupt_runs():
        lines.append(f"plan run {run_id} was interrupted when the console ended during it; "
                     "it is listed as interrupted")
    for line in lines:
        log.warning("%s", line)
    # a write into a finished trial's file that the console did not live to record
    # (app.trials.rewrite: its lines are logged there)
    from app.trials.rewrite import settle_marked
    return lines + settle_marked(registry)
