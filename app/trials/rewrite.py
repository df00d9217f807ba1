"""A finished trial's file that the console itself writes into afterwards: an assessment's
task figures (app.assessments.runner), EMG imported beside it, the session's MVCs
(app.emg), the camera's pose (app.pose). The registry keeps the SHA-256 of each trial's
file as finished (app.records.registry.provenance), and an export, a study and the trial
store read a registered trial only when its file has that checksum; a file the console
wrote into was refused by them all ('not the file recorded ... restore the file from a
backup'), so that the README's `rehab assess run CODE --task all` or `rehab emg import ID`
followed by `rehab export --patient CODE` left trials out.

`rewriting(registry, trial_id)` brackets such a write: the file is checked to be the one
recorded before it, and its new checksum is recorded after it
(`RecordStore.record_rewritten`). A file that was not the one recorded before stays
refused: the console's own write never passes off a changed file as the trial's.
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Iterator
from pathlib import Path

from app.records.registry.provenance import file_checksum
from app.records.store import RecordStore

log = logging.getLogger(__name__)


@contextlib.contextmanager
def rewriting(registry: RecordStore, trial_id: int, what: str) -> Iterator[None]:
    """Record the file's new checksum after the block's write into trial `trial_id`'s
    file (`what` it wrote, for the log), when the file was the one recorded before."""
    trial = registry.trial(trial_id)
    problem = registry.verify_trial_file(trial) if trial.checksum is not None else "none"
    yield
    if problem is not None:
        return
    registry.record_rewritten(trial_id, file_checksum(registry.trial_path(trial)))
    log.info("trial %d: its file now holds %s; its checksum is recorded again", trial_id,
             what)


def trial_of_file(registry: RecordStore, path: str | os.PathLike) -> int | None:
    """The registered trial whose file `path` is, or None: a file outside the data folder's
    `trials/<code>/`, or of no registered trial (`trials/simulated/`, a copy)."""
    from app.errors import AppError

    where = Path(path).resolve()
    try:
        trials = registry.trials_for_patient(where.parent.name)
    except AppError:  # no patient of that code
        return None
    for trial in trials:
        try:
            if registry.trial_path(trial).resolve() == where:
                return trial.id
        except AppError:  # a stored path the data folder refuses: not this file
            continue
    return None


@contextlib.contextmanager
def rewriting_files(registry: RecordStore, paths, what: str) -> Iterator[None]:
    """`rewriting` for each of `paths` that is a registered trial's file (the others are
    written as they are)."""
    with contextlib.ExitStack() as stack:
        for path in paths:
            trial_id = trial_of_file(registry, path)
            if trial_id is not None:
                stack.enter_context(rewriting(registry, trial_id, what))
        yield
