"""Each finished trial's file copied into the department's shared trial store, proven whole
before the registry records it there (issue 32; app.records.trialstore,
app.records.registry.stores, schema v11). On both engines (tests/app/records/conftest.py)."""

from __future__ import annotations

import errno
import os

import pytest

import app.records.trialstore as trialstore
from app.errors import InvalidRecordError, RegistryError
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.trialstore import store_pending, store_trial
from app.trials.finalize import finalize_trial
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT
from tests.app.records.history import registry_at
from tests.device.smalldisk import DISK_KIND, SmallDisk

PARAMS = THESIS_SUBJECT.replace(duration_s=2.0)


def _finished_trial(registry, code):
    begun = registry.begin_trial(code, PARAMS, backend="simulator")
    save(simulate(PARAMS, patient="healthy"), begun.path, subject_code=code)
    return registry.trial(finalize_trial(registry, begun.trial_id).trial_id)


@pytest.fixture
def station(open_registry):
    registry = open_registry(station="robot-2")
    return registry, registry.create_patient("Ada", "Example").code


def test_a_finished_trial_is_copied_proven_and_recorded_where_it_is(station, tmp_path):
    registry, code = station
    trial = _finished_trial(registry, code)
    store = tmp_path / "store" / "robot-2"
    store.mkdir(parents=True)
    assert registry.trials_to_store() == [trial]

    done = store_pending(registry, store)
    assert done.problems == []
    (stored,) = done.trials
    assert stored.stored_in == str(store)
    copy = store / trial.file
    assert copy.read_bytes() == registry.trial_path(trial).read_bytes()
    assert registry.trial(trial.id).stored_in == str(store)
    assert registry.verify_trial_file(trial.id) is None
    assert registry.trials_to_store() == []
    assert [p.name for p in copy.parent.iterdir()] == [copy.name]  # no partial left
    assert store_pending(registry, store).trials == []  # nothing twice

    with open(copy, "r+b") as file:  # the store's copy damaged later
        file.seek(-1, 2)
        last = file.read(1)
        file.seek(-1, 2)
        file.write(bytes([last[0] ^ 1]))
    problem = registry.verify_trial_file(trial.id)
    assert str(copy) in problem
    assert "restore it from the station's data folder" in problem


def test_a_store_not_mounted_keeps_the_trials_waiting_and_takes_them_when_it_is(
        station, tmp_path):
    registry, code = station
    first, second = _finished_trial(registry, code), _finished_trial(registry, code)
    store = tmp_path / "not-mounted"
    done = store_pending(registry, store)
    assert done.trials == []
    assert len(done.problems) == 1  # one line for the store, not one per trial
    assert "is not there (is the network folder mounted?)" in done.problems[0]
    assert [t.id for t in registry.trials_to_store()] == [first.id, second.id]
    store.mkdir()
    assert [t.id for t in store_pending(registry, store).trials] == [first.id, second.id]


def test_a_different_file_in_the_store_is_never_replaced_and_the_others_go_on(
        station, tmp_path):
    registry, code = station
    first, second = _finished_trial(registry, code), _finished_trial(registry, code)
    store = tmp_path / "store"
    (store / first.file).parent.mkdir(parents=True)
    (store / first.file).write_bytes(b"someone else's file")
    done = store_pending(registry, store)
    assert [t.id for t in done.trials] == [second.id]
    (line,) = done.problems
    assert "is another file than trial" in line
    assert "it was not replaced" in line
    assert (store / first.file).read_bytes() == b"someone else's file"
    assert registry.trial(first.id).stored_in is None


def test_a_copy_already_there_and_whole_is_recorded_as_it_is(station, tmp_path):
    registry, code = station
    trial = _finished_trial(registry, code)
    store = tmp_path / "store"
    (store / trial.file).parent.mkdir(parents=True)
    (store / trial.file).write_bytes(registry.trial_path(trial).read_bytes())
    assert store_trial(registry, trial, store).stored_in == str(store)


@pytest.mark.changes_recorded_files  # on purpose (tests/recorded_files.py)
def test_a_data_folder_file_changed_since_its_end_is_not_copied(station, tmp_path):
    registry, code = station
    trial = _finished_trial(registry, code)
    with open(registry.trial_path(trial), "ab") as file:
        file.write(b"\0")
    store = tmp_path / "store"
    store.mkdir()
    (line,) = store_pending(registry, store).problems
    assert "is not the one recorded" in line
    assert not any(store.rglob("*.h5*"))  # neither the file nor a partial copy
    assert registry.trial(trial.id).stored_in is None


@pytest.mark.parametrize("kind", [DISK_KIND])
def test_a_full_store_leaves_nothing_half_written_and_the_trial_waits(
        station, tmp_path, monkeypatch, kind):
    registry, code = station
    trial = _finished_trial(registry, code)
    disk = SmallDisk(tmp_path, 1)
    try:
        if kind == "injected":
            def full(_writer, _piece):
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            monkeypatch.setattr(trialstore, "_write", full)
        (line,) = store_pending(registry, disk.root).problems
        assert "could not be copied to the trial store" in line
        assert "No space left on device" in line
        assert "\n" not in line
        assert not any(disk.root.rglob("*.h5*"))
        assert registry.trial(trial.id).stored_in is None
    finally:
        disk.close()


def test_only_a_finished_trial_with_its_checksum_is_recorded_as_stored(station):
    registry, code = station
    begun = registry.begin_trial(code, PARAMS, backend="simulator")
    with pytest.raises(RegistryError, match="has no checksum kept yet"):
        registry.record_stored(begun.trial_id, "/mnt/store")
    with pytest.raises(InvalidRecordError, match="give the trial store's folder as an "
                                                 "absolute path"):
        registry.record_stored(begun.trial_id, "relative/store")


def test_a_v10_registry_gains_the_store_keeping_every_trial(tmp_path):
    folder = tmp_path / "data"
    with registry_at(folder, 10) as conn:
        conn.execute("INSERT INTO patients (code, created_at) VALUES ('P0000001', 'c')")
        conn.execute("INSERT INTO sessions (patient_id, number, date) VALUES (1, 1, "
                     "'2026-12-01')")
        conn.execute("INSERT INTO trials (session_id, number, parameters, file, metrics, "
                     "status, started_at, station, checksum) VALUES (1, 1, '{}', "
                     "'trials/P0000001/a.h5', '{\"rmse_x_mm\": 2.5}', 'complete', "
                     f"'2026-12-01T10:00:00+00:00', 'robot-1', '{'a' * 64}')")
    registry = Registry(DataDir(folder))
    (trial,) = registry.trials_for_patient("P0000001")
    assert (trial.metrics, trial.station, trial.checksum, trial.stored_in) == (
        {"rmse_x_mm": 2.5}, "robot-1", "a" * 64, None)
    assert registry.integrity_check() == []


def test_rehab_run_copies_to_the_store_and_rehab_trials_says_where(tmp_path, capsys,
                                                                   monkeypatch):
    """As a station's command line uses it: the setting names the store; `rehab run` copies
    its trial (and any waiting), `rehab trials` says where the copy is; a store not mounted
    is one line on stderr, the trial waiting."""
    from app.cli.main import main
    from app.records.settings import Settings, save_settings

    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    store = tmp_path / "share" / "robot-1"
    save_settings(Settings(trial_store=str(store)))
    data = ["--data-dir", str(tmp_path / "data")]
    code = Registry(DataDir(tmp_path / "data")).create_patient("Ada", "Example").code
    assert main(["run", "--code", code, "--duration", "2", *data]) == 0
    out, err = capsys.readouterr()
    assert err.count("is not there (is the network folder mounted?)") == 1
    store.mkdir(parents=True)
    assert main(["run", "--code", code, "--duration", "2", *data]) == 0
    out, err = capsys.readouterr()
    assert "Copied to the trial store" in out
    assert "2 trial file(s), each checked against its checksum" in out
    assert main(["trials", code, *data]) == 0
    out, _ = capsys.readouterr()
    assert out.count(f"a copy in the trial store {store}") == 2
