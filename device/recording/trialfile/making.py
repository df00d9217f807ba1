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
from device.safewrite import OutputRefused, claim_private_file


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
        # a trial holds a patient's data: its user's only from the first moment, whatever
        # the umask (device.safewrite: created exclusively, 0600; HDF5's "w" keeps the
        # mode). A chmod after HDF5 made it left an instant in which another user could
        # open it, and read all that was written later through that descriptor.
        claim_private_file(making)
    except OutputRefused as exc:
        said = exc.__context__  # what the system said, when it said something
        raise _disk_error(path, "create", said if isinstance(said, OSError) else exc) \
            from None
    try:
        # A small chunk cache: HDF5's default (1 MiB a dataset) holds the last MiB of
        # every channel, 30+ MiB that a writer appending in order never reads back.
        return h5py.File(making, "w", libver=LIBVER, rdcc_nbytes=CHUNK_CACHE_BYTES)
    except (OSError, RuntimeError) as exc:
        with contextlib.suppress(OSError):
            os.unlink(making)
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
