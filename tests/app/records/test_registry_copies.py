"""The registry's copies are written as every file is (issue 28 #1, device.safewrite): the
copy Registry.backup makes, the one kept before a migration and the one kept of a damaged
registry never replace a file, are whole or absent, and are 0600 from the start whatever
the umask (a copy holds the patients' names and birth years)."""

from __future__ import annotations

import contextlib
import os
import sqlite3
import stat

import pytest

from app.errors import RegistryError, SchemaError
from app.records.datadir import DataDir
from app.records.registry import Registry


def mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.fixture
def open_umask():
    old = os.umask(0o022)
    yield
    os.umask(old)


@pytest.fixture
def registry(tmp_path) -> Registry:
    registry = Registry(DataDir(tmp_path / "data"))
    registry.create_patient("Ada", "Example", birth_year=1950)
    return registry


def rows(path) -> list:
    with contextlib.closing(sqlite3.connect(path)) as conn:
        return conn.execute("SELECT name FROM sqlite_master ORDER BY name").fetchall()


def test_a_copy_never_replaces_a_file_there(registry, tmp_path):
    """SQLite's backup copies into whatever database the name holds: another registry's
    copy, or any SQLite file, was replaced by this one."""
    theirs = tmp_path / "theirs.sqlite3"
    with sqlite3.connect(theirs) as conn:
        conn.execute("CREATE TABLE kept (x)")
    before = theirs.read_bytes()
    with pytest.raises(RegistryError, match="already exists and is kept"):
        registry.backup(theirs)
    assert theirs.read_bytes() == before
    assert rows(theirs) == [("kept",)]
    plain = tmp_path / "notes.txt"
    plain.write_text("mine")
    with pytest.raises(RegistryError, match="already exists and is kept"):
        registry.backup(plain)
    assert plain.read_text() == "mine"


def test_a_copy_goes_nowhere_the_data_folder_keeps_its_own(registry, tmp_path):
    root = registry.data_dir.root
    for inside in (root / "copy.sqlite3", registry.data_dir.ensure("trials") / "copy.sqlite3",
                   root / "registry.sqlite3.copy"):
        with pytest.raises(RegistryError, match=r"data folder|named like a registry"):
            registry.backup(inside)
        assert not inside.exists()
    copy = registry.backup(registry.data_dir.ensure("exports") / "copy.sqlite3")
    assert rows(copy) == rows(registry.path)  # below exports/: a place for outputs


def test_a_copy_is_whole_and_its_users_only_from_the_start(registry, tmp_path, open_umask):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    copy = registry.backup(elsewhere / "copy.sqlite3")
    assert sorted(p.name for p in elsewhere.iterdir()) == ["copy.sqlite3"]  # no temporary
    assert mode(copy) == 0o600
    assert rows(copy) == rows(registry.path)
    with contextlib.closing(sqlite3.connect(copy)) as conn:
        assert conn.execute("SELECT first_name FROM patients").fetchall() == [("Ada",)]


def test_every_damaged_registry_is_kept_in_a_copy_of_its_own(tmp_path, open_umask):
    """A damaged registry is copied aside before anything is done: a second refusal in the
    same second replaced the first copy, and the copy took the damaged file's mode."""
    data = DataDir(tmp_path / "data")
    data.ensure()
    data.registry_path.write_bytes(b"first damage")
    os.chmod(data.registry_path, 0o644)
    with pytest.raises(SchemaError, match="a copy is kept as"):
        Registry(data)
    data.registry_path.write_bytes(b"second damage")
    with pytest.raises(SchemaError, match="a copy is kept as"):
        Registry(data)
    kept = sorted(data.root.glob("registry.sqlite3.damaged-*"))
    assert sorted(p.read_bytes() for p in kept) == [b"first damage", b"second damage"]
    assert {mode(p) for p in kept} == {0o600}
