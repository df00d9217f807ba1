"""A new trial file: made under a hidden name in its folder, and given its own name only
once its header is written and it reads as an SWMR file, never over another file
(docs/data-format.md, Crash safety: a reader polling for the trial's file met it half
made, flagged open for plain writing, and read it as damaged)."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import h5py

from device.errors import RecordingError
from device.recording.trialfile.layout import CHUNK_CACHE_BYTES, LIBVER, _disk_error

PRIVATE = getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)


def making_name(path: Path) -> Path:
    """The hidden name a trial file is made under (in its own folder, so that the link to
    its name is on the same file system)."""
    return path.with_name(f".{path.name}.{os.getpid()}.making")


def make_file(path: Path, making: Path) -> h5py.File:
    """The new file for `path`, open for writing under the hidden name `making`."""
    parent = path.parent
    if not parent.is_dir():
        raise RecordingError(
            f"cannot create trial file {path}: the folder {parent} does not exist. "
            "Check the data directory setting or create the folder."
        )
    if path.exists():
        raise _taken(path)
    try:
        # a trial holds a patient's data: readable by its user only from its first byte,
        # whatever the umask (made empty, exclusively and 0600; HDF5's "w" keeps the mode)
        fd = os.open(making, os.O_WRONLY | os.O_CREAT | os.O_EXCL | PRIVATE, 0o600)
    except OSError as exc:
        raise _disk_error(path, "create", exc) from exc
    try:
        try:
            os.fchmod(fd, 0o600)
        finally:
            os.close(fd)
        # A small chunk cache: HDF5's default (1 MiB a dataset) holds the last MiB of
        # every channel, 30+ MiB that a writer appending in order never reads back.
        return h5py.File(making, "w", libver=LIBVER, rdcc_nbytes=CHUNK_CACHE_BYTES)
    except (OSError, RuntimeError) as exc:
        with contextlib.suppress(OSError):
            os.unlink(making)  # ours: made just now
        raise _disk_error(path, "create", exc) from exc


def publish(making: Path, path: Path) -> None:
    """The file made as `making` takes its name `path`, never over another file."""
    try:
        os.link(making, path)  # fails if the name is taken
    except FileExistsError:
        raise _taken(path) from None
    except OSError:
        # a file system without hard links (FAT): the name was free a moment ago
        if path.exists():
            raise _taken(path) from None
        os.rename(making, path)
    with contextlib.suppress(FileNotFoundError):
        os.unlink(making)


def _taken(path: Path) -> RecordingError:
    return RecordingError(
        f"cannot create trial file {path}: a file of that name exists, and trial files are "
        "never overwritten. Choose another name or move the old file."
    )
