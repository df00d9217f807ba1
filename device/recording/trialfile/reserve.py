"""Disk space a trial file really holds: blocks allocated to the file beyond its end, so
that what fills the disk cannot take them (docs/data-format.md, Crash safety).

Why: HDF5 does not recover from a write that fails for want of space. A disk filled by
another program in the middle of a trial left the file flagged "open for writing" and
unreadable, every sample lost (issue 28, item 2); checking the free space before each
write cannot help, since the other program takes it between the check and the write.

How: `fallocate(FALLOC_FL_KEEP_SIZE)` allocates blocks past the file's end without
changing its size. HDF5 sees the same file; its writes that extend the file land in the
blocks already allocated, and an allocated block is never refused. `HeldSpace` keeps
`nbytes` held beyond the end and tops the hold up after every flush; when the disk can no
longer give it, what is still held is enough to write the trial's last samples and close
the file. The blocks beyond the end are given back when the file is done (`release`).

Where it cannot work: a system or file system without `fallocate` (not Linux; some
network and FUSE file systems; ZFS refuses FALLOC_FL_KEEP_SIZE), where `HeldSpace.held`
stays False and only the free-space check stands; and copy-on-write file systems
(btrfs, ZFS), where overwriting an allocated block may still need a new one.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import errno
import os
from pathlib import Path

from device.errors import RecordingError

FALLOC_FL_KEEP_SIZE = 0x01
FALLOC_FL_PUNCH_HOLE = 0x02

RESERVE_BYTES = 8 * 2**20
"""Held beyond a live trial file's end: some 40 s of samples at 500 Hz (a trial takes
about 11 MiB per minute) and the room `close` needs, where between two flushes (at most
0.5 s) the file grows by under 1 MiB (0.5 s of samples and a new chunk per channel)."""
CLOSE_BYTES = 2 * 2**20
"""Kept for `close` when the disk is short: the status, the summary and the assistance
group take some 100 KiB (measured: docs/performance.md, Full disk)."""
NO_SPACE = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)


class SpaceShort(RecordingError):
    """The disk can no longer give the trial file its reserve: the recording stops in good
    order, and what is held takes the trial's last samples and the close."""


def _load_fallocate():
    if not hasattr(os, "posix_fallocate"):  # not a POSIX system with fallocate at all
        return None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        function = libc.fallocate64
    except (OSError, AttributeError):
        return None
    function.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_int64, ctypes.c_int64]
    function.restype = ctypes.c_int
    return function


_FALLOCATE = _load_fallocate()


def fallocate(fd: int, mode: int, offset: int, length: int) -> None:
    """Linux's fallocate(2); OSError with its errno (EOPNOTSUPP where it is missing)."""
    if _FALLOCATE is None:
        raise OSError(errno.EOPNOTSUPP, "fallocate is not available on this system")
    if _FALLOCATE(fd, mode, offset, length) != 0:
        code = ctypes.get_errno()
        raise OSError(code, os.strerror(code))


class HeldSpace:
    """`nbytes` of disk held beyond the end of the file at `path`, through a descriptor of
    its own (HDF5 keeps its own; allocation belongs to the file, whichever descriptor asks).

    `top_up()` holds `nbytes` past the current end again and returns '' or, once the disk
    cannot give it, why (said once; the hold then stays as it is). `room()` is what is
    still held past the end."""

    def __init__(self, path: str | os.PathLike, nbytes: int = RESERVE_BYTES) -> None:
        self.path = Path(path)
        self.nbytes = int(nbytes)
        self.end = 0
        """The offset up to which blocks are held (0: nothing held)."""
        self.held = False
        """Whether this file system holds space at all (see the module notes)."""
        self.short = ""
        self.unsupported = ""
        self._fd = os.open(self.path, os.O_RDWR | getattr(os, "O_CLOEXEC", 0))
        # named by the folder it is in, which a file keeps when it is renamed or linked

    def size(self) -> int:
        return os.fstat(self._fd).st_size

    def top_up(self) -> str:
        """Hold `nbytes` past the end again: '' when held (or when this file system cannot
        hold space: see `unsupported`), else the sentence saying the disk is short."""
        if self.short or self.unsupported or self._fd < 0:
            return self.short
        size = self.size()
        try:
            fallocate(self._fd, FALLOC_FL_KEEP_SIZE, size, self.nbytes)
        except OSError as exc:
            if exc.errno in NO_SPACE:
                self.short = (f"the disk holding {self.path.parent} is full (only "
                              f"{max(0, self.end - size) / 2**20:.1f} MiB held for this file "
                              "were left)")
                return self.short
            self.unsupported = (f"this file system does not hold space for a file "
                                f"({exc.strerror or exc}); only the free-space check guards "
                                "the trial file")
            return ""
        self.end = max(self.end, size + self.nbytes)
        self.held = True
        return ""

    def ensure(self, nbytes: int) -> bool:
        """Whether `nbytes` are held past the end, holding them if the disk has them (the
        close's room, when the disk has freed some since): True where nothing can be held
        at all, as the write then depends on the free space alone."""
        if not self.held:
            return True
        if self._fd < 0:
            return False
        size = self.size()
        if self.end - size >= nbytes:
            return True
        try:
            fallocate(self._fd, FALLOC_FL_KEEP_SIZE, size, nbytes)
        except OSError:
            return False
        self.end = max(self.end, size + nbytes)
        return True

    def room(self) -> int | None:
        """Bytes held past the file's end now; None when nothing is held."""
        if not self.held or self._fd < 0:
            return None
        return max(0, self.end - self.size())

    def release(self) -> None:
        """Give back what is held past the end and close the descriptor (idempotent)."""
        if self._fd < 0:
            return
        try:
            size = self.size()
            if self.held and self.end > size:
                try:
                    fallocate(self._fd, FALLOC_FL_PUNCH_HOLE | FALLOC_FL_KEEP_SIZE, size,
                              self.end - size)
                except OSError:
                    # a truncation past the end frees every block beyond it
                    os.ftruncate(self._fd, size + 1)
                    os.ftruncate(self._fd, size)
        except OSError:
            pass  # the blocks stay allocated to the file; nothing of it is lost
        finally:
            os.close(self._fd)
            self._fd = -1
            self.end = 0


def hold_for_update(path: str | os.PathLike, nbytes: int) -> HeldSpace:
    """Space for an addition to a closed file, held before HDF5 opens it for writing: an
    open for writing flags the file, and a write that then fails for want of space left
    it flagged and unreadable. Raises SpaceShort (the file untouched) when the disk cannot
    give it; on a file system that cannot hold space, goes on unguarded."""
    space = HeldSpace(path, nbytes)
    problem = space.top_up()
    if problem:
        space.release()
        raise SpaceShort(f"nothing was added to {Path(path).name}: {problem}; the file is "
                         "unchanged. Free space on the disk, then store it again")
    return space
