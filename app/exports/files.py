"""Writing export files safely: never over an existing file unless asked, never half a file.

Every output is written to a hidden temporary file beside its final name and
moved into place only when complete, so an interrupted export (a full disk, a
crash) leaves no truncated file behind. Without `overwrite` the move refuses a
name that exists, even one created by another program after the export
checked: on file systems without hard links (FAT, exFAT, some network shares)
that last-moment check falls back to an exists test.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO

from app.errors import AppError

_SHOWN = 3


class ExportError(AppError):
    """An export cannot be written: the destination is unwritable, or its files exist."""


class OutputExistsError(ExportError):
    """An export would replace existing files and `overwrite` was not given."""


def prepare_folder(folder: str | os.PathLike) -> Path:
    """Create `folder` (and its parents) if missing and check it can be written."""
    folder = Path(folder).expanduser().absolute()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise ExportError(
            f"cannot export to the folder {folder}: a file of that name is in the way. "
            "Choose another folder, or move that file"
        ) from None
    except OSError as exc:
        raise _unwritable(folder, exc) from exc
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
            "with overwrite=True (--overwrite) to replace them"
        )


@contextlib.contextmanager
def output(path: Path, *, overwrite: bool, text: bool = False) -> Iterator[IO]:
    """A file to write `path` through: a temporary beside it, moved into place on success."""
    folder = path.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(dir=folder, prefix=f".{path.name}.",
                                             suffix=".part")
    except OSError as exc:
        raise _unwritable(folder, exc) from exc
    temporary = Path(temporary)
    try:
        mode = "w" if text else "wb"
        options = {"encoding": "utf-8", "newline": ""} if text else {}
        with os.fdopen(handle, mode, **options) as stream:
            yield stream
        _move_into_place(temporary, path, overwrite)
    except OSError as exc:
        raise ExportError(
            f"writing {path} failed: {exc.strerror or exc}. Check the free space and "
            f"permissions of {folder}; nothing was left half-written"
        ) from exc
    finally:
        with contextlib.suppress(OSError):
            temporary.unlink()


def write_text(path: Path, text: str, *, overwrite: bool) -> Path:
    with output(path, overwrite=overwrite, text=True) as stream:
        stream.write(text)
    return path


def _move_into_place(temporary: Path, path: Path, overwrite: bool) -> None:
    if overwrite:
        os.replace(temporary, path)
        return
    try:
        # A hard link fails if the name exists, where a rename would replace it.
        os.link(temporary, path)
    except FileExistsError:
        refuse_existing([path], overwrite=False)
    except OSError:
        refuse_existing([path], overwrite=False)
        os.replace(temporary, path)


def _unwritable(folder: Path, exc: OSError) -> ExportError:
    return ExportError(
        f"cannot write in the export folder {folder}: {exc.strerror or exc}. Check its "
        "permissions and that the disk is connected, or choose another folder"
    )
