"""A small disk to fill in tests: a tmpfs of a few MiB where this machine lets the tests
mount one (root, as in CI), else the same full disk injected at the calls through which
the recorder meets it (the reserve's fallocate, the free-space check). `DISK_KIND` says
which one runs, and tests carry it in their ids, so neither is skipped silently."""

from __future__ import annotations

import contextlib
import errno
import functools
import os
import subprocess
import tempfile
from pathlib import Path

import pytest

import device.recording.trialfile.reserve as reserve
import device.recording.trialfile.writer as writer


@functools.cache
def disk_kind() -> str:
    """'tmpfs' when a tmpfs can be mounted here, else 'injected' (or as REHAB_TEST_DISK
    says: `injected` runs the injected full disk on a machine that could mount one)."""
    if os.environ.get("REHAB_TEST_DISK") == "injected":
        return "injected"
    with tempfile.TemporaryDirectory() as folder:
        try:
            mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", folder],
                                     capture_output=True, timeout=20).returncode == 0
        except (OSError, subprocess.SubprocessError):
            return "injected"
        if mounted:
            subprocess.run(["umount", folder], capture_output=True, timeout=20)
            return "tmpfs"
    return "injected"


DISK_KIND = disk_kind()
DISK_WORDS = {
    "tmpfs": "a real full disk (a small tmpfs mounted and filled)",
    "injected": "injected at the recorder's write calls (no tmpfs can be mounted here, or "
                "REHAB_TEST_DISK=injected)",
}


def fill(folder: Path) -> Path:
    """Take every free byte of the file system holding `folder`, as another program would."""
    path = folder / "another-program.bin"
    block = b"\0" * 2**20
    with open(path, "wb", buffering=0) as stream:
        size = len(block)
        while size:
            try:
                stream.write(block[:size])
            except OSError as exc:
                if exc.errno != errno.ENOSPC:
                    raise
                size //= 2
        with contextlib.suppress(OSError):
            os.fsync(stream.fileno())
    return path


class SmallDisk:
    """`root`: a folder on a disk of `size_mib`; `fill()` fills it to 100 %. Closed (the
    disk unmounted, the patches undone) by `close()` or at the end of a `with` block."""

    def __init__(self, base: Path, size_mib: int) -> None:
        self.kind = DISK_KIND
        self.root = base / "disk"
        self.root.mkdir()
        self._patch = pytest.MonkeyPatch()
        self.mounted = False
        if self.kind == "tmpfs":
            subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_mib}m", "tmpfs",
                            str(self.root)], check=True, capture_output=True, timeout=20)
            self.mounted = True

    def fill(self) -> None:
        if self.kind == "tmpfs":
            fill(self.root)
            return

        def no_space(*_args):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        self._patch.setattr(reserve, "fallocate", no_space)
        self._patch.setattr(writer, "_free_bytes", lambda folder: 0)

    def free(self) -> None:
        with contextlib.suppress(FileNotFoundError):
            (self.root / "another-program.bin").unlink()
        self._patch.undo()

    def __enter__(self) -> SmallDisk:
        return self

    def __exit__(self, *_exc) -> None:
        self.close()

    def close(self) -> None:
        self._patch.undo()
        if self.mounted:
            subprocess.run(["umount", "-l", str(self.root)], capture_output=True, timeout=20)
            self.mounted = False
