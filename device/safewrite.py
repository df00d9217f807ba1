"""One guarded way to write a file: never over an existing file unless asked, never half a
file, never a mode the umask chose.

Every file the console writes by a name (a user's `--output`, an export, a report, a
model, an EMG recording, a video's timestamps) is written through this module:

* `check_target(path, overwrite)` — the one check of a file about to be written: its
  folder exists and is a folder, the name is not a folder, a device, a pipe or
  anything but a plain file, it does not exist unless `overwrite`, and it is never a
  SQLite database (a registry: the console never writes one by a user's name). What
  the operating system says about the path (a symlink loop, a name too long, a
  folder in the way) is folded into the same one-line `OutputRefused`.
* `atomic_output(path, overwrite=…)` — a stream to write the whole file through: a
  temporary file beside it (created 0600 by the library, whatever the umask),
  fsynced, then moved into place: hard-linked when nothing may be replaced (a link
  fails if the name exists, where a rename would replace it, so a file created by
  another program after the check is still not replaced), renamed over the old file
  only with `overwrite`. An interrupted write leaves the old file or none, never half.
* `atomic_path(...)` — the same for libraries that write by name (HDF5, matplotlib):
  the temporary's path is given and moved into place afterwards.
* `new_private_file(path)` — a file that is written as it grows (a video's
  timestamps, a live trial's HDF5 file) and so cannot be renamed into place: created
  exclusively (O_EXCL, never following a symlink), 0600.
* `make_private_folders(folder)` — the folders missing on the way to `folder`,
  created 0700; a folder that exists is never touched (its mode is its owner's).

The data folder's own rule (nothing it owns is replaced by a user's output) is the
application's: app.records.safewrite adds it on top of this module.
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import IO

from device.errors import DeviceError

PRIVATE_FILE = 0o600
PRIVATE_FOLDER = 0o700
SQLITE_HEADER = b"SQLite format 3\x00"
MAX_FOLDER_DEPTH = 64
"""Folders made for one output at most: a deeper chain is a typo, not a study's layout."""
_TEMPORARY = ".rehab-{token}.part"
"""A short name: a temporary named after a 250-character file would itself be too long."""


class OutputRefused(DeviceError):
    """A file cannot be written where it was asked: the message is one line saying why
    and what to do."""


def folded(text: object) -> str:
    """A message on one line: a library's newlines and tabs become '; ' and spaces."""
    lines = [" ".join(line.split()) for line in str(text).splitlines()]
    return "; ".join(line for line in lines if line)


def os_reason(exc: BaseException) -> str:
    """What the operating system said, in words, without its traceback."""
    if isinstance(exc, OSError):
        if exc.errno == errno.ELOOP:
            return "a symbolic link loops back on itself on the way to it"
        if exc.errno == errno.ENAMETOOLONG:
            return "the name or the path is too long for the file system"
        if exc.strerror:
            return exc.strerror
    if isinstance(exc, RecursionError):
        return "the path has too many levels"
    return folded(exc) or type(exc).__name__


def shown(path: object) -> str:
    """The path for a message: shortened when it is absurdly long, so the line stays one
    readable line."""
    text = os.fspath(path) if isinstance(path, os.PathLike | str) else str(path)
    text = text.encode("utf-8", "backslashreplace").decode("utf-8")
    return text if len(text) <= 160 else f"{text[:70]}…{text[-70:]} ({len(text)} characters)"


def absolute(path: str | os.PathLike) -> Path:
    """`path` with ~ expanded, made absolute without following links (a link's own name is
    what is replaced or refused); OutputRefused for a path the system cannot take."""
    try:
        text = os.fspath(path)
        if "\x00" in text:
            raise OutputRefused(f"{shown(text)!r} has a NUL character: give a path")
        return Path(os.path.abspath(os.path.expanduser(text)))
    except (TypeError, ValueError, RecursionError) as exc:
        raise OutputRefused(f"{shown(path)}: not a usable path ({os_reason(exc)})") from None


def check_target(path: str | os.PathLike, *, overwrite: bool = False) -> Path:
    """The absolute path of a file about to be written, or OutputRefused saying why not
    (see the module's doc)."""
    path = absolute(path)
    named = shown(path)
    if not path.name or path.name in (".", ".."):
        raise OutputRefused(f"{named} is a folder, not a file name: give a file's name")
    try:
        folder = os.stat(path.parent)
    except FileNotFoundError:
        raise OutputRefused(f"cannot write {named}: the folder {shown(path.parent)} does not "
                            "exist. Create it first, or give another place") from None
    except (OSError, RecursionError) as exc:
        raise OutputRefused(f"cannot write {named}: {os_reason(exc)}. Give another "
                            "place") from None
    if not stat.S_ISDIR(folder.st_mode):
        raise OutputRefused(f"cannot write {named}: {shown(path.parent)} is not a folder")
    try:
        there = os.stat(path)
    except FileNotFoundError:
        if os.path.islink(path):
            raise OutputRefused(f"{named} is a symbolic link to nothing: remove it or give "
                                "another name") from None
        return path
    except (OSError, RecursionError) as exc:
        raise OutputRefused(f"cannot write {named}: {os_reason(exc)}. Give another "
                            "name") from None
    if stat.S_ISDIR(there.st_mode):
        raise OutputRefused(f"{named} is a folder: give a file's name")
    if not stat.S_ISREG(there.st_mode):
        raise OutputRefused(f"{named} is not a plain file (a device, a pipe or a socket): "
                            "give a file's name")
    if not overwrite:
        raise OutputRefused(f"{named} already exists and is kept: give another name, or "
                            "--overwrite to replace it")
    if _is_sqlite(path):
        raise OutputRefused(f"{named} is a SQLite database (a registry?): the console never "
                            "writes over one; give another name")
    return path


def _is_sqlite(path: Path) -> bool:
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError:
        return False
    try:
        return os.read(fd, len(SQLITE_HEADER)) == SQLITE_HEADER
    except OSError:
        return False
    finally:
        os.close(fd)


def make_private_folders(folder: str | os.PathLike, *, max_depth: int = MAX_FOLDER_DEPTH
                         ) -> Path:
    """Create the folders missing on the way to `folder`, each 0700 (its user's only,
    whatever the umask); an existing one is left as it is. Returns the absolute folder;
    OutputRefused when a file is in the way, a level cannot be made, or more than
    `max_depth` levels are missing."""
    folder = absolute(folder)
    missing: list[Path] = []
    here = folder
    while True:
        try:
            info = os.stat(here)
        except FileNotFoundError:
            missing.append(here)
            if len(missing) > max_depth:
                raise OutputRefused(f"cannot create {shown(folder)}: more than {max_depth} "
                                    "folders would be made; check the path") from None
            if here.parent == here:
                break
            here = here.parent
            continue
        except (OSError, RecursionError) as exc:
            raise OutputRefused(f"cannot use the folder {shown(here)}: {os_reason(exc)}") \
                from None
        if not stat.S_ISDIR(info.st_mode):
            raise OutputRefused(f"cannot create the folder {shown(folder)}: {shown(here)} is "
                                "a file, not a folder. Move it, or choose another place")
        break
    for level in reversed(missing):
        try:
            os.mkdir(level, PRIVATE_FOLDER)
        except FileExistsError:
            continue  # made meanwhile by another process: its mode is its maker's
        except OSError as exc:
            raise OutputRefused(f"cannot create the folder {shown(level)}: "
                                f"{os_reason(exc)}. Check the permissions of "
                                f"{shown(level.parent)}, or choose another place") from None
        os.chmod(level, PRIVATE_FOLDER)  # the umask may have taken the owner's bits too
    return folder


def folder_problem(folder: str | os.PathLike, *, follow_links: bool = True) -> str | None:
    """Why `folder` is not a folder of this user's alone, or None when it is: it must be a
    folder (a symbolic link to one only with `follow_links`), owned by this user, writable
    by no one else (its group counts as no one else only when it is the user's own
    private group), and every folder on the way to it owned by this user or root and
    writable by no one else unless sticky (/tmp: then only the owner of the entry below
    may rename it, and that entry is checked in turn). The words complete "<folder> …"."""
    if os.name != "posix":
        return None  # no POSIX modes: the user profile's own ACLs keep it private
    uid = os.geteuid()
    try:
        info = os.lstat(folder)
        if stat.S_ISLNK(info.st_mode):
            if not follow_links:
                return "is a symbolic link"
            info = os.stat(folder)
        real = Path(os.path.realpath(folder))
    except FileNotFoundError:
        return "does not exist"
    except (OSError, RecursionError, ValueError) as exc:
        return f"cannot be used ({os_reason(exc)})"
    if not stat.S_ISDIR(info.st_mode):
        return "is not a folder"
    if info.st_uid != uid:
        return f"belongs to {user_name(info.st_uid)}, not to {user_name(uid)}"
    if _writable_by_others(info):
        return f"can be written by others (mode {stat.S_IMODE(info.st_mode):o})"
    for parent in real.parents:
        try:
            above = os.stat(parent)
        except OSError as exc:
            return f"cannot be checked: {shown(parent)} on the way ({os_reason(exc)})"
        if above.st_uid not in (uid, 0):
            return (f"lies in {shown(parent)}, which belongs to {user_name(above.st_uid)}, who "
                    "could put another folder in its place")
        if _writable_by_others(above) and not above.st_mode & stat.S_ISVTX:
            return (f"lies in {shown(parent)}, which others can write (mode "
                    f"{stat.S_IMODE(above.st_mode):o}): they could put another folder in its "
                    "place")
    return None


def _writable_by_others(info: os.stat_result) -> bool:
    if info.st_mode & stat.S_IWOTH:
        return True
    return bool(info.st_mode & stat.S_IWGRP) and not _private_group(info.st_gid)


def _private_group(gid: int) -> bool:
    """The user's own group (Debian's and Fedora's user private groups): named as the user,
    their primary group, and no one else listed in it."""
    try:
        import grp
        import pwd

        user = pwd.getpwuid(os.geteuid())
        group = grp.getgrgid(gid)
    except (ImportError, KeyError):
        return False
    return gid == user.pw_gid and group.gr_name == user.pw_name and not (
        set(group.gr_mem) - {user.pw_name})


def user_name(uid: int) -> str:
    try:
        import pwd

        return f"user {pwd.getpwuid(uid).pw_name}"
    except (ImportError, KeyError):
        return f"user id {uid}"


def new_private_file(path: str | os.PathLike, *, binary: bool = False,
                     encoding: str = "utf-8") -> IO:
    """A new file opened for writing, created exclusively (it must not exist, a symbolic
    link is not followed) and 0600: for files written as they grow, which cannot be
    renamed into place."""
    path = check_target(path)
    flags = (os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
             | getattr(os, "O_CLOEXEC", 0))
    try:
        fd = os.open(path, flags, PRIVATE_FILE)
    except FileExistsError:
        raise OutputRefused(f"{shown(path)} already exists and is kept: give another "
                            "name") from None
    except OSError as exc:
        raise OutputRefused(f"cannot create {shown(path)}: {os_reason(exc)}. Check the "
                            "folder's permissions and free space") from None
    os.fchmod(fd, PRIVATE_FILE)
    if binary:
        return os.fdopen(fd, "wb")
    return os.fdopen(fd, "w", encoding=encoding, newline="")


def claim_private_file(path: str | os.PathLike) -> Path:
    """Create `path` empty, exclusively and 0600, and return it: for a library that then
    opens it by name and truncates it (HDF5's "w"), which keeps the mode. Nothing else can
    take the name meanwhile."""
    new_private_file(path, binary=True).close()
    return absolute(path)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, *, overwrite: bool = False) -> Iterator[Path]:
    """A temporary path beside `path` (an empty 0600 file) for a library to write by name;
    moved into place when the block ends without an error, removed otherwise."""
    with _atomic(path, overwrite) as (temporary, fd):
        os.close(fd)
        yield temporary


def write_failed(path: str | os.PathLike, exc: OSError) -> OutputRefused:
    """The one line of a write made aside that failed before it was put in place: what
    failed, what to check, and that nothing of it was left."""
    return OutputRefused(f"writing {shown(path)} failed: {os_reason(exc)}. Check the free "
                         "space and the folder's permissions; nothing was left half-written")


@contextlib.contextmanager
def _atomic(path: str | os.PathLike, overwrite: bool) -> Iterator[tuple[Path, int]]:
    """The temporary beside `path` and its open descriptor (closed by the caller); moved
    into place when the block ends without an error, removed otherwise."""
    path = check_target(path, overwrite=overwrite)
    temporary, fd = _temporary_beside(path)
    try:
        yield temporary, fd
        _sync_file(temporary)
        _into_place(temporary, path, overwrite)
    except OSError as exc:
        raise write_failed(path, exc) from None
    finally:
        with contextlib.suppress(OSError):
            os.unlink(temporary)


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike, *, overwrite: bool = False, text: bool = False,
                  encoding: str = "utf-8") -> Iterator[IO]:
    """A stream to write the whole of `path` through (see the module's doc)."""
    with _atomic(path, overwrite) as (_, fd):
        # the descriptor made with O_EXCL, not the name again: nothing can be put in its place
        options = {"encoding": encoding, "newline": ""} if text else {}
        with os.fdopen(fd, "w" if text else "wb", **options) as stream:
            yield stream


def write_bytes(path: str | os.PathLike, data: bytes, *, overwrite: bool = False) -> Path:
    with atomic_output(path, overwrite=overwrite) as stream:
        stream.write(data)
    return absolute(path)


def write_text(path: str | os.PathLike, text: str, *, overwrite: bool = False) -> Path:
    with atomic_output(path, overwrite=overwrite, text=True) as stream:
        stream.write(text)
    return absolute(path)


def _temporary_beside(path: Path) -> tuple[Path, int]:
    flags = (os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
             | getattr(os, "O_CLOEXEC", 0))
    for _ in range(8):
        temporary = path.with_name(_TEMPORARY.format(token=secrets.token_hex(6)))
        try:
            fd = os.open(temporary, flags, PRIVATE_FILE)
        except FileExistsError:
            continue
        except OSError as exc:
            raise OutputRefused(f"cannot write in {shown(path.parent)}: {os_reason(exc)}. "
                                "Check its permissions and free space, or choose another "
                                "place") from None
        os.fchmod(fd, PRIVATE_FILE)
        return temporary, fd
    raise OutputRefused(f"cannot make a temporary file in {shown(path.parent)}")


def _sync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _into_place(temporary: Path, path: Path, overwrite: bool) -> None:
    if overwrite:
        if _is_sqlite(path):  # became one since the check
            raise OutputRefused(f"{shown(path)} is a SQLite database: the console never "
                                "writes over one; give another name")
        os.replace(temporary, path)
    else:
        try:
            os.link(temporary, path)  # fails if the name exists, where rename would replace
        except FileExistsError:
            raise OutputRefused(f"{shown(path)} appeared while it was being written and is "
                                "kept: give another name, or --overwrite") from None
        except OSError as exc:
            if exc.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV,
                                 errno.EMLINK):
                raise
            # no hard links here (FAT, exFAT, some network shares): the last-moment check
            # falls back to an existence test
            if os.path.lexists(path):
                raise OutputRefused(f"{shown(path)} appeared while it was being written and "
                                    "is kept: give another name, or --overwrite") from None
            os.replace(temporary, path)
    sync_folder(path.parent)


def sync_folder(folder: Path) -> None:
    """Make a rename in `folder` durable (its entry on disk); best effort."""
    if os.name != "posix":
        return
    try:
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
    except OSError:
        return
    try:
        with contextlib.suppress(OSError):
            os.fsync(fd)
    finally:
        os.close(fd)
