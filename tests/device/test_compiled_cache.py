"""The compiled kernels' cache: keyed by the source, known warm only when it holds
every kernel the Python side calls."""

import os
import time
from pathlib import Path

from device.compiled import cachedir, warmup


def test_the_cache_is_warm_only_with_every_entry_kernel(tmp_path, monkeypatch):
    monkeypatch.setattr(cachedir, "CACHE_DIR", tmp_path)
    assert not cachedir.is_warm()
    index = tmp_path / "compiled_0123"
    index.mkdir()
    first, *rest = cachedir.ENTRY_KERNELS
    (index / f"{first}-170.py311.nbi").write_bytes(b"")
    (index / "robot_terms.mass_terms-150.py311.nbi").write_bytes(b"")  # not an entry
    assert not cachedir.is_warm()
    for name in rest[:-1]:
        (index / f"{name}-190.py311.nbi").write_bytes(b"")
    assert not cachedir.is_warm()
    (index / f"{rest[-1]}-240.py311.nbi").write_bytes(b"")
    assert cachedir.is_warm()


def test_every_entry_kernel_is_in_a_warm_cache():
    """The names are numba's own: after load_kernels the real cache holds them all."""
    warmup.load_kernels()
    assert cachedir.is_warm()


def test_the_cache_key_covers_the_kernels_in_core_too():
    """A kernel in core compiled into the loop's tick must start a fresh cache when it
    changes (numba would not notice: the caller's file did not change)."""
    import core.robot_terms

    sources = [path for root in cachedir._SOURCES for path in root.rglob("*.py")]
    assert Path(core.robot_terms.__file__).resolve() in [p.resolve() for p in sources]


def test_the_cache_directory_is_keyed_by_the_source():
    assert cachedir.CACHE_DIR is not None
    assert cachedir.CACHE_DIR.name == cachedir._source_hash()


def test_stale_caches_of_earlier_sources_are_pruned(tmp_path, monkeypatch):
    current = tmp_path / "0123456789abcdef"
    stale = tmp_path / "fedcba9876543210"
    recent = tmp_path / "aaaaaaaaaaaaaaaa"  # another checkout, in use
    other = tmp_path / "keep-me"
    for folder in (current, stale, recent, other):
        folder.mkdir()
    month_ago = time.time() - 30 * 24 * 3600
    os.utime(stale, (month_ago, month_ago))
    os.utime(other, (month_ago, month_ago))
    monkeypatch.setattr(warmup, "CACHE_DIR", current)
    assert warmup.prune_stale_caches() == [stale]
    assert current.exists()
    assert recent.exists()
    assert other.exists()
    assert not stale.exists()
