"""Adding to a closed trial file what the console computes after the trial: its metrics,
the assistance's estimates (and, through `open_for_update`, EMG and pose).

Every addition first holds disk space for what it writes (device.recording.trialfile.
reserve): HDF5 flags a file "open for writing" as it opens it for writing, and a write
that then failed for want of space left the flag set and the trial unreadable."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Mapping
from pathlib import Path

import h5py

from device.errors import RecordingError
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

UPDATE_RESERVE_BYTES = 2**20
"""Held for an addition that says nothing of its size: metrics and estimates take a few
KiB. One that writes arrays (EMG, pose) passes its own `reserve_bytes`."""


@contextlib.contextmanager
def open_for_update(path: str | Path, *, wait_s: float | None = None,
                    sleep=time.sleep, clock=time.monotonic,
                    reserve_bytes: int = UPDATE_RESERVE_BYTES):
    """A closed trial file opened to add to it (metrics, estimates, EMG, pose).

    `reserve_bytes` are held on the disk before the file is opened, and what is left of
    them given back after it is closed: on a disk that cannot give them, SpaceShort (a
    RecordingError) is raised and the file is left as it was.

    In one process HDF5 refuses to open a file for writing while it is open for reading,
    whatever the file locking: the window's report or replay, or a researcher's loader in
    the same Python, may hold it at that moment. Such a reader holds it briefly, so the
    update waits for it (up to `wait_s`, by default UPDATE_WAIT_S, trying every
    UPDATE_RETRY_S) instead of failing and losing what it was to store. Any other error
    is raised at once."""
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
            yield f
    finally:
        space.release()


def write_metrics(path: str | Path, metrics: Mapping) -> None:
    """Store a closed trial's metrics in its `/metrics` group (replacing earlier ones).

    The recorder closes the file as soon as the trial ends; the console computes the
    metrics afterwards and keeps them beside the data with this."""
    values = _check_metrics(metrics)
    try:
        with open_for_update(path) as f:
            if f.attrs.get("status") == STATUS_RECORDING:
                raise RecordingError(f"{path} is still being recorded; add metrics after it "
                                     "closes")
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
        with open_for_update(path) as f:
            if f.attrs.get("status") == STATUS_RECORDING:
                raise RecordingError(f"{path} is still being recorded; add to its assistance "
                                     "after it closes")
            group = f.require_group("assistance")
            taken = sorted((set(group.attrs) | set(group)) & (set(arrays) | set(scalars)))
            if taken:
                raise RecordingError(f"{Path(path).name} already has {', '.join(taken)} in "
                                     "/assistance; nothing was changed")
            _write_assistance(group, scalars, arrays)
    except (OSError, RuntimeError, ValueError) as exc:
        raise _disk_error(Path(path), "store the assistance's estimates in", exc) from exc


