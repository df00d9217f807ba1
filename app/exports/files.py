"""Writing export files safely: never over an existing file unless asked, never half a file.

Every output goes through the console's one guarded write (app.records.safewrite,
device.safewrite): a hidden temporary file beside its final name, 0600, moved into
place only when complete, so an interrupted export (a full disk, a crash) leaves no
truncated file behind. Without `overwrite` the move refuses a name that exists, even
one created by another program after the export checked. An export folder inside a
data folder is refused but below its exports/ and reports/.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO

from app.errors import AppError
from app.records.safewrite import OutputRefused, atomic_output, check_output_folder
from device.safewrite import make_private_folders

_SHOWN = 3


class ExportError(AppError):
    """An export cannot be written: the destination is unwritable, or its files exist."""


class OutputExistsError(ExportError):
    """An export would replace existing files and `overwrite` was not given."""


def prepare_folder(folder: str | os.PathLike) -> Path:
    """Create `folder` (and its parents) if missing, private to its user, and check it can
    be written; never a data folder's own place but its exports/ and reports/
    (app.records.safewrite)."""
    try:
        folder = check_output_folder(folder, what="the export folder")
    except OutputRefused as exc:
        raise ExportError(f"cannot export there: {exc}") from None
    # Permission bits lie (ACLs, read-only mounts, root); only a write tells.
    try:
        handle, name = tempfile.mkstemp(dir=folder, prefix=".export-write-test-")
    except OSError as exc:
        raise _unwritable(folder, exc) from exc
    os.close(handle)
    with contextlib.suppress(OSError):
        os.unlink(name)
    return folder


def refuse_existing(paths: Iterable[Path], overwrite: bool) -> None:
    """Raise OutputExistsError naming the outputs that exist, unless `overwrite`."""
    if overwrite:
        return
    existing = [p for p in paths if p.exists()]
    if existing:
        shown = ", ".join(str(p) for p in existing[:_SHOWN])
        more = f" and {len(existing) - _SHOWN} more" if len(existing) > _SHOWN else ""
        raise OutputExistsError(
            f"the export would replace {len(existing)} existing file(s): {shown}{more}. "
            "Nothing was written. Choose another folder, move those files, or export "
            "again with --overwrite to replace them"
        )


@contextlib.contextmanager
def output(path: Path, *, overwrite: bool, text: bool = False) -> Iterator[IO]:
    """A file to write `path` through: app.records.safewrite's, a temporary beside it moved
    into place on success (never over a file without `overwrite`), 0600."""
    refuse_existing([path], overwrite)
    try:
        make_private_folders(path.parent)
        with atomic_output(path, overwrite=overwrite, text=text) as stream:
            yield stream
    except OutputRefused as exc:
        raise ExportError(f"{exc} (nothing was left half-written)") from None


def write_text(path: Path, text: str, *, overwrite: bool) -> Path:
    with output(path, overwrite=overwrite, text=True) as stream:
        stream.write(text)
    return path


def _unwritable(folder: Path, exc: OSError) -> ExportError:
    return ExportError(
        f"cannot write in the export folder {folder}: {exc.strerror or exc}. Check its "
        "permissions and that the disk is connected, or choose another folder"
    )
