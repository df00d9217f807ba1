"""A study or an export from the registry reads each trial where its file is and only the
file recorded (issue 32: "trial files go to a shared trial store … and the registry records
where each file is and its checksum"; app.exports.plan.verified_place): the data folder's
file, else the shared trial store's copy, each only when its SHA-256 is the checksum kept at
the trial's end. A researcher's machine without a station's data folder reads the store; a
file changed since its trial ended is listed with why, never measured or exported as if it
were the trial."""

from __future__ import annotations

import pytest

from app.exports.run import export_patients
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.trialstore import store_pending
from app.study import sources
from app.study.rows import analyse_trials
from app.trials.finalize import finalize_trial
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT
from tests.trialfiles import flip_last_byte

PARAMS = THESIS_SUBJECT.replace(duration_s=2.0)


@pytest.fixture
def department(tmp_path):
    """A station's registry with four finished trials of one patient, the first three copied
    into the shared trial store (proven whole), the fourth not yet."""
    registry = Registry(DataDir(tmp_path / "data"), station="robot-2")
    code = registry.create_patient("Ada", "Example").code
    store = tmp_path / "store" / "robot-2"
    store.mkdir(parents=True)
    trials = []
    for seed in range(4):
        begun = registry.begin_trial(code, PARAMS, backend="simulator")
        save(simulate(PARAMS, patient="healthy", seed=seed), begun.path, subject_code=code)
        trials.append(finalize_trial(registry, begun.trial_id).trial_id)
        if seed == 2:
            assert store_pending(registry, store).problems == []
    return registry, code, [registry.trial(t) for t in trials], store


def _rows(registry, code):
    frame = analyse_trials(sources.from_registry(registry, code).trials)
    return {int(row.trial_id): row for row in frame.itertuples()}


@pytest.mark.changes_recorded_files  # on purpose (tests/recorded_files.py)
def test_each_trial_is_read_where_its_recorded_file_is(department):
    registry, code, (first, second, third, fourth), store = department
    whole = _rows(registry, code)
    assert all(row.failure == "" for row in whole.values())
    assert all("trial store" not in row.notes for row in whole.values())

    registry.trial_path(first).unlink()  # the data folder's file gone: the store's is read
    flip_last_byte(registry.trial_path(second))  # changed here, whole in the store
    flip_last_byte(registry.trial_path(third))  # changed here and in the store
    flip_last_byte(store / third.file)
    flip_last_byte(registry.trial_path(fourth))  # changed here, not copied yet
    rows = _rows(registry, code)

    for trial, why in ((first, "is missing"), (second, "is not the file recorded")):
        row = rows[trial.id]
        assert row.failure == ""
        assert f"read from the trial store's copy {store / trial.file}" in row.notes
        assert why in row.notes
        assert row.metric_rmse_x_m == whole[trial.id].metric_rmse_x_m
        assert row.metric_sparc == whole[trial.id].metric_sparc
    third_failure = rows[third.id].failure
    assert str(registry.trial_path(third)) in third_failure
    assert str(store / third.file) in third_failure
    assert third_failure.count("is not the file recorded") == 2
    assert f"the registry's {third.checksum[:12]}" in third_failure
    assert third_failure.endswith("not read: restore the file from a backup")
    fourth_failure = rows[fourth.id].failure
    assert fourth_failure.startswith(f"trial {fourth.id}: {registry.trial_path(fourth)} is "
                                     "not the file recorded")
    assert "\n" not in third_failure + fourth_failure


@pytest.mark.changes_recorded_files  # on purpose (tests/recorded_files.py)
def test_an_export_takes_the_same_files_and_lists_the_others(department, tmp_path):
    registry, code, (first, _, third, _), store = department
    registry.trial_path(first).unlink()
    flip_last_byte(registry.trial_path(third))
    flip_last_byte(store / third.file)
    result = export_patients(registry, [code], tmp_path / "export")
    assert result.exported == 3
    assert [f.reason.split(":")[0] for f in result.failed] == [f"trial {third.id}"]
    assert "not read: restore the file from a backup" in result.failed[0].reason
    assert any(f"read from the trial store's copy {store / first.file}" in note
               for note in result.notes)
    index = (tmp_path / "export" / "trials.csv").read_text()
    assert first.file.rsplit("/", 1)[-1].removesuffix(".h5") in index


def test_a_file_never_stored_is_sent_to_its_station_not_to_a_backup(department):
    """A researcher's machine (or another station) reading the registry without the
    recording station's data folder: a trial never copied to a trial store is most likely
    there, not lost. It said only 'restore the file from a backup'."""
    registry, code, (*_, fourth), _ = department
    registry.trial_path(fourth).unlink()  # not here, and never copied to the store
    failure = _rows(registry, code)[fourth.id].failure
    assert failure == (
        f"trial {fourth.id}: {registry.trial_path(fourth)} is missing; not read: it was "
        "recorded at station robot-2 and is in no trial store. Run this at robot-2, copy the "
        f"file from its data folder to {registry.trial_path(fourth)}, or give the stations a "
        "shared trial store (\"trial_store\" in settings.json: README, Several stations); "
        "restore it from a backup if it is lost")
