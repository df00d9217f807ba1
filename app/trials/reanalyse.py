"""Stored trials' figures re-computed from their files (`rehab reanalyse`): after the
console's analysis changed (the robot's share of the work counting its help alone, core.work;
a record analysed before has no `robot_help_work_J` and reads its share as NaN,
core.work.drop_old_share), the registry's figures of the trials recorded before are made
those of today's analysis.

Each trial gets the analysis a finished trial gets (app.trials.analysis.analyse_data, which
app.trials.finalize runs), from its file as recorded:

* the file is never written: read only after it is proven the one recorded (its SHA-256
  against the registry's checksum, app.exports.plan.verified_place: the data folder's
  file, else the shared trial store's copy) and against its own seal (the reader); a
  trial whose file is missing, changed or unreadable, or that cannot be measured, is
  listed with why and skipped, and the run goes on;
* the registry's figures are replaced by the new ones, keeping any figure the analysis
  does not make (the circle task's figures of both ways, app.assessments.runner), with a
  note on the trial saying which analysis made them (app.trials.analysis.ANALYSIS and the
  console's version), when, who ran it, and each changed figure's old and new value, in
  one transaction per trial (Registry.record_reanalysis);
* a figure the analysis gives again, to rounding (`same_figure`), is kept as stored; a
  trial whose figures all are is left as it is: running it twice changes nothing the
  second time;
* a trial marked invalid is re-analysed and stays invalid (its marks are not touched);
  one still recording is left to its end (app.trials.finalize).

`dry_run` computes and lists the same changes and stores nothing.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from app.errors import AppError
from app.exports.plan import TrialSource, registry_source, verified_place
from app.records.registry import Trial
from app.records.registry.values import metrics_json, parse_metrics
from app.records.store import RecordStore
from app.trials.analysis import ANALYSIS, CHANNELS_USED, analyse_data
from app.trials.reader import read_trial
from core.errors import CoreError
from device.errors import DeviceError
from device.recording.trialfile import software_version
from device.safewrite import folded

CHANGED, UNCHANGED, SKIPPED = "changed", "unchanged", "skipped"
BY_DEFAULT = "rehab reanalyse"
MAX_NOTE_CHANGES = 60
"""Changed figures a note lists by name (the rest counted): a note holds 10,000 characters."""


@dataclass(frozen=True, slots=True)
class Outcome:
    """One trial's re-analysis: CHANGED (its figures' `changes`, old → new), UNCHANGED, or
    SKIPPED with `reason`; `stored` whether the registry now holds the new figures."""

    trial: Trial
    result: str
    changes: tuple[tuple[str, float, float], ...] = ()
    reason: str = ""
    stored: bool = False
    notes: tuple[str, ...] = ()

    def line(self) -> str:
        """The trial's line in the command's list."""
        head = (f"trial {self.trial.id} ({self.trial.patient_code} session "
                f"{self.trial.session_number} trial {self.trial.number})")
        if self.result == SKIPPED:
            return f"{head}: skipped: {self.reason}"
        if self.result == UNCHANGED:
            return f"{head}: unchanged"
        verb = "changed" if self.stored else "would change"
        return f"{head}: {verb} {len(self.changes)} figure(s): {changes_text(self.changes)}"


def figure_text(value: float) -> str:
    """A figure as the change list and the note write it: 6 significant digits, 'none'
    for NaN (undefined, or not computed then)."""
    return "none" if not math.isfinite(value) else f"{value:.6g}"


def changes_text(changes) -> str:
    """Changed figures as the change list and the note write them: 'key old → new; …'."""
    return "; ".join(f"{key} {figure_text(old)} → {figure_text(new)}"
                     for key, old, new in changes)


def trials_of(registry: RecordStore, code: str | None = None,
              session: int | None = None) -> list[Trial]:
    """The trials to re-analyse: one session of a patient's, a patient's, or every
    patient's (`code` None), by patient, session and trial number."""
    if code is None:
        return [t for p in registry.patients() for t in registry.trials_for_patient(p.code)]
    if session is None:
        return registry.trials_for_patient(code)
    return registry.trials(code, session)


def reanalyse(registry: RecordStore, trials: Iterable[Trial], *, dry_run: bool = False,
              by: str = BY_DEFAULT,
              progress: Callable[[int, Outcome], None] | None = None) -> list[Outcome]:
    """Re-analyse `trials` (see the module's doc); `progress(done, outcome)` after each."""
    outcomes = []
    if not dry_run:
        from app.trials.rewrite import settle_all

        trials = list(trials)
        settle_all(registry, trials)  # a write into a file its console did not record
        trials = [registry.trial(t.id) for t in trials]
    for done, trial in enumerate(trials, 1):
        outcome = reanalyse_trial(registry, trial, dry_run=dry_run, by=by)
        outcomes.append(outcome)
        if progress is not None:
            progress(done, outcome)
    return outcomes


def reanalyse_trial(registry: RecordStore, trial: Trial, *, dry_run: bool = False,
                    by: str = BY_DEFAULT) -> Outcome:
    """One trial's re-analysis (see the module's doc)."""
    if not trial.finished:
        return Outcome(trial, SKIPPED, reason="still recording: its figures are computed "
                                              "when it ends")
    try:
        path, place_note = verified_place(_source(registry, trial))
        data = read_trial(path, CHANNELS_USED)
        checksum_note = _unverified(trial)
        analysis = analyse_data(data)
    except (AppError, CoreError, DeviceError, ValueError, OSError) as exc:
        return Outcome(trial, SKIPPED, reason=folded(exc))
    # as the registry stores them and reads them back (JSON: NaN is null)
    made = parse_metrics([metrics_json(analysis.to_metrics())])[0]
    changes = tuple((key, trial.metrics.get(key, math.nan), value)
                    for key, value in made.items()
                    if not same_figure(trial.metrics.get(key, math.nan), value))
    new = {**trial.metrics, **{key: value for key, _, value in changes}}
    notes = tuple(n for n in (place_note, checksum_note, *analysis.notes) if n)
    if not changes:
        return Outcome(trial, UNCHANGED, notes=notes)
    if dry_run:
        return Outcome(trial, CHANGED, changes, notes=notes)
    try:
        registry.record_reanalysis(trial.id, trial.metrics, new,
                                   _note(changes, data.software_version), by=by)
    except AppError as exc:
        return Outcome(trial, SKIPPED, changes, reason=f"not stored: {folded(exc)}",
                       notes=notes)
    return Outcome(trial, CHANGED, changes, stored=True, notes=notes)


def _source(registry: RecordStore, trial: Trial) -> TrialSource:
    """The trial as a source to find its recorded file (app.exports.plan)."""
    return registry_source(registry, trial, None, "")


def _unverified(trial: Trial) -> str:
    if trial.checksum is not None:
        return ""
    return ("the registry keeps no checksum of its file (a trial recorded before schema v10): "
            "the file was verified against its own seal only")


def same_figure(old: float, new: float) -> bool:
    """Whether a stored figure is the one the analysis gives again, to rounding: a trial
    analysed as it was recorded (a block at a time, app.trials.analysis.analyse_stored)
    has the figures of the whole analysis to the last digits, which are not a change and
    are kept as stored."""
    if math.isnan(old) or math.isnan(new):
        return math.isnan(old) and math.isnan(new)
    return math.isclose(old, new, rel_tol=SAME_TO, abs_tol=1e-12)


SAME_TO = 1e-9
"""The relative difference under which a figure is the same (rounding: blockwise sums)."""


def _note(changes, recorded_by: str) -> str:
    """The note stored with the new figures: which analysis, and what changed."""
    listed = changes_text(changes[:MAX_NOTE_CHANGES])
    more = len(changes) - MAX_NOTE_CHANGES
    return (f"Figures re-computed from the trial's file (unchanged) by the console's "
            f"analysis of {ANALYSIS} (rehab-console {software_version()}, `rehab "
            f"reanalyse`; the file was recorded by {recorded_by or 'an unknown version'}): "
            f"{listed}"
            + (f"; and {more} more" if more > 0 else ""))
