"""Trials a crashed console left 'recording' are finished from their files at the next
start, and a trial another console may still be recording is left alone."""

import os
import time

import pytest

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


def test_the_registry_keeps_why_a_trial_ended(tmp_path):
    """Issue 13 #18: the fault's words survive in the registry: from the file's last fault
    event, or (a dead recorder, a full disk: the file cannot hold it) as the caller saw
    it. A complete trial has none."""
    from app.trials.finalize import finalize_lost, finalize_trial

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Lovelace", body_mass_kg=91.0).code
    faulted, complete, lost, unreadable = (
        registry.begin_trial(code, PARAMS, backend="simulator") for _ in range(4))
    pushed = simulate(PARAMS, patient="wrong_way", patient_options={
        "wrong_way_force_N": 50.0, "wrong_way_fraction": 0.9, "wrong_way_episode_s": 5.0})
    assert pushed.status == "faulted"
    save(pushed, faulted.path, subject_code=code)
    save(simulate(PARAMS, patient="healthy"), complete.path, subject_code=code)
    save(simulate(PARAMS, patient="healthy"), lost.path, subject_code=code)
    unreadable.path.write_bytes(b"cut off")

    finalize_trial(registry, faulted.trial_id)
    finalize_trial(registry, complete.trial_id, reason="ignored: it completed")
    finalize_lost(registry, lost.trial_id, "the recorder process stopped")
    finalize_lost(registry, unreadable.trial_id, "the disk is full")

    fault = [e for e in pushed.events if e["kind"] == "fault"][-1]["message"]
    assert fault
    assert registry.trial(faulted.trial_id).end_reason == fault
    assert registry.trial(complete.trial_id).end_reason == ""
    assert registry.trial(lost.trial_id).end_reason == "the recorder process stopped"
    assert registry.trial(unreadable.trial_id).end_reason == "the disk is full"


def test_the_registry_and_the_next_proposal_take_the_level_the_trial_ended_at(tmp_path):
    """Issue 27, item 5: a trial built at 100 % that the therapist lowered to 60 % during
    its exercise was stored and followed as a 100 % trial ("100 % → 90 %", more help than
    the patient just had). Its file's per-tick level (as the live loop records it) is what
    the registry and the proposal read."""
    import numpy as np

    from app.trials.finalize import finalize_trial
    from app.trials.headless import SimulatedTrial

    params = THESIS_SUBJECT.replace(assist="as-needed", repetitions=2)
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Lovelace", body_mass_kg=91.0).code
    begun = registry.begin_trial(code, params, backend="simulator")
    trial = simulate(params, patient="weak", seed=0)
    records = trial.records.copy()
    exercise = np.flatnonzero(records["phase"] == 2)
    change = int(exercise[0]) + 2900  # 5.8 s into the exercise
    records["assistance_level"][change:] = 0.6
    event = {"time_s": change * 0.002, "tick": change, "kind": "assistance",
             "message": "assistance level set to 60%", "values": {"level": 0.6}}
    changed = SimulatedTrial(**{**{f: getattr(trial, f) for f in trial.__slots__},
                                "records": records, "events": (*trial.events, event)})
    save(changed, begun.path, subject_code=code)

    done = finalize_trial(registry, begun.trial_id)

    stored = registry.trial(begun.trial_id).assistance
    assert stored.summary() == "100 % → 60 % at 5.8 s"
    assert (stored.at_start, stored.at_end) == (1.0, 0.6)
    assert done.proposal.change == "assistance"  # the weak patient led about 89 %
    assert "60 % → 50 %" in done.proposal.reason
    assert done.proposal.assistance_level == 0.5
    # the robot as the file names it, with the simulator's seed of this trial
    assert registry.trial(begun.trial_id).backend == "simulator (weak, seed 0)"


KILLED_IN_THE_CLOSE = """
import os, sys
from app.trials.headless import simulate
from core.trial import THESIS_SUBJECT
from device.recording.trialfile import SubjectInfo, TrialFileWriter

params = THESIS_SUBJECT.replace(repetitions=1)
trial = simulate(params, patient="healthy")
writer = TrialFileWriter(sys.argv[1], parameters=params,
                         subject=SubjectInfo.from_parameters(sys.argv[2], params),
                         robot={}, backend="simulator", sample_period_s=0.002)
writer.append(trial.records)
writer.flush()
writer.close("complete")  # the reopen below is the close's, killed half way
import h5py
f = h5py.File(sys.argv[1], "r+", libver=("v110", "v110"), locking=False)
del f.attrs["seal"], f.attrs["seal_sha256"]  # the close writes its seal last
f.attrs["status"] = "complete"
f.require_group("metrics").attrs["rmse_x_m"] = 0.5
f.flush()
os.kill(os.getpid(), 9)
"""


def test_a_file_whose_writer_was_killed_while_adding_to_it_is_finished_from_its_samples(
        tmp_path):
    """Issue 28 #2: a writer killed while it had a trial file open for writing (the close's
    reopen, the metrics, EMG) left it flagged "open for writing"; no reader could open it
    ("file is not already open for SWMR writing") and the trial was listed as lost with
    no figures. The next start clears the flags of the dead writer (as h5clear -s) and
    finishes the trial from its samples."""
    import subprocess
    import sys
    from pathlib import Path

    import h5py

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Lovelace", body_mass_kg=91.0).code
    begun = registry.begin_trial(code, PARAMS, backend="simulator")
    begun.path.parent.mkdir(parents=True, exist_ok=True)
    root = Path(__file__).resolve().parents[3]
    ran = subprocess.run([sys.executable, "-c", KILLED_IN_THE_CLOSE, str(begun.path), code],
                         cwd=root, capture_output=True, text=True, timeout=300)
    assert ran.returncode == -9, ran.stderr
    with pytest.raises(OSError, match="open for write"):
        h5py.File(begun.path, "r")
    an_hour_ago = time.time() - 3600
    os.utime(begun.path, (an_hour_ago, an_hour_ago))

    lines = finish_interrupted(registry)

    trial = registry.trial(begun.trial_id)
    assert "its file was kept" in lines[0]
    assert trial.status == "complete"
    assert trial.metrics["rmse_x_m"] < 0.005  # from its samples, not the half-written 0.5
    with h5py.File(begun.path, "r") as f:
        assert f["timeseries/tick"].shape[0] > 1000
