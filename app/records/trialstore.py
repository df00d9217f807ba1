"""Each finished trial's file copied into the department's shared trial store, the copy proven
whole before the registry records it there (issue 32; app.records.registry.stores says what
is recorded and why the data folder stays the first place).

The store is a folder, typically a network share mounted on each station, given per station
(the setting `trial_store`, e.g. /mnt/rehab-trials/robot-2). A trial's file goes to the same
relative path there as in the data folder (trials/<code>/<name>.h5). A copy is:

1. written beside its place under a temporary name, hashed as it is written, and flushed
   to the disk (fsync): a copy cut off by the network is never taken for a file;
2. refused when what was read is not the file recorded (its SHA-256 is not the checksum the
   registry kept at the trial's end: the data folder's file changed since);
3. put in place without ever replacing a file there (a link, which fails when the name is
   taken; where the share cannot link, a rename after checking the name is free);
4. read back from the store and hashed again: the registry records the store
   (`Registry.record_stored`) only when the copy there has the checksum.

A file already in the store with the recorded checksum (a copy made before the registry
could record it) is recorded as it is; one with another checksum is never replaced, and the
trial is listed with why. When the store cannot be reached the trials wait in the data
folder, and `store_pending` copies them at its next call (the window calls it after each
trial and as it opens).
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import logging
import os
import secrets
from dataclasses import dataclass, field
from pathlib import Path

from app.errors import RegistryError, RegistryUnreachable
from app.records.registry.provenance import file_checksum
from app.records.registry.trials import Trial
from app.records.store import RecordStore
from device.safewrite import OutputRefused, make_private_folders

log = logging.getLogger(__name__)

_CHUNK = 1 << 20


class StoreProblem(RegistryError):
    """The shared trial store cannot take files now (not there, full, not writable): the
    line says why; every trial waits."""


class TrialNotCopied(StoreProblem):
    """This trial's file is not copied (its file, or the store's file of its name, is not
    the one recorded): the line says why; the other trials are copied."""


@dataclass
class Stored:
    """What `store_pending` did: the trials copied (or found) and recorded, and a line for
    each that was not (the store unreachable stops the round: one line for all)."""

    trials: list[Trial] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)


def store_trial(registry: RecordStore, trial: Trial, store: str | os.PathLike) -> Trial:
    """Copy `trial`'s file into the shared trial store at `store` and record it there (the
    module's doc); the trial as recorded after. StoreProblem (one line) when it cannot."""
    root = Path(store)
    if not root.is_absolute():
        raise StoreProblem(f"the trial store {store} is not an absolute folder: set the "
                           "setting trial_store to the store's folder for this station")
    if not root.is_dir():
        raise StoreProblem(f"the trial store {root} is not there (is the network folder "
                           "mounted?); the trials wait in the data folder and are copied "
                           "when it is")
    if trial.checksum is None:
        raise TrialNotCopied(f"trial {trial.id} has no checksum kept: its copy could not be "
                           "proven whole, so it is not copied")
    source = registry.trial_path(trial)
    if not source.is_file():
        raise TrialNotCopied(f"trial {trial.id}'s file {source} is not in the data folder: "
                             "it cannot be copied to the trial store; restore it from a "
                             "backup")
    target = root / trial.file
    try:
        if target.exists():
            found = file_checksum(target)
            if found != trial.checksum:
                raise TrialNotCopied(
                    f"{target} in the trial store is another file than trial {trial.id}'s "
                    f"(SHA-256 {found[:12]}…, the registry's {trial.checksum[:12]}…): it was "
                    "not replaced; move it aside to let the trial's file be copied")
        else:
            _copy(source, target, trial)
            found = file_checksum(target)  # read back from the store
            if found != trial.checksum:
                with contextlib.suppress(OSError):
                    target.unlink()
                raise StoreProblem(f"the copy of trial {trial.id} in the trial store read back "
                                   f"differently (SHA-256 {found[:12]}…): it was removed and "
                                   "will be made again")
    except (OSError, OutputRefused) as exc:
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
        raise StoreProblem(f"trial {trial.id}'s file could not be copied to the trial store "
                           f"{root}: {why}; it waits in the data folder") from None
    return registry.record_stored(trial.id, str(root))


def _copy(source: Path, target: Path, trial: Trial) -> None:
    make_private_folders(target.parent)  # as private as the data folder's (0700, 0600)
    partial = target.with_name(f".{target.name}.part-{secrets.token_hex(4)}")
    digest = hashlib.sha256()
    try:
        descriptor = os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with open(source, "rb") as reader, os.fdopen(descriptor, "wb") as writer:
            while piece := reader.read(_CHUNK):
                digest.update(piece)
                _write(writer, piece)
            writer.flush()
            os.fsync(writer.fileno())
        if digest.hexdigest() != trial.checksum:
            raise TrialNotCopied(
                f"trial {trial.id}'s file in the data folder ({source}) is not the one "
                "recorded (its SHA-256 differs from the checksum kept at its end): it was "
                "not copied; restore it from a backup")
        _into_place(partial, target)
    finally:
        with contextlib.suppress(FileNotFoundError):
            partial.unlink()


def _write(writer, piece: bytes) -> None:
    """One piece of a copy into the store (a test injects a full store here where no small
    disk can be mounted)."""
    writer.write(piece)


def _into_place(partial: Path, target: Path) -> None:
    """`partial` at `target`, never over a file there."""
    try:
        os.link(partial, target)  # fails when the name is taken
    except OSError as exc:
        if exc.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV):
            raise
        if target.exists():  # a share without links: check, then rename
            raise FileExistsError(errno.EEXIST, "a file is already there", str(target)) \
                from None
        os.rename(partial, target)
    folder = os.open(target.parent, os.O_RDONLY)
    try:
        os.fsync(folder)
    finally:
        os.close(folder)


def store_pending(registry: RecordStore, store: str | os.PathLike) -> Stored:
    """Copy every trial of this station not yet in the store (oldest first), one by one;
    stop at the first the store cannot take for a reason of its own (not there, full, not
    writable): the rest wait for the next call."""
    done = Stored()
    try:
        waiting = registry.trials_to_store()
    except RegistryUnreachable as exc:
        done.problems.append(str(exc))
        return done
    for trial in waiting:
        try:
            done.trials.append(store_trial(registry, trial, store))
        except TrialNotCopied as exc:
            done.problems.append(str(exc))
        except StoreProblem as exc:
            done.problems.append(str(exc))
            break  # the store itself: the next trials would fail alike
    # the callers say the problems (the window once, the command line on stderr)
    for trial in done.trials:
        log.info("trial %d copied to the trial store %s and checked", trial.id, store)
    return done
