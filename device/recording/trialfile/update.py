"""Adding to a closed trial file what the console computes after the trial: its metrics,
the assistance's estimates (and, through `open_for_update`, EMG and pose), each checked
against the file's seal before and sealed again after (device.recording.trialfile.seal).

Every addition first holds disk space for what it writes (device.recording.trialfile.
reserve): HDF5 flags a file "open for writing" as it opens it for writing, and a write
that then failed for want of space left the flag set and the trial unreadable."""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Mapping
from pathlib import Path

import h5py

from device.errors import RecordingError
from device.recording.trialfile import seal as sealing
from device.recording.trialfile.layout import (
    ALREADY_OPEN,
    LIBVER,
    STATUS_RECORDING,
    UPDATE_RETRY_S,
    UPDATE_WAIT_S,
    _assistance_parts,
    _check_metrics,
    _disk_error,
    _write_assistance,
)
from device.recording.trialfile.reserve import hold_for_update
from device.recording.trialfile.verify import Damaged, check_heaps, held, inventory

ROOMS = ("/metrics", "/assistance", "/emg", "/emg/mvc", "/pose")
"""The groups an update may write, each re-sealed whole."""

UPDATE_RESERVE_BYTES = 2**20
"""Held for an addition that says nothing of its size: metrics and estimates take a few
KiB. One that writes arrays (EMG, pose) passes its own `reserve_bytes`."""


@contextlib.contextmanager
def open_for_update(path: str | Path, room: str, *, wait_s: float | None = None,
                    sleep=time.sleep, clock=time.monotonic,
                    reserve_bytes: int = UPDATE_RESERVE_BYTES):
    """A closed trial file opened to add to its group `room` (one of ROOMS: the metrics,
    estimates, EMG, MVCs, pose).

    A sealed file is checked first (its structure, its root attributes and everything in
    `room`), so an addition never seals over damage, and sealed again when the block ends:
    `room` digested anew, every other part kept as it was sealed, and nothing outside
    `room` may have appeared or gone. A file without a seal (an older format, or one being
    recorded) is opened as it is. A damaged file raises RecordingError naming it.

    `reserve_bytes` are held on the disk before the file is opened, and what is left of
    them given back after it is closed: on a disk that cannot give them, SpaceShort (a
    RecordingError) is raised and the file is left as it was.

    In one process HDF5 refuses to open a file for writing while it is open for reading,
    whatever the file locking: the window's report or replay, or a researcher's loader in
    the same Python, may hold it at that moment. Such a reader holds it briefly, so the
    update waits for it (up to `wait_s`, by default UPDATE_WAIT_S, trying every
    UPDATE_RETRY_S) instead of failing and losing what it was to store. Any other error
    is raised at once."""
    if room not in ROOMS:
        raise RecordingError(f"an update may write {', '.join(ROOMS)}, not {room!r}")
    # one thread at a time in a trial file (verify.held)
    with held(path), _opened_for_update(path, room, wait_s, sleep, clock, reserve_bytes) as f:
        yield f


@contextlib.contextmanager
def _opened_for_update(path, room, wait_s, sleep, clock, reserve_bytes):
    try:
        check_heaps(path)
    except Damaged as exc:
        raise _damaged(path, exc) from None
    deadline = clock() + (UPDATE_WAIT_S if wait_s is None else wait_s)
    space = hold_for_update(path, reserve_bytes)
    try:
        while True:
            try:
                f = h5py.File(path, "r+", libver=LIBVER, locking=False)
                break
            except OSError as exc:
                if ALREADY_OPEN not in str(exc) or clock() >= deadline:
                    raise
            sleep(UPDATE_RETRY_S)
        with f:
            try:
                seal = _checked_seal(f, room)
            except Damaged as exc:
                raise _damaged(path, exc) from None
            if seal is not None:
                # the room marked before anything changes: a kill from here on leaves it
                # pending (unverified, said so), not the whole trial refused as damaged
                sealing.write_seal(f, seal.parts, {*seal.pending, room})
                f.flush()
                os.fsync(f.id.get_vfd_handle())
            try:
                yield f
            except BaseException:
                # what the failed update left in its room is the console's, not damage:
                # sealed as it is, so the trial stays readable (the caller reports it)
                if seal is not None:
                    with contextlib.suppress(OSError, RuntimeError, ValueError,
                                             RecordingError):
                        _reseal(f, seal, room)
                raise
            if seal is not None:
                _reseal(f, seal, room)
    finally:
        space.release()


def _checked_seal(f: h5py.File, room: str) -> sealing.Seal | None:
    """The file's seal after checking its structure, its root and `room` (unless an earlier
    addition of `room` was interrupted: this one replaces it)."""
    found = inventory(f)
    seal = sealing.Seal.read(f)
    if seal is not None:
        seal.check_structure(found)
        seal.check("/", found)
        seal.check_room(found, room)
    return seal


def _reseal(f: h5py.File, seal: sealing.Seal, room: str) -> None:
    found = inventory(f)
    outside = {p for p in found.paths if not sealing.in_room(p, room)}
    if ({p for p in outside if not seal.is_pending(p)}
            != {p for p in seal.parts if not sealing.in_room(p, room)
                and not seal.is_pending(p)}):
        raise RecordingError(f"an update of {room} changed groups or datasets outside it "
                             f"in {f.filename}; it was not sealed")
    parts = {p: h for p, h in seal.parts.items() if p in outside}
    parts |= {p: sealing.part_digest(p, found) for p in found.paths if p not in outside}
    sealing.write_seal(f, parts, [r for r in seal.pending if r != room])


def refuse_while_recording(f, shown, then: str) -> None:
    """Refuse an update of a file its recorder has not closed (a live trial, or one a
    crash left): what is added now would sit beside records still to come, or seal over
    a file that needs recovering. `shown` names the file, `then` says what to do."""
    if f.attrs.get("status") == STATUS_RECORDING:
        raise RecordingError(f"{shown} is still being recorded; {then}")


def _damaged(path, exc: Damaged) -> RecordingError:
    return RecordingError(f"trial file {path}: {exc.problem}; nothing was stored in it. Restore "
                          "it from the backup or the original")


def write_metrics(path: str | Path, metrics: Mapping) -> None:
    """Store a closed trial's metrics in its `/metrics` group (replacing earlier ones).

    The recorder closes the file as soon as the trial ends; the console computes the
    metrics afterwards and keeps them beside the data with this."""
    values = _check_metrics(metrics)
    try:
        with open_for_update(path, "/metrics") as f:
            refuse_while_recording(f, path, "add metrics after it closes")
            group = f.require_group("metrics")
            for key in list(group.attrs):
                del group.attrs[key]
            for key, value in values.items():
                group.attrs[key] = value
    except (OSError, RuntimeError, ValueError) as exc:
        raise _disk_error(Path(path), "store the metrics in", exc) from exc


def add_assistance(path: str | Path, values: Mapping) -> None:
    """Add to a closed trial's `/assistance` group what the console learnt beside the loop
    (a live trial's estimates of the patient's force, app.emg.live_feed): numbers and
    strings as attributes, arrays as checksummed float64 datasets, as `close` writes them.
    A name the group already holds is refused: nothing there is overwritten."""
    scalars, arrays = _assistance_parts(values)
    try:
        with open_for_update(path, "/assistance") as f:
            refuse_while_recording(f, path, "add to its assistance after it closes")
            group = f.require_group("assistance")
            taken = sorted((set(group.attrs) | set(group)) & (set(arrays) | set(scalars)))
            if taken:
                raise RecordingError(f"{Path(path).name} already has {', '.join(taken)} in "
                                     "/assistance; nothing was changed")
            _write_assistance(group, scalars, arrays)
    except (OSError, RuntimeError, ValueError) as exc:
        raise _disk_error(Path(path), "store the assistance's estimates in", exc) from exc


