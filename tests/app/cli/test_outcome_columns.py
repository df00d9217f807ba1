"""Researchers see what each trial ran and what followed it (issue 27, item 18):
`trials.csv` of an export, `rehab trials` and `rehab progress --csv` give the assistance
mode, the levels in effect (start, end, changes), the proposal and its decision, and why a
trial ended; all three say the same."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest

from app.cli.main import main
from app.records.datadir import DataDir
from app.records.outcomes import OUTCOME_COLUMNS
from app.records.registry import Registry
from app.trials.finalize import finalize_trial
from app.trials.headless import SimulatedTrial, save, simulate
from core.trial import THESIS_SUBJECT

PARAMS = THESIS_SUBJECT.replace(assist="as-needed", repetitions=2)
FAULT = "torque limit: 5.1 N·m > 5 N·m"


def _lowered(trial: SimulatedTrial, at_tick: int, level: float) -> SimulatedTrial:
    """The trial as the live loop records a therapist's change at `at_tick`."""
    records = trial.records.copy()
    records["assistance_level"][at_tick:] = level
    event = {"time_s": at_tick * 0.002, "tick": at_tick, "kind": "assistance",
             "message": f"assistance level set to {level:.0%}", "values": {"level": level}}
    return SimulatedTrial(**{**{f: getattr(trial, f) for f in trial.__slots__},
                             "records": records, "events": (*trial.events, event)})


@pytest.fixture
def course(tmp_path, monkeypatch, capsys):
    """Three trials of one patient: one lowered to 60 % live, one as proposed, one faulted."""
    monkeypatch.setenv("REHAB_DATA_DIR", str(tmp_path / "data"))
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Example", body_mass_kg=91.0).code
    params = PARAMS.replace(**registry.patient(code).trial_overrides())
    first = registry.begin_trial(code, params, backend="simulator")
    trial = simulate(params, patient="weak", seed=0)
    start = int(np.flatnonzero(trial.records["phase"] == 2)[0])
    save(_lowered(trial, start + 2900, 0.6), first.path, subject_code=code)
    finalize_trial(registry, first.trial_id)
    capsys.readouterr()
    assert main(["run", "--code", code, "--patient", "weak", "--repetitions", "2",
                 "--assist", "as-needed", "--as-proposed", "--seed", "0"]) == 0
    third = registry.begin_trial(code, params, backend="simulator")
    save(simulate(params, patient="weak", seed=1), third.path, subject_code=code)
    finalize_trial(registry, third.trial_id, "faulted", FAULT)
    capsys.readouterr()
    return tmp_path, code


def test_the_three_places_say_what_each_trial_ran_and_what_followed(course, capsys):
    tmp_path, code = course

    assert main(["trials", code]) == 0
    listing = capsys.readouterr().out
    assert "as-needed" in listing
    assert "100 % → 60 % at 5.8 s" in listing
    assert "60 % → 50 %" in listing  # the proposal after it, from where it ended
    assert "(accepted)" in listing
    assert f"ended: {FAULT}" in listing
    assert "robot: simulator (weak, seed 0)" in listing

    assert main(["progress", code, "--csv"]) == 0
    progress = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
    assert main(["export", "--patient", code, "--output", str(tmp_path / "out")]) == 0
    capsys.readouterr()
    with (tmp_path / "out" / "trials.csv").open(newline="") as stream:
        exported = list(csv.DictReader(stream))

    for rows in (progress, exported):
        assert len(rows) == 3
        assert set(OUTCOME_COLUMNS) <= set(rows[0])
        first, second, third = rows
        assert {r["assistance_mode"] for r in rows} == {"as-needed"}
        assert (float(first["assistance_level_start"]),
                float(first["assistance_level_end"])) == (1.0, 0.6)
        assert json.loads(first["assistance_changes"]) == [[pytest.approx(5.8), 0.6]]
        assert float(first["proposal_assistance_level"]) == 0.5
        assert first["proposal_decision"] == "accepted"
        assert float(second["assistance_level_start"]) == 0.5
        assert json.loads(second["assistance_changes"]) == []
        assert second["proposal_decision"] == "changed"  # the third went back to 100 %
        assert third["end_reason"] == FAULT
        assert third["proposal_decision"] == "pending"
        assert first["end_reason"] == ""


def test_a_folder_export_reads_the_levels_and_the_fault_from_the_files(course, capsys):
    tmp_path, _ = course
    assert main(["export", "--folder", str(tmp_path / "data" / "trials"), "--output",
                 str(tmp_path / "study")]) == 0
    capsys.readouterr()
    with (tmp_path / "study" / "trials.csv").open(newline="") as stream:
        rows = sorted(csv.DictReader(stream), key=lambda r: r["trial"])
    assert json.loads(rows[0]["assistance_changes"]) == [[pytest.approx(5.8), 0.6]]
    assert rows[0]["proposal_decision"] == ""  # no registry: no proposal
    assert rows[2]["end_reason"] == ""  # this file holds no fault event; the registry does
