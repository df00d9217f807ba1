"""Trials a crashed console left 'recording' are finished from their files at the next
start, and a trial another console may still be recording is left alone."""

import os
import time

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.trials.finalize import finish_interrupted
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT

PARAMS = THESIS_SUBJECT.replace(repetitions=1)


def test_interrupted_trials_are_finished_from_their_files(tmp_path):
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Lovelace", body_mass_kg=91.0).code
    closed, missing, damaged, live = (
        registry.begin_trial(code, PARAMS, backend="simulator") for _ in range(4))
    save(simulate(PARAMS, patient="healthy"), closed.path, subject_code=code)
    closed.path.parent.mkdir(parents=True, exist_ok=True)
    damaged.path.write_bytes(b"not an HDF5 file")
    save(simulate(PARAMS, patient="weak"), live.path, subject_code=code)
    an_hour_ago = time.time() - 3600
    for begun in (closed, damaged):
        os.utime(begun.path, (an_hour_ago, an_hour_ago))

    lines = finish_interrupted(registry)

    assert registry.trial(closed.trial_id).status == "complete"
    assert registry.trial(closed.trial_id).metrics["rmse_x_m"] < 0.005
    assert registry.trial(missing.trial_id).status == "recording_lost"
    assert registry.trial(damaged.trial_id).status == "recording_lost"
    assert registry.trial(live.trial_id).status == "recording"  # written seconds ago
    assert len(lines) == 3
    assert "now listed as complete" in lines[0]
    assert "file is missing" in lines[1]
    assert "cannot be read" in lines[2]
    assert [t.id for t in registry.unfinished_trials()] == [live.trial_id]
    assert finish_interrupted(registry, now=time.time() + 60) != []
    assert registry.unfinished_trials() == []


def test_a_trial_whose_recorder_died_is_finished_whatever_its_file_holds(tmp_path):
    from app.trials.finalize import finalize_lost

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Lovelace", body_mass_kg=91.0).code
    readable, unreadable = (registry.begin_trial(code, PARAMS, backend="simulator")
                            for _ in range(2))
    save(simulate(PARAMS, patient="healthy"), readable.path, subject_code=code)
    unreadable.path.write_bytes(b"cut off by a killed recorder")
    for begun in (readable, unreadable):
        done = finalize_lost(registry, begun.trial_id)
        assert done.status == "recording_lost"
        assert registry.trial(begun.trial_id).status == "recording_lost"
    assert "could not be read" in done.notes[0]
