"""A trial's registry row and its file begin and end together: one way to register a trial
at Start and to take it back when the run is refused or fails.

`registered_trial(registry, code, parameters, …)` registers the trial (status
`recording`, the file's name reserved) around the block that runs it; if the block
raises, for whatever reason (a path out of reach, a force estimate refused, a full
disk, Ctrl-C), `take_back` ends what was begun before the exception goes on:

* no file was made: the row is withdrawn (Registry.withdraw_trial), as if the trial
  had never started;
* a file with no sample (refused after it was opened): the file is removed and the row
  withdrawn;
* a file with samples: kept, and the trial finished from it as `recording_lost` with
  the reason (app.trials.finalize.finalize_lost), so its data stay and every reader
  sees a finished trial.

Never is a row left `recording` without a file (a "ghost": `rehab export --patient`
failed on it ever after). The window's Start uses the same `take_back` when the loop
refuses to start a trial it has registered.
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Iterator
from dataclasses import dataclass

from app.errors import AppError
from app.records.registry import BegunTrial
from app.records.store import RecordStore
from app.trials.finalize import finalize_lost
from app.trials.reader import read_trial
from device.safewrite import folded

log = logging.getLogger(__name__)

WITHDRAWN = "withdrawn"
KEPT = "kept"


@dataclass(frozen=True, slots=True)
class TakenBack:
    """What `take_back` did: `outcome` WITHDRAWN (no trace left) or KEPT (finished as
    recording lost with what reached its file); `words`, that in a phrase for a message."""

    outcome: str
    words: str


@contextlib.contextmanager
def registered_trial(registry: RecordStore, code: str, parameters, **begin) -> Iterator[
        BegunTrial]:
    """Register the trial (Registry.begin_trial with `begin`'s options) for the block that
    runs it; take it back (`take_back`) if the block raises, then let the error go on with
    what was done added as a note (`exc.__notes__`)."""
    begun = registry.begin_trial(code, parameters, **begin)
    try:
        yield begun
    except BaseException as exc:
        why = folded(exc) or type(exc).__name__
        try:
            done = take_back(registry, begun, why)
        except Exception as failure:  # the refusal is what the user must read first
            log.error("trial %d could not be taken back after %r: %s", begun.trial_id, why,
                      failure)
            exc.add_note(f"the trial {begun.trial_id} could not be taken back: "
                         f"{folded(failure)}")
        else:
            exc.add_note(done.words)
        raise


def take_back(registry: RecordStore, begun: BegunTrial | int, why: str) -> TakenBack:
    """End a registered trial whose run was refused or failed (see the module's doc)."""
    trial_id = begun if isinstance(begun, int) else begun.trial_id
    path = registry.trial_path(trial_id)
    if os.path.lexists(path) and _samples(path) == 0:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(path)
        log.info("trial %d: its file held no sample and was removed: %s", trial_id, why)
    if not os.path.lexists(path):
        registry.withdraw_trial(trial_id, why)
        return TakenBack(WITHDRAWN, "the trial was not registered")
    finalize_lost(registry, trial_id, why)
    return TakenBack(KEPT, "the trial is registered as recording lost, with what reached "
                           "its file")


def _samples(path) -> int | None:
    """The file's sample count, or None when it cannot be read (then it is kept)."""
    try:
        return read_trial(path, ()).n_samples
    except AppError:
        return None
