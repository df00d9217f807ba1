"""One guarded way to take a file someone named as input: a plain file of a bounded size, or a
folder, checked before any reader opens it.

A reader given a pipe waits for a writer that never comes (`--marks <fifo>` hung), one
given /dev/zero reads until memory runs out (MemoryError), one given a folder, /proc or a
link loop fails in the library's words. `check_file` refuses all of these in one line
(`InputRefused`) before the reader runs: the path must name a regular file (after its
links), no larger than the reader's bound; `check_folder` a folder that can be listed.
`read_bytes` / `read_text` read such a file whole, opened without blocking and never
more than the bound, for readers that take the text.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from device.errors import DeviceError
from device.safewrite import absolute, os_reason, shown

MAX_TEXT_BYTES = 64 * 2**20
"""A CSV of marks, reference angles or settings larger than this is not one."""


class InputRefused(DeviceError):
    """A file named as input cannot be read as one: the message is one line, `problem` the
    part of it after the file's name."""

    def __init__(self, what: str, path: object, problem: str) -> None:
        self.path, self.problem = path, problem
        super().__init__(f"{what} {shown(path)} {problem}")


def check_file(path: str | os.PathLike, *, what: str = "file",
               max_bytes: int | None = None) -> Path:
    """The absolute path of a regular file no larger than `max_bytes` (links followed), or
    InputRefused saying what it is instead."""
    path = absolute(path)
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise InputRefused(what, path, "does not exist; check the path") from None
    except (OSError, RecursionError, ValueError) as exc:
        raise InputRefused(what, path, f"cannot be read: {os_reason(exc)}") from None
    if stat.S_ISDIR(info.st_mode):
        raise InputRefused(what, path, "is a folder: give a file")
    if not stat.S_ISREG(info.st_mode):
        raise InputRefused(what, path, "is not a plain file (a device, a pipe or a "
                           "socket): give a file")
    if max_bytes is not None and info.st_size > max_bytes:
        raise InputRefused(what, path, f"is {_size(info.st_size)}, more than such a "
                           f"file can be ({_size(max_bytes)}): check it is the right file")
    return path


def check_folder(path: str | os.PathLike, *, what: str = "folder") -> Path:
    """The absolute path of a folder that can be listed, or InputRefused."""
    path = absolute(path)
    try:
        info = os.stat(path)
        if stat.S_ISDIR(info.st_mode):
            with os.scandir(path):
                pass
    except FileNotFoundError:
        raise InputRefused(what, path, "does not exist; check the path") from None
    except (OSError, RecursionError, ValueError) as exc:
        raise InputRefused(what, path, f"cannot be read: {os_reason(exc)}") from None
    if not stat.S_ISDIR(info.st_mode):
        raise InputRefused(what, path, "is not a folder")
    return path


def read_bytes(path: str | os.PathLike, *, what: str = "file",
               max_bytes: int = MAX_TEXT_BYTES) -> bytes:
    """The whole of a checked file (check_file), at most `max_bytes` read whatever the file
    claims: it is opened without blocking, so a pipe put in its place returns at once."""
    path = check_file(path, what=what, max_bytes=max_bytes)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise InputRefused(what, path, f"cannot be read: {os_reason(exc)}") from None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise InputRefused(what, path, "is not a plain file: give a file")
        chunks, size = [], 0
        while size <= max_bytes:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as exc:
        raise InputRefused(what, path, f"cannot be read: {os_reason(exc)}") from None
    finally:
        os.close(fd)
    if size > max_bytes:
        raise InputRefused(what, path, f"is more than such a file can be "
                           f"({_size(max_bytes)}): check it is the right file")
    return b"".join(chunks)


def read_text(path: str | os.PathLike, *, what: str = "file",
              max_bytes: int = MAX_TEXT_BYTES, encoding: str = "utf-8") -> str:
    """read_bytes decoded; InputRefused when it is not text in `encoding`."""
    data = read_bytes(path, what=what, max_bytes=max_bytes)
    try:
        return data.decode(encoding)
    except UnicodeDecodeError:
        raise InputRefused(what, absolute(path), f"is not {encoding} text") from None


def _size(count: int) -> str:
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if count >= scale:
            return f"{count / scale:.1f} {unit}"
    return f"{count} bytes"
