"""The POSIX shared-memory segment under a record ring (device.recording.ring): its name,
its map in each process, its removal, and the reclaiming of segments a crash left behind.

The process that calls `RecordRing.create` owns the segment; everyone else uses
`RecordRing.attach`. The owner need not be the writer: when the process that starts
the loop owns the ring and the loop attaches to write, a crashed loop still leaves the
ring with its owner, to be drained and unlinked.

Every handle calls `close()` (unmaps, once every view it handed out is dropped).
Only the owner calls `unlink()` (removes the name; mappings already open stay valid,
so readers can still drain). ``with RecordRing.create(...) as ring:`` does both. If
the owner forgets, a finaliser unlinks when its handle is collected or the
interpreter exits (never in a forked child that inherited the handle).

If the owner is killed, what happens depends on its resource tracker. A standalone
owner's own tracker unlinks the segment at once (with a "leaked shared_memory"
warning). When the tracker is shared with processes still running (an owner started
by multiprocessing) or died with the owner (the process group killed), the segment
stays in /dev/shm with everything written so far, readable by anyone who attaches.
Names are ``<prefix><owner pid>_<random>``, so `reclaim_stale`, called by the next
owner at start-up, unlinks every segment with the prefix whose owner pid is gone; a
running owner is never touched. Failing that, a shared tracker unlinks it when the
last process sharing it exits.

The Python 3.11 resource_tracker quirk: ``SharedMemory(name)`` also registers the
segment with the *attaching* process's tracker. An attacher with its own tracker (a
process not started by multiprocessing from the owner) then unlinks the owner's live
segment when it exits, with a "leaked" warning. The usual cure, unregistering right
after attaching, is wrong when the tracker is shared (any multiprocessing child): the
tracker keeps a set, so the attacher removes the owner's entry and the owner's own
``unlink()`` later makes the tracker print a KeyError traceback. So attachers here
never register: they map the segment with ``_posixshmem.shm_open`` (what
``SharedMemory`` itself uses; Python 3.13 exposes the same as ``track=False``). Only
the owner is tracked, and only the owner's ``unlink()`` unregisters.
"""

from __future__ import annotations

import mmap
import os
import re
import secrets
from multiprocessing import resource_tracker
from pathlib import Path

from device.errors import DeviceError

try:
    import _posixshmem
except ImportError:  # pragma: no cover - Windows
    _posixshmem = None

NAME_PREFIX = "rehab_ring_"
SHM_DIR = Path("/dev/shm")


class RingError(DeviceError):
    """The ring segment is missing, is not a ring of this layout or dtype, or was misused."""


def _check_prefix(prefix: str) -> None:
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*_", prefix):
        raise ValueError(f"ring name prefix {prefix!r}: ASCII letters, digits and '_', "
                         "starting with a letter and ending in '_'")


def new_ring_name(prefix: str) -> str:
    """A new segment's name, ``<prefix><owner pid>_<random>``: `reclaim_stale` reads the
    owner's pid back from it."""
    if _posixshmem is None:  # pragma: no cover - Windows
        raise RingError("the record ring needs POSIX shared memory (Linux)")
    _check_prefix(prefix)
    return f"{prefix}{os.getpid()}_{secrets.token_hex(4)}"


class SegmentMap:
    """One process's map of a segment, made without telling the resource tracker (module
    docstring). Unlike SharedMemory it has no __del__ that closes the map under views that
    are collected later than it, so a dropped RecordRing is freed by reference counting."""

    def __init__(self, name: str) -> None:
        fd = _posixshmem.shm_open("/" + name, os.O_RDWR, mode=0o600)
        try:
            self._mmap = mmap.mmap(fd, os.fstat(fd).st_size)
        finally:
            os.close(fd)
        self.buf = memoryview(self._mmap)

    def close(self) -> None:
        """Unmap; BufferError (and callable again) while a numpy view of `buf` is alive."""
        if self.buf is not None:
            self.buf.release()
            self.buf = None
        if self._mmap is not None:
            self._mmap.close()
            self._mmap = None


def map_segment(name: str) -> SegmentMap:
    """This process's map of the segment `name`; RingError when there is none (yet, or
    any more) or it is still being made."""
    try:
        return SegmentMap(name)
    except FileNotFoundError:
        raise RingError(
            f"no ring named {name!r}: its owner has not created it yet or has already "
            "unlinked it; start the loop first, or check the name passed to this process"
        ) from None
    except ValueError as e:  # mmap of an empty file: caught between shm_open and ftruncate
        raise RingError(f"ring {name!r} is not initialised yet ({e}); attach again") from e


def unlink_segment(name: str) -> bool:
    """Remove a tracked segment's name and its resource-tracker entry; False if already gone."""
    try:
        _posixshmem.shm_unlink("/" + name)
    except (FileNotFoundError, PermissionError):
        return False
    finally:
        # SharedMemory.unlink() would skip this when the name is already gone, leaving an
        # entry the tracker later "cleans up" with two warnings.
        resource_tracker.unregister("/" + name, "shared_memory")
    return True


def owner_cleanup(name: str, owner_pid: int) -> None:
    # The finaliser: garbage collection or interpreter exit of an owner that did not
    # unlink. A forked child inherits the handle but must not destroy its parent's ring.
    if os.getpid() == owner_pid:
        unlink_segment(name)

def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # someone else's process: alive
    try:  # a zombie (dead, not yet reaped by its parent) still answers kill(pid, 0)
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return True
    return stat.rpartition(")")[2].split()[0] != "Z"


def reclaim_stale(prefix: str = NAME_PREFIX) -> list[str]:
    """Unlink the rings with this name prefix whose owner process is gone; their names.

    For the owner to call at start-up, after a crash left a segment behind. A ring whose
    owner pid is alive (or was reused by another process) is left alone. Linux only:
    elsewhere there is no directory to list and this returns [].
    """
    _check_prefix(prefix)
    if not SHM_DIR.is_dir():
        return []
    reclaimed = []
    for entry in sorted(SHM_DIR.iterdir()):
        name = entry.name
        pid_text, sep, _ = name.removeprefix(prefix).partition("_")
        if not name.startswith(prefix) or not sep or not pid_text.isdigit():
            continue
        pid = int(pid_text)
        if pid <= 0 or _pid_alive(pid):
            continue
        # Register first: if the dead owner shared our tracker, this is a no-op and the
        # unregister in unlink_segment removes its entry; if not, the pair cancels out.
        resource_tracker.register("/" + name, "shared_memory")
        if unlink_segment(name):
            reclaimed.append(name)
    return reclaimed
