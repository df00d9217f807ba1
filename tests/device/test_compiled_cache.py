"""The compiled kernels' cache: keyed by the source, known warm only when it holds
every kernel the Python side calls."""

import os
import pickle
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

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
    assert cachedir.is_warm(), (cachedir.CACHE_DIR, cachedir.CACHE_PROBLEM)


def test_every_entry_kernel_is_in_a_warm_cache():
    """The names are numba's own: after load_kernels the real cache holds them all."""
    warmup.load_kernels()
    assert cachedir.is_warm(), (cachedir.CACHE_DIR, cachedir.CACHE_PROBLEM)


def test_the_cache_key_covers_the_kernels_in_core_too():
    """A kernel in core compiled into the loop's tick must start a fresh cache when it
    changes (numba would not notice: the caller's file did not change)."""
    import core.robot_terms

    sources = [path for root in cachedir._SOURCES for path in root.rglob("*.py")]
    assert Path(core.robot_terms.__file__).resolve() in [p.resolve() for p in sources]


def test_the_cache_directory_is_keyed_by_the_source():
    assert cachedir.CACHE_DIR is not None, cachedir.CACHE_PROBLEM
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


# -- a cache no one else can write (issue 28 #9) ----------------------------------------------
ROOT = Path(__file__).resolve().parents[2]
SMALL_KERNEL = ("from core.robot_terms import trig\n"
                "from device.compiled import cachedir\n"
                "from device.compiled.jit import compiled\n"
                "print(cachedir.CACHE_DIR)\n"
                "compiled(trig)(0.1, 0.2)\n")


class _Payload:
    """What an attacker would plant: unpickling it runs code (here: makes a file)."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return exec, (f"import pathlib; pathlib.Path({str(self.marker)!r}).touch()",)


def _compile_small_kernel(env: dict) -> str:
    done = subprocess.run([sys.executable, "-c", SMALL_KERNEL], env=env, cwd=ROOT,
                          capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


@pytest.mark.slow
def test_a_pickle_planted_in_the_old_shared_fallback_never_runs(tmp_path):
    """With the user's cache folder unusable the cache once fell back to a shared,
    predictable $TMPDIR/rehab-console-numba/<hash>, accepted a folder found there, and
    numba unpickled its index files: a planted pickle ran inside `rehab run`. Now there is
    no fallback: the kernels compile in memory and nothing there is read."""
    env = {k: v for k, v in os.environ.items() if k != "REHAB_NUMBA_CACHE"}
    # where numba files this kernel's index, relative to the cache folder it was given
    # (the folder the console printed, <REHAB_NUMBA_CACHE>/<source hash>: relative to
    # REHAB_NUMBA_CACHE itself the plant went one folder too deep and was never read)
    learned = Path(_compile_small_kernel({**env, "REHAB_NUMBA_CACHE":
                                          str(tmp_path / "learned")}))
    indexes = [p.relative_to(learned) for p in learned.rglob("*.nbi")]
    assert indexes
    shared = tmp_path / "tmp"
    shared.mkdir()
    shared.chmod(0o1777)
    marker = tmp_path / "payload-ran"
    planted = shared / "rehab-console-numba" / cachedir._source_hash()
    for index in indexes:
        (planted / index).parent.mkdir(parents=True, exist_ok=True)
        (planted / index).write_bytes(pickle.dumps(_Payload(marker)))
    unusable = tmp_path / "not-a-folder"
    unusable.write_text("the user's cache folder cannot be made here")
    used = _compile_small_kernel({**env, "XDG_CACHE_HOME": str(unusable),
                                  "HOME": str(unusable), "TMPDIR": str(shared)})
    assert not marker.exists(), "the planted pickle ran"
    assert used == "None"


def test_the_cache_is_only_in_a_folder_of_the_users_alone(tmp_path):
    mine, problem = cachedir.private_cache_dir(tmp_path / "new" / "cache")
    assert problem == ""
    assert mine == tmp_path / "new" / "cache" / cachedir._source_hash()
    assert stat.S_IMODE(mine.stat().st_mode) == stat.S_IMODE(mine.parent.stat().st_mode) \
        == 0o700
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    folder, problem = cachedir.private_cache_dir(shared)
    assert folder is None
    assert "can be written by others" in problem
    assert list(shared.iterdir()) == []  # nothing made in it
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / cachedir._source_hash()).mkdir(mode=0o700)
    linked = tmp_path / "linked"
    linked.mkdir()
    (linked / cachedir._source_hash()).symlink_to(elsewhere / cachedir._source_hash())
    folder, problem = cachedir.private_cache_dir(linked)
    assert folder is None
    assert "symbolic link" in problem
    if os.geteuid() == 0:  # a folder another user made, as root can make one
        theirs = tmp_path / "theirs"
        (theirs / cachedir._source_hash()).mkdir(parents=True, mode=0o700)
        os.chown(theirs / cachedir._source_hash(), 65534, 65534)
        folder, problem = cachedir.private_cache_dir(theirs)
        assert folder is None
        assert "belongs to" in problem
