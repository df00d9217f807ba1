"""Where the compiled kernels are cached, worked out without importing numba (the
install script asks whether the cache is warm before paying for numba's import).

numba invalidates a cached function only when its own file changes, not when a
kernel it calls from another file does, so the directory is keyed by a hash of every
source the kernels may come from (core and device, core.kernels) and of where they
are: any edit there starts a fresh cache. Set
REHAB_NUMBA_CACHE to put it elsewhere; where no directory is writable it is None and
the kernels are compiled in memory only.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

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


def _writable_cache_dir() -> Path | None:
    for root in (_cache_root(), Path(tempfile.gettempdir()) / "rehab-console-numba"):
        path = root / _source_hash()
        try:
            path.mkdir(parents=True, exist_ok=True)
            probe = path / ".probe"
            probe.write_bytes(b"")
            probe.unlink()
        except OSError:
            continue
        return path
    return None


CACHE_DIR = _writable_cache_dir()


ENTRY_KERNELS = ("engine.run_ticks", "engine.simulated_tick", "engine.supervised_command",
                 "checks.supervise", "pipeline.control", "physics.read", "physics.write",
                 "physics.reset")
"""The kernels called from Python, as numba names their cache files (<module>.<name>);
the others are compiled into them."""


def is_warm() -> bool:
    """Whether the cache already holds every entry kernel for this source."""
    if CACHE_DIR is None:
        return False
    cached = {path.name.split("-")[0] for path in CACHE_DIR.rglob("*.nbi")}
    return all(name in cached for name in ENTRY_KERNELS)
