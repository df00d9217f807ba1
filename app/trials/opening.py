"""Opening a trial file for reading: the checks before h5py reads a value, the wait while a
writer closes it, one sentence for each way it cannot be opened, and how far its content
can be verified against its seal (docs/data-format.md, "The seal"). Used by
app.trials.reader and the loader's quick path."""

from __future__ import annotations

import re
import time
from pathlib import Path

import h5py

from app.errors import TrialFileError
from device.recording.trialfile import STATUS_RECORDING
from device.recording.trialfile.layout import SEALED_SINCE_VERSION
from device.recording.trialfile.seal import Seal, check_header
from device.recording.trialfile.verify import Damaged, Inventory, check_heaps

# A writer's final reopen (docs/data-format.md, "Closing") takes milliseconds;
# a reader that meets it waits that long rather than failing.
_BUSY_RETRY_S = 2.0
_BUSY_PAUSE_S = 0.1

RESTORE = "Restore it from the backup or the original"

SEALED = "verified"
"""TrialData.seal of a closed file whose seal matched everything read."""
HEADER_ONLY = "header verified (not closed)"
"""A file being recorded or left open by a crash: its header's digest matched; its samples
have only their checksums until it is closed."""
CLOSE_INTERRUPTED = "unsealed (closing interrupted)"
UNSEALED_OLDER = "unsealed (older format)"
"""A file of format version 1, written before the seal existed: nothing but its samples'
checksums and the checks of app.trials.checks vouches for it."""


def one_line(exc: BaseException) -> str:
    """HDF5's messages carry line breaks; every refusal is one line."""
    return " ".join(str(exc).split())


# -- opening ----------------------------------------------------------------


def check_file(path: Path) -> None:
    if not path.exists():
        raise TrialFileError(
            path, "does not exist",
            "Check the path; if the registry lists it, the file was moved or deleted. "
            + RESTORE + ".",
        )
    if not path.is_file():
        raise TrialFileError(path, "is not a file (a folder?)", "Choose the trial's .h5 file.")
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise TrialFileError(path, f"cannot be examined ({exc})", "Check the disk.") from exc
    if size == 0:
        raise TrialFileError(
            path, "is empty (0 bytes): nothing was ever written to it",
            "No data can be recovered from it; record the trial again or restore the file "
            "from the backup.",
        )
    try:
        is_hdf5 = h5py.is_hdf5(path)
    except OSError as exc:
        raise TrialFileError(path, f"cannot be read ({exc})",
                             "Check its permissions and the disk.") from exc
    if not is_hdf5:
        raise TrialFileError(
            path, f"is not an HDF5 file ({size} bytes without the HDF5 signature): it is "
            "another kind of file or badly damaged",
            "Choose the trial's .h5 file. " + RESTORE + ".",
        )


def open_trial_file(path: Path) -> h5py.File:
    try:
        check_heaps(path)
    except Damaged as exc:
        raise TrialFileError(path, exc.problem, RESTORE + ".") from None
    except OSError as exc:
        raise TrialFileError(path, f"cannot be read ({one_line(exc)})",
                             "Check its permissions and the disk.") from exc
    deadline = time.monotonic() + _BUSY_RETRY_S
    while True:
        try:
            # A closed file opens normally. One being recorded (or left behind by a
            # crash) carries HDF5's "open for writing" flag and opens only as an
            # SWMR reader, which sees every flushed sample. Without HDF5's file locks,
            # as every other open of a trial file in the window's process (the metrics,
            # the EMG and the pose written beside it): HDF5 refuses a second open of a
            # file in one process with the other locking flag ("file locking flag values
            # don't match"), which failed a read while the window stored a trial's EMG.
            try:
                return h5py.File(path, "r", locking=False)
            except OSError as exc:
                if not _open_for_write(exc):
                    raise
            return h5py.File(path, "r", swmr=True, locking=False)
        except OSError as exc:
            if _open_for_write(exc) and time.monotonic() < deadline:
                time.sleep(_BUSY_PAUSE_S)
                continue
            raise _open_error(path, exc) from exc


def _open_for_write(exc: OSError) -> bool:
    """A writer has the file: recording it, closing it, or (a file made before trial files
    were made under a hidden name) between creating it and starting SWMR."""
    text = str(exc)
    return ("already open for write" in text or "unable to lock file" in text
            or "not already open for SWMR writing" in text)


def _open_error(path: Path, exc: OSError) -> TrialFileError:
    text = str(exc)
    truncated = re.search(r"truncated file: eof = (\d+).*stored_eof = (\d+)", text)
    if truncated:
        have, need = int(truncated.group(1)), int(truncated.group(2))
        return TrialFileError(
            path, f"is truncated: it holds {have} bytes of the {need} its header records, so it "
            "was cut short (an interrupted copy or download, or a full disk)",
            "Copy it again from the original, or restore it from the backup.",
        )
    if _open_for_write(exc):
        return TrialFileError(
            path, "is held open for writing by another program, not in the recorder's "
            "live (SWMR) mode",
            "Close the program that has it open; if none does, it was left so by a crash "
            "while the trial was being closed: run `h5clear -s` on a copy of the file.",
        )
    if isinstance(exc, PermissionError):
        return TrialFileError(path, "cannot be read: permission denied",
                              "Check the file's permissions.")
    return TrialFileError(path, f"cannot be opened as HDF5 ({one_line(exc)}); it is damaged",
                          RESTORE + ".")


UNSEALED_OLDER_NOTE = (
    "unsealed (older format): written before trial files were sealed (format version 1), "
    "so nothing vouches for its metadata, events and groups but the checks every file "
    "passes; its samples have their checksums")
CLOSE_INTERRUPTED_NOTE = (
    "unsealed (closing interrupted): its header verifies, but it was not sealed when it was "
    "closed (the console stopped while closing it), so its status, summary, metrics, events "
    "and samples are not verified")


def seal_of(f: h5py.File, found: Inventory, attrs: dict) -> tuple[Seal | None, str, list[str]]:
    """The file's seal, checked against its structure and its root attributes (None when it
    has none), how far the file can be verified, and the note that says so; Damaged when
    the seal does not match or a file of this format lacks it."""
    return _seal_of(f, found, attrs, str(attrs.get("status", "")))


def _seal_of(f, found, attrs, status):
    seal = Seal.read(f)
    if seal is not None:
        seal.check_structure(found)
        seal.check("/", found)
        if seal.pending:
            rooms = ", ".join(seal.pending)
            return seal, f"{SEALED} but {rooms} (an addition was interrupted)", [
                f"an addition to {rooms} was interrupted (the console stopped while writing "
                f"it), so {rooms} is not verified; the rest of the file is"]
        return seal, SEALED, []
    if int(attrs["format_version"]) < SEALED_SINCE_VERSION:
        return None, UNSEALED_OLDER, [UNSEALED_OLDER_NOTE]
    check_header(f)
    if status == STATUS_RECORDING:
        return None, HEADER_ONLY, []
    return None, CLOSE_INTERRUPTED, [CLOSE_INTERRUPTED_NOTE]
