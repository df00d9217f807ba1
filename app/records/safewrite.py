"""The data folder's rule on top of device.safewrite: nothing a data folder owns is ever
written over by a file someone named.

device.safewrite is the one way a file is written (checked, atomic, private, never over
an existing file unless asked); this module adds what only the application knows: a
data folder (a folder holding `registry.sqlite3`, or the one this console uses) owns its
registry, its trial files, its models and its logs, and a user's output (`--output`, an
export's folder) may be written inside it only below `exports/` and `reports/`, the two
places the console itself writes outputs for people. Anywhere inside a data folder
else, and any file named like the registry, is refused in one line, `--overwrite` or
not: `rehab learn pendulum --output "$D/registry.sqlite3" --overwrite` replaces nothing.
The console's own writers inside the data folder (a saved model, a report, an export to
its default folder) say `owned=True`.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO

from app.records.datadir import EXPORTS, REGISTRY_NAME, REPORTS
from device.safewrite import (
    OutputRefused,
    absolute,
    atomic_output as _atomic_output,
    atomic_path as _atomic_path,
    check_target,
    folded,
    make_private_folders,
    os_reason,
)

__all__ = [
    "OUTPUTS_ALLOWED",
    "OutputRefused",
    "atomic_output",
    "atomic_path",
    "check_output",
    "check_output_folder",
    "data_folder_around",
    "folded",
    "os_reason",
    "refuse_owned_folder",
    "write_text",
]

OUTPUTS_ALLOWED = (EXPORTS, REPORTS)
"""The only places inside a data folder where a user's outputs may go."""


def data_folder_around(path: str | os.PathLike, roots: Iterable[Path] = ()) -> Path | None:
    """The data folder `path` lies in, or None: the nearest folder above it that holds a
    registry, or one of `roots` (the data folder this command uses, which may not have its
    registry yet). Links are followed too: a folder linked into a data folder is in it."""
    owner = _owner(absolute(path), roots)
    return None if owner is None else owner[0]


def _owner(path: Path, roots: Iterable[Path]) -> tuple[Path, Path] | None:
    """(the data folder `path` lies in, `path` relative to it), or None."""
    known = {absolute(r) for r in roots}
    candidates = [path]
    with contextlib.suppress(OSError, RuntimeError, ValueError):
        real = Path(os.path.realpath(path.parent)) / path.name
        if real != path:
            candidates.append(real)
        known |= {Path(os.path.realpath(r)) for r in known}
    for candidate in candidates:
        for folder in candidate.parents:
            try:
                if folder in known or os.path.lexists(folder / REGISTRY_NAME):
                    return folder, candidate.relative_to(folder)
            except (OSError, ValueError):
                continue
    return None


def _refuse_owned(path: Path, roots: Iterable[Path], what: str,
                  shown: Path | None = None) -> None:
    """OutputRefused when `path` is a registry's name or what a data folder owns; the line
    names `shown` (a folder, where `path` is a probe inside it: "…/trials/_" told a user
    of a file name they never gave) or else `path`."""
    if path.name.startswith(REGISTRY_NAME):
        raise OutputRefused(f"{what} {path} is named like a registry: the console never "
                            "writes over a registry; give another name")
    owner = _owner(path, roots)
    if owner is None:
        return
    root, inside = owner
    if len(inside.parts) > 1 and inside.parts[0] in OUTPUTS_ALLOWED:
        return
    raise OutputRefused(f"{what} {shown or path} is inside the data folder {root}, which keeps its "
                        "registry, trial files and models there: write it elsewhere, or "
                        f"below its {'/ or '.join(OUTPUTS_ALLOWED)}/ folders")


def check_output(path: str | os.PathLike, *, overwrite: bool = False,
                 roots: Iterable[Path] = (), inputs: Iterable[str | os.PathLike] = (),
                 what: str = "output") -> Path:
    """The absolute path of a file a user named to be written, or OutputRefused (one line):
    device.safewrite.check_target's checks, nothing a data folder owns (see the module's
    doc; `roots` adds the command's data folder), and none of the command's own `inputs`."""
    _refuse_owned(absolute(path), tuple(roots), what)
    path = check_target(path, overwrite=overwrite)
    for given in inputs:
        with contextlib.suppress(OSError, ValueError):
            if os.path.exists(given) and os.path.samefile(given, path):
                raise OutputRefused(f"{what} {path} is also one of the command's inputs: "
                                    "give another name")
    return path


def refuse_owned_folder(folder: str | os.PathLike, *, roots: Iterable[Path] = (),
                        what: str = "output folder") -> Path:
    """`check_output_folder`'s refusal without making the folder: for a command that
    checks where its outputs go before any work, and makes them after (app.study)."""
    folder = absolute(folder)
    _refuse_owned(folder / "_", tuple(roots), what, shown=folder)
    return folder


def check_output_folder(folder: str | os.PathLike, *, roots: Iterable[Path] = (),
                        owned: bool = False, what: str = "output folder") -> Path:
    """An output folder (an export's), created private where missing and never a data
    folder's own place unless `owned` (the console's default export folder)."""
    folder = absolute(folder)
    if not owned:
        _refuse_owned(folder / "_", roots, what, shown=folder)
    return make_private_folders(folder)


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike, *, overwrite: bool = False, text: bool = False,
                  owned: bool = False, roots: Iterable[Path] = ()) -> Iterator[IO]:
    """device.safewrite.atomic_output, refusing what a data folder owns unless `owned`."""
    if not owned:
        check_output(path, overwrite=overwrite, roots=roots)
    with _atomic_output(path, overwrite=overwrite, text=text) as stream:
        yield stream


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, *, overwrite: bool = False, owned: bool = False,
                roots: Iterable[Path] = ()) -> Iterator[Path]:
    """device.safewrite.atomic_path, refusing what a data folder owns unless `owned`."""
    if not owned:
        check_output(path, overwrite=overwrite, roots=roots)
    with _atomic_path(path, overwrite=overwrite) as temporary:
        yield temporary


def write_text(path: str | os.PathLike, text: str, *, overwrite: bool = False,
               owned: bool = False) -> Path:
    with atomic_output(path, overwrite=overwrite, text=True, owned=owned) as stream:
        stream.write(text)
    return absolute(path)
