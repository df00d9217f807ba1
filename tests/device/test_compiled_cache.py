"""The compiled kernels' cache: keyed by the source, known warm only when it holds
every kernel the Python side calls."""

import os
import time

from device.compiled import cachedir, warmup


def test_the_cache_is_warm_only_with_every_entry_kernel(tmp_path, monkeypatch):
    monkeypatch.setattr(cachedir, "CACHE_DIR", tmp_path)
    assert not cachedir.is_warm()
    index = tmp_path / "compiled_0123"
    index.mkdir()
    (index / "trial.run_ticks-170.py311.nbi").write_bytes(b"")
    (index / "looptick.loop_tick-150.py311.nbi").write_bytes(b"")
    assert not cachedir.is_warm()
    (index / "looptick.warm_tick-190.py311.nbi").write_bytes(b"")
    assert not cachedir.is_warm()
    (index / "dynamics.evaluate-240.py311.nbi").write_bytes(b"")
    (index / "dynamics.patient_torque-130.py311.nbi").write_bytes(b"")
    assert cachedir.is_warm()


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
