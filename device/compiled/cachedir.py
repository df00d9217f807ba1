"""Where the compiled kernels are cached, worked out without importing numba (the
install script asks whether the cache is warm before paying for numba's import).

numba invalidates a cached function only when its own file changes, not when a
kernel it calls from another file does, so the directory is keyed by a hash of every
file in this package (and of where it is): any edit starts a fresh cache. Set
REHAB_NUMBA_CACHE to put it elsewhere; where no directory is writable it is None and
the kernels are compiled in memory only.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent


def _source_hash() -> str:
    # numba files its cache under the source's path too: two checkouts get two caches
    digest = hashlib.sha256(str(_PACKAGE).encode())
    for path in sorted(_PACKAGE.glob("*.py")):
        digest.update(path.name.encode())
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


ENTRY_KERNELS = ("dynamics.evaluate", "dynamics.patient_torque", "trial.run_ticks",
                 "looptick.loop_tick", "looptick.warm_tick")
"""The kernels called from Python (the others are compiled into them)."""


def is_warm() -> bool:
    """Whether the cache already holds every entry kernel for this source."""
    if CACHE_DIR is None:
        return False
    cached = {path.name.split("-")[0] for path in CACHE_DIR.rglob("*.nbi")}
    return all(name in cached for name in ENTRY_KERNELS)
