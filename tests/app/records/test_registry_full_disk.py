"""The registry on a full disk (issue 28 #3): everything can still be read, by the console
and by the command line, and a write is refused in one line that says why."""

from __future__ import annotations

import sqlite3

import pytest
from hypothesis import given, strategies as st

import app.records.registry.database as database
from app.errors import RegistryError
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.snapshot import committed_image, snapshot_connection
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT
from tests.app.cli.running import run
from tests.device.smalldisk import DISK_KIND, SmallDisk

PARAMS = THESIS_SUBJECT.replace(repetitions=1)


class FullDiskConnection:
    """A connection to the registry's file as SQLite gives it on a full disk: it opens,
    and its first statement cannot map the WAL's index ("disk I/O error")."""

    def __init__(self, *args, **kwargs) -> None:
        pass

    def execute(self, *_args):
        raise sqlite3.OperationalError("disk I/O error")

    def close(self) -> None:
        pass


@pytest.fixture
def full_disk_registry(tmp_path, monkeypatch):
    """A registry with a patient and a trial (and the console's WAL), its disk then filled
    by another program: (disk, registry, patient code, trial id)."""
    disk = SmallDisk(tmp_path, 96)
    try:
        folder = disk.root / "data"
        monkeypatch.setenv("REHAB_DATA_DIR", str(folder))
        monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
        registry = Registry(DataDir(folder))
        code = registry.create_patient("Ada", "Lovelace", body_mass_kg=91.0).code
        begun = registry.begin_trial(code, PARAMS, backend="simulator")
        save(simulate(PARAMS, patient="healthy"), begun.path, subject_code=code)
        from app.trials.finalize import finalize_trial

        finalize_trial(registry, begun.trial_id)
        disk.fill()
        if disk.kind == "injected":
            connect = sqlite3.connect

            def full(target, *args, **kwargs):
                if str(target) == ":memory:":
                    return connect(target, *args, **kwargs)
                return FullDiskConnection()

            monkeypatch.setattr(database.sqlite3, "connect", full)
        yield disk, registry, code, begun.trial_id
    finally:
        disk.close()


@pytest.mark.parametrize("kind", [DISK_KIND])
def test_the_registry_reads_on_a_full_disk_and_refuses_writes_in_one_line(
        full_disk_registry, kind):
    _disk, registry, code, trial_id = full_disk_registry
    again = Registry(registry.data_dir)  # opening it needs no write either
    assert [p.code for p in again.patients()] == [code]
    trial = again.trial(trial_id)
    assert trial.status == "complete"
    assert trial.metrics["rmse_x_m"] < 0.005
    assert [s.status for s in again.trial_summaries(code)] == ["complete"]
    with pytest.raises(RegistryError) as caught:
        again.create_patient("Grace", "Hopper", body_mass_kg=60.0)
    text = str(caught.value)
    assert "full" in text
    assert "nothing was saved" in text
    assert "\n" not in text


@pytest.mark.parametrize("kind", [DISK_KIND])
def test_the_command_line_lists_reports_and_shows_progress_on_a_full_disk(
        full_disk_registry, kind, capsys, tmp_path):
    """`rehab trials`, `report` and `progress` said "disk I/O error" and exited."""
    _disk, _registry, code, trial_id = full_disk_registry
    status, out, err = run(["trials", code], capsys)
    assert (status, err) == (0, "")
    assert "complete" in out
    status, out, err = run(["progress", code], capsys)
    assert status == 0
    assert "RMSE x" in out
    status, out, err = run(["report", str(trial_id), "--output", str(tmp_path / "r.pdf")],
                           capsys)
    assert status == 0, err
    assert (tmp_path / "r.pdf").stat().st_size > 0
    status, out, err = run(["patients", "add", "--first-name", "Grace", "--last-name",
                            "Hopper", "--body-mass", "60", "--upper-arm", "0.30", "--forearm",
                            "0.28", "--side", "right", "--shoulder", "-0.12", "0.73"], capsys)
    assert status == 2
    assert len(err.strip().splitlines()) == 1
    assert "full" in err


@given(st.lists(st.tuples(st.sampled_from(["insert", "update", "delete", "commit",
                                           "checkpoint"]),
                          st.integers(0, 40), st.text(max_size=300)),
                max_size=60))
def test_a_snapshot_reads_exactly_what_sqlite_reads(tmp_path_factory, steps):
    """The in-memory copy is the database file with the WAL's committed frames: what an
    ordinary reader sees, whatever was committed, checkpointed or left uncommitted."""
    path = tmp_path_factory.mktemp("wal") / "r.sqlite3"
    writer = sqlite3.connect(path, isolation_level=None)
    writer.execute("PRAGMA journal_mode = WAL")
    writer.execute("PRAGMA wal_autocheckpoint = 0")
    writer.execute("CREATE TABLE t (k INTEGER PRIMARY KEY, v TEXT)")
    writer.execute("BEGIN")
    for action, key, text in steps:
        if action == "insert":
            writer.execute("INSERT OR REPLACE INTO t VALUES (?, ?)", (key, text))
        elif action == "update":
            writer.execute("UPDATE t SET v = v || ? WHERE k % 3 = ?", (text, key % 3))
        elif action == "delete":
            writer.execute("DELETE FROM t WHERE k = ?", (key,))
        elif action == "commit":
            writer.execute("COMMIT")
            writer.execute("BEGIN")
        else:
            writer.execute("COMMIT")
            writer.execute("PRAGMA wal_checkpoint(PASSIVE)")
            writer.execute("BEGIN")
    # the last changes stay uncommitted: no reader sees them
    reader = sqlite3.connect(path)
    seen = reader.execute("SELECT * FROM t ORDER BY k").fetchall()
    reader.close()
    copy = snapshot_connection(path)
    assert copy.execute("SELECT * FROM t ORDER BY k").fetchall() == seen
    with pytest.raises(sqlite3.OperationalError, match="readonly"):
        copy.execute("DELETE FROM t")
    copy.close()
    writer.execute("ROLLBACK")
    writer.close()
    assert committed_image(path)[18:20] == b"\x01\x01"
