"""Where the compiled kernels are cached, worked out without importing numba (the
install script asks whether the cache is warm before paying for numba's import).

numba invalidates a cached function only when its own file changes, not when a
kernel it calls from another file does, so the directory is keyed by a hash of every
source the kernels may come from (core and device, core.kernels) and of where they
are: any edit there starts a fresh cache. Set REHAB_NUMBA_CACHE to put it elsewhere.

numba unpickles the index files it finds in the cache and runs the machine code beside
them, in the process that drives the robot: a cache another user can write is a way to
run their code there (issue 28 #9: a pickle planted in the old shared fallback,
$TMPDIR/rehab-console-numba, ran inside `rehab run`). So the cache is used only in a
folder of this user's alone, checked, not assumed (device.safewrite.folder_problem:
owned by the user, writable by no one else, not a symbolic link, every folder on the
way owned by the user or root and writable by no one else unless sticky); it is made
0700 where missing. Anywhere else `CACHE_DIR` is None, `CACHE_PROBLEM` says why, and
the kernels are compiled in memory only, every start: slower, never unsafe. There is no
fallback to a shared folder.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from device.safewrite import OutputRefused, folder_problem, make_private_folders

_PACKAGE = Path(__file__).resolve().parent
_SOURCES = (_PACKAGE.parents[1] / "core", _PACKAGE.parent)
"""Where kernels live: core and device (this package's parent)."""


def _source_hash() -> str:
    # numba files its cache under the source's path too: two checkouts get two caches
    digest = hashlib.sha256(str(_PACKAGE).encode())
    for root in _SOURCES:
        for path in sorted(root.rglob("*.py")):
            digest.update(str(path.relative_to(root.parent)).encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _cache_root() -> Path:
    explicit = os.environ.get("REHAB_NUMBA_CACHE")
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "rehab-console" / "numba"


def private_cache_dir(root: Path | None = None) -> tuple[Path | None, str]:
    """(the cache folder for this source under `root` (default: REHAB_NUMBA_CACHE or the
    user's cache folder), "") when it is this user's alone and writable; (None, why)
    otherwise, and nothing found there is ever loaded."""
    root = _cache_root() if root is None else root
    path = root / _source_hash()
    for folder in (root, path):  # the root checked before anything is made inside it
        try:
            make_private_folders(folder)
        except OutputRefused as exc:
            return None, str(exc)
        problem = folder_problem(folder, follow_links=False)
        if problem:
            return None, f"the compiled kernels' cache {path}: its folder {folder} {problem}"
    try:
        probe = path / ".probe"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        return None, f"the compiled kernels' cache {path} cannot be written ({exc.strerror})"
    return path, ""


CACHE_DIR, CACHE_PROBLEM = private_cache_dir()


ENTRY_KERNELS = ("engine.run_ticks", "engine.simulated_tick", "engine.supervised_command",
                 "checks.supervise", "control_kernel.control", "physics.read", "physics.write",
                 "physics.reset")
"""The kernels called from Python, as numba names their cache files (<module>.<name>);
the others are compiled into them."""


def is_warm() -> bool:
    """Whether the cache already holds every entry kernel for this source."""
    if CACHE_DIR is None:
        return False
    cached = {path.name.split("-")[0] for path in CACHE_DIR.rglob("*.nbi")}
    return all(name in cached for name in ENTRY_KERNELS)
