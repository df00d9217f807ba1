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

The file changes before the registry can record it, so a console killed in between, a
registry that cannot be written then (a full disk) or a write that failed half-way (the
update seals what it left, device.recording.trialfile.update) left the trial refused for
good, with advice to restore a backup that would lose what was written, and a file a kill
left flagged "open for writing" that no reader opened. So the write is marked first: a file
`<trial file>.rewriting` beside it (the trial, its checksum before, what is written, when),
locked by the writer while it writes and removed once the new checksum is recorded.
`settle` finds a mark whose writer is gone (its lock free): when the file was the one
recorded before the write and now verifies against its own seal (a room the write left
unfinished is said so by every reader), its new checksum is recorded and the event logged;
otherwise the mark stays and the line says why. The window's start (app.trials.finalize),
the exports and the study (app.exports.plan) and the next write into the trial settle
marks.
"""

from __future__ import annotations

import contextlib
import datetime
import errno
import fcntl
import json
import logging
import os
from collections.abc import Iterable, Iterator
from pathlib import Path

from app.errors import AppError
from app.records.registry.provenance import file_checksum
from app.records.store import RecordStore

log = logging.getLogger(__name__)

MARK_SUFFIX = ".rewriting"
MAX_MARK_BYTES = 4096


def mark_of(path: str | os.PathLike) -> Path:
    """The mark beside a trial file that the console is writing into."""
    path = Path(path)
    return path.with_name(path.name + MARK_SUFFIX)


@contextlib.contextmanager
def rewriting(registry: RecordStore, trial_id: int, what: str) -> Iterator[None]:
    """Record the file's new checksum after the block's write into trial `trial_id`'s
    file (`what` it wrote, for the log), when the file was the one recorded before. The
    write is marked before it begins (AppError, nothing written, when it cannot be)."""
    trial = registry.trial(trial_id)
    if trial.checksum is None:
        yield
        return
    line = settle(registry, trial)  # an earlier write into it that did not end
    if line is not None:
        log.warning("%s", line)
        trial = registry.trial(trial_id)
    if registry.verify_trial_file(trial) is not None:
        yield  # not the file recorded: written as it is, and still refused
        return
    path = registry.trial_path(trial)
    with _marked(path, trial, what) as mark:
        try:
            yield
        except BaseException:
            # a failed write may have changed the file (the update seals what it left)
            line, done = _adopt(registry, trial, path, what, trial.checksum)
            mark.keep = not done
            if line is not None:
                log.warning("%s", line)
            raise
        try:
            checksum = file_checksum(path)
            if checksum != trial.checksum:
                registry.record_rewritten(trial_id, checksum)
        except (OSError, AppError) as exc:
            mark.keep = True
            raise AppError(
                f"{path.name} now holds {what}, but the registry did not record the file's "
                f"new checksum ({_reason(exc)}): the file is kept marked as written by the "
                f"console ({mark.path.name}), and its checksum is recorded once the registry "
                "can be written (at the window's next start, the next export, or the next "
                "write into the trial)") from None
    log.info("trial %d: its file now holds %s; its checksum is recorded again", trial_id,
             what)


class _Mark:
    def __init__(self, path: Path, fd: int) -> None:
        self.path, self.fd, self.keep = path, fd, False


@contextlib.contextmanager
def _marked(path: Path, trial, what: str) -> Iterator[_Mark]:
    """The mark made (exclusively), locked and flushed before the write; removed after it
    unless `keep` (the registry did not record the new checksum)."""
    where = mark_of(path)
    try:
        fd = os.open(where, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
    except OSError as exc:
        busy = exc.errno == errno.EEXIST
        raise AppError(
            f"nothing was written into {path.name}: "
            + (f"another write into it has not ended ({where.name} is there)" if busy
               else f"its mark {where.name} cannot be made ({_reason(exc)})")
            + ("; wait for it, or open the window once to settle it" if busy else
               "; free space on the disk or check the folder's permissions")) from None
    mark = _Mark(where, fd)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        text = json.dumps({"trial": trial.id, "before": trial.checksum, "what": what,
                           "started_utc": _now()})
        os.write(fd, text.encode("utf-8"))
        os.fsync(fd)
    except OSError as exc:
        os.close(fd)
        with contextlib.suppress(OSError):
            where.unlink()
        raise AppError(f"nothing was written into {path.name}: its mark {where.name} cannot "
                       f"be written ({_reason(exc)}); free space on the disk") from None
    try:
        yield mark
    finally:
        if not mark.keep:
            with contextlib.suppress(OSError):
                where.unlink()
        os.close(fd)


def settle(registry: RecordStore, trial) -> str | None:
    """Settle the mark of an earlier write into `trial`'s file whose writer is gone: its
    new checksum recorded when it verifies, the mark removed when nothing was written.
    A line for the therapist when something was settled or cannot be; None when there is
    no mark, or its writer is still at work."""
    path = registry.trial_path(trial)
    where = mark_of(path)
    try:
        fd = os.open(where, os.O_RDWR | os.O_NOFOLLOW)
    except FileNotFoundError:
        return None
    except OSError as exc:
        return (f"trial {trial.id}: the mark {where} of a write into its file cannot be "
                f"read ({_reason(exc)})")
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return None  # a console is writing into it now: its own end records it
        mark = _read_mark(fd) or {}
        if mark.get("trial") not in (None, trial.id):
            return None  # not this trial's: left alone
        line, done = _adopt(registry, trial, path, str(mark.get("what", "an addition")),
                            mark.get("before"), started=str(mark.get("started_utc", "")),
                            writer_gone=True)
        if done:
            with contextlib.suppress(OSError):
                where.unlink()
        return line
    finally:
        os.close(fd)


def _adopt(registry: RecordStore, trial, path: Path, what: str, before: object, *,
           started: str = "", writer_gone: bool = False) -> tuple[str | None, bool]:
    """After a write into `path` that did not end (its block failed, or its writer is
    gone): the file's new checksum recorded when the file was the one recorded before
    (`before`) and now verifies against its own seal. (A line or None, whether the mark
    may go.)"""
    try:
        now = file_checksum(path)
    except OSError as exc:
        return (f"trial {trial.id}: its file {path} cannot be read after {what} was written "
                f"into it ({_reason(exc)})"), False
    if now == trial.checksum:
        return None, True  # nothing had changed yet
    if before != trial.checksum:
        return None, True  # not a write from the file recorded: the mismatch is said as is
    how = (f"{what} written into its file {path.name}"
           + (f" (begun {started})" if started else "")
           + " was not recorded in the registry (the console stopped, or the registry could "
           "not be written then)" if writer_gone
           else f"writing {what} into its file {path.name} failed")
    if writer_gone:
        from app.trials.finalize import unflag
        unflag(path)  # the flags a killed writer left, or no reader opens it
        now = file_checksum(path)
    problem, unfinished = _verified(path)
    if problem is not None:
        return (f"trial {trial.id}: {how}, and the file does not verify (it {problem}): "
                "restore it from a backup or the trial store"), False
    try:
        registry.record_rewritten(trial.id, now)
    except AppError as exc:
        return (f"trial {trial.id}: {how}; the file verifies, but its new checksum cannot be "
                f"recorded now ({_reason(exc)}): the console tries again at its next start "
                "or export"), False
    left = (f", but for {', '.join(unfinished)}, which the write left unfinished (every "
            "reader says so: write it again)" if unfinished else "")
    return (f"trial {trial.id}: {how}; the file verifies against its seal{left}, so its "
            "new checksum is recorded"), True


def _verified(path: Path) -> tuple[str | None, tuple[str, ...]]:
    """What is wrong with the trial file against its seal (every group and dataset), and
    the rooms an unfinished addition left unverified."""
    from device.errors import RecordingError
    from device.recording.trialfile.seal import open_room
    from device.recording.trialfile.verify import Damaged

    try:
        with open_room(path, "/") as opened:
            seal = None if opened is None else opened[2]
            if seal is None:
                return "has no seal to be verified against", ()
            return None, seal.pending
    except Damaged as exc:
        return exc.problem, ()
    except (OSError, RecordingError, ValueError, KeyError, RuntimeError) as exc:
        return f"cannot be read ({_reason(exc)})", ()


def settle_all(registry: RecordStore, trials: Iterable) -> list[str]:
    """`settle` for each of `trials` that has a mark: the lines, for the caller to say."""
    lines = []
    for trial in trials:
        if trial.checksum is None or not mark_of(registry.trial_path(trial)).exists():
            continue
        line = settle(registry, trial)
        if line is not None:
            log.info("%s", line)  # the caller says it
            lines.append(line)
    return lines


def settle_marked(registry: RecordStore) -> list[str]:
    """`settle` for every marked trial file of the data folder (the window's start)."""
    trials = []
    for where in sorted(registry.data_dir.trials_dir.glob(f"*/*{MARK_SUFFIX}")):
        trial_id = trial_of_file(registry, where.with_name(where.name[:-len(MARK_SUFFIX)]))
        if trial_id is not None:
            trials.append(registry.trial(trial_id))
    return settle_all(registry, trials)


def _read_mark(fd: int) -> dict | None:
    try:
        raw = os.pread(fd, MAX_MARK_BYTES + 1, 0)
        mark = json.loads(raw.decode("utf-8")) if len(raw) <= MAX_MARK_BYTES else None
    except (OSError, ValueError):
        return None
    return mark if isinstance(mark, dict) else None


def _now() -> str:
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def _reason(exc: BaseException) -> str:
    if isinstance(exc, OSError):
        return exc.strerror or str(exc)
    # the registry's "nothing was saved" is of the registry: the file holds the write
    return " ".join(str(exc).split()).removesuffix("; nothing was saved")


def trial_of_file(registry: RecordStore, path: str | os.PathLike) -> int | None:
    """The registered trial whose file `path` is, or None: a file outside the data folder's
    `trials/<code>/`, or of no registered trial (`trials/simulated/`, a copy)."""
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
