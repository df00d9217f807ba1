"""Norms fitted from a folder of the controls' assessment trial files: each person's first
session's figures with their covariates (registry or people table), retests from the
second session, invalid, damaged and non-assessment trials left out and said."""

from __future__ import annotations

import csv
import datetime
import shutil

import numpy as np
import pytest

from app.norms import load_norms
from app.norms.controls import (
    controls_from_trials,
    people_from_table,
    read_assessments,
    retest_from_trials,
    robot_kind,
    trial_files,
)
from core.assessment import FIGURES
from core.trial import THESIS_SUBJECT
from device.recording.record import CHANNELS, RECORD_DTYPE
from device.recording.trialfile import SubjectInfo, write_trial
from tests.app.cli.running import run
from tests.app.norms.controls import figures

PERIOD_S = 0.002
SIM = "simulator (healthy, seed 1)"
SUMMARY = {"plant": "realistic"}


def trial_file(folder, code, session, number, when, metrics, *, task="range", side="right",
               backend=SIM, summary=SUMMARY):
    records = np.zeros(10, dtype=RECORD_DTYPE)
    records["tick"] = np.arange(10)
    records["time"] = np.arange(10) * PERIOD_S
    params = THESIS_SUBJECT.replace(assessment=task, side=side)
    stamp = when.strftime("%Y%m%dT%H%M%SZ")
    path = folder / code / f"{code}_S{session:03d}_T{number:03d}_{stamp}.h5"
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_trial(path, records, parameters=params,
                       subject=SubjectInfo.from_parameters(code, params), robot={},
                       backend=backend, sample_period_s=PERIOD_S, channels=CHANNELS,
                       summary=summary, metrics=metrics)


def study(tmp_path, n=30, seed=4):
    """n controls, each with two sessions of the range task a week apart (a trait plus
    session noise), their people table; returns the folder, the table and the truth."""
    rng = np.random.default_rng(seed)
    folder = tmp_path / "trials"
    people_csv = tmp_path / "people.csv"
    truth = {}
    with people_csv.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["subject", "birth_year", "sex", "handedness"])
        for i in range(n):
            code = f"C{i:03d}"
            birth = int(rng.integers(1946, 2004))
            sex, hand = ["female", "male"][i % 2], "left" if i % 5 == 0 else "right"
            side = "left" if i % 3 == 0 else "right"
            writer.writerow([code, birth, sex, hand])
            trait = rng.standard_normal(4)
            person = {"age_years": 2026 - birth, "sex": sex}
            for session in (1, 2):
                when = datetime.datetime(2026, 3, 1 + 7 * session, 10, tzinfo=datetime.UTC)
                values = figures(person, trait, rng)
                metrics = {k: values[k] for k in ("range_area_m2", "range_area_ratio")}
                trial_file(folder, code, session, 1, when, metrics, side=side)
                truth[(code, session)] = (metrics, side, 2026 - birth)
    return folder, people_csv, truth


def test_rows_are_first_sessions_with_covariates(tmp_path):
    folder, people_csv, truth = study(tmp_path, n=6)
    # beside them: an exercise trial, a damaged file, a person not in the table
    when = datetime.datetime(2026, 3, 8, 11, tzinfo=datetime.UTC)
    trial_file(folder, "C000", 1, 2, when, {"rmse_m": 0.01}, task="")
    (folder / "C001" / "C001_S001_T009_20260308T110000Z.h5").write_bytes(b"\x89HDF garbage")
    trial_file(folder, "X999", 1, 1, when, {"range_area_m2": 0.05, "range_area_ratio": 0.8})
    # and the weak virtual patient's, registered in the same data folder: it was read as a
    # healthy control (the 26th of 25 in a walkthrough)
    weak = trial_file(folder, "C002", 1, 3, when, {"range_area_m2": 0.02,
                                                   "range_area_ratio": 0.3},
                      backend="simulator (weak, seed 5)")
    trials, skipped = read_assessments(trial_files(folder))
    assert len(trials) == 13
    reasons = sorted(skipped.values())
    assert len(reasons) == 3
    assert reasons[0] == ("a simulated weak patient (simulator (weak, seed 5)), not a healthy "
                          "control")
    assert skipped[str(weak)] == reasons[0]
    assert reasons[1] == "not an assessment trial"
    assert reasons[2].startswith("not read: trial file")
    controls, left = controls_from_trials(trials, people_from_table(people_csv), FIGURES)
    assert left == {"X999": "no birth year, sex and handedness for this subject (registry or "
                            "people table)"}
    assert controls.subjects == tuple(f"C{i:03d}" for i in range(6))
    for i, code in enumerate(controls.subjects):
        metrics, side, age = truth[(code, 1)]
        assert controls.figures["range_area_m2"][i] == metrics["range_area_m2"]
        person = controls.people[i]
        assert (person.age_years, person.tested_side, person.robot) == (
            age, side, "simulator-realistic")
    retest, _ = retest_from_trials(trials, people_from_table(people_csv), FIGURES)
    second = retest.subjects.index("C002#2")
    assert retest.figures["range_area_ratio"][second] == truth[("C002", 2)][0][
        "range_area_ratio"]


def test_robot_kind():
    assert robot_kind(SIM, SUMMARY) == "simulator-realistic"
    assert robot_kind("simulator (weak, seed 3)", {"plant": "ideal"}) == "simulator-ideal"
    assert robot_kind("quanser (NI USB-6221)", {}) == "hardware"


pytestmark = pytest.mark.usefixtures("no_shipped_norms")  # only the norms each test uses


def test_fit_and_mdc_from_a_folder(tmp_path, data, capsys):
    folder, people_csv, _ = study(tmp_path, n=30)
    norms = tmp_path / "norms.json"
    code, out, err = run(["norms", "fit", "--trials", str(folder), "--people", str(people_csv),
                          "--source", "30 controls' files", "--output", str(norms)], capsys)
    assert code == 0, err
    assert "60 assessment trials of 30 people" in out
    model = load_norms(norms)
    assert set(model.figures) == {"range_area_m2", "range_area_ratio"}
    assert model.figures["range_area_m2"].regression.n == 30
    assert set(model.tasks) == {"range"}
    assert model.covariates.levels["robot"] == ("simulator-realistic",)
    with_mdc = tmp_path / "mdc.json"
    code, out, err = run(["norms", "mdc", "--trials", str(folder), "--people", str(people_csv),
                          "--norms", str(norms), "--output", str(with_mdc)], capsys)
    assert code == 0, err
    assert load_norms(with_mdc).figures["range_area_m2"].mdc95 > 0


def test_folder_refusals(tmp_path, data, capsys):
    folder, people_csv, _ = study(tmp_path, n=3)
    out = str(tmp_path / "n.json")
    code, _, err = run(["norms", "fit", "--trials", str(folder), "--source", "s", "--output",
                        out], capsys)
    assert code == 2
    assert "registry" in err
    code, _, err = run(["norms", "fit", "--trials", str(folder), "--people", str(people_csv),
                        "--source", "s", "--output", out], capsys)
    assert code == 2
    assert "nothing to fit" in err
    code, _, err = run(["norms", "fit", "--controls", str(people_csv), "--people",
                        str(people_csv), "--source", "s", "--output", out], capsys)
    assert code == 2
    assert "--people goes with --trials" in err
    empty = tmp_path / "empty"
    empty.mkdir()
    code, _, err = run(["norms", "fit", "--trials", str(empty), "--people", str(people_csv),
                        "--source", "s", "--output", out], capsys)
    assert code == 2
    assert "(0 trial file(s), none an assessment's)" in err
    bad = tmp_path / "bad.csv"
    shutil.copy(people_csv, bad)
    bad.write_text(bad.read_text().replace("female", "f", 1))
    code, _, err = run(["norms", "fit", "--trials", str(folder), "--people", str(bad),
                        "--source", "s", "--output", out], capsys)
    assert code == 2
    assert "line 2: sex" in err
    bad.write_text(people_csv.read_text().replace(",", ";"))
    code, _, err = run(["norms", "fit", "--trials", str(folder), "--people", str(bad),
                        "--source", "s", "--output", out], capsys)
    assert code == 2
    assert f"people table {bad}: its columns are separated by semicolons" in err
    code, _, err = run(["norms", "mdc", "--norms", out, "--output", str(tmp_path / "m.json")],
                       capsys)
    assert code == 2
    assert "one of them" in err


def test_covariates_from_the_registry_and_invalid_trials_left_out(tmp_path, data, registry,
                                                                   capsys):
    """Controls registered in a data folder: their sex, handedness and birth year come from
    the registry; a trial marked invalid there is not used, and the output says so."""
    rng = np.random.default_rng(8)
    ids, born = {}, {}
    for i in range(24):
        patient = registry.create_patient(f"C{i}", "Control", birth_year=1950 + i,
                                          side="right", sex=["female", "male"][i % 2],
                                          handedness="left" if i % 4 == 0 else "right")
        values = figures({"age_years": 76 - i, "sex": patient.sex}, rng.standard_normal(4),
                         rng)
        metrics = {k: values[k] for k in ("range_area_m2", "range_area_ratio")}
        when = datetime.datetime(2026, 3, 2, 9, i, tzinfo=datetime.UTC)
        params = THESIS_SUBJECT.replace(assessment="range")
        begun = registry.begin_trial(patient.code, params, backend=SIM, session_number=1,
                                     started_at=when)
        records = np.zeros(10, dtype=RECORD_DTYPE)
        records["tick"] = np.arange(10)
        records["time"] = np.arange(10) * PERIOD_S
        write_trial(begun.path, records, parameters=params,
                    subject=SubjectInfo.from_parameters(patient.code, params), robot={},
                    backend=SIM, sample_period_s=PERIOD_S, channels=CHANNELS,
                    summary=SUMMARY, metrics=metrics)
        registry.finish_trial(begun.trial_id, "complete", metrics)
        ids[patient.code] = begun.trial_id
        born[patient.code] = 1950 + i
    marked = sorted(ids)[0]  # codes are drawn: any one of the 24
    registry.mark_trial(ids[marked], valid=False, reason="patient distracted", by="test")
    norms = tmp_path / "norms.json"
    code, out, err = run(["norms", "fit", "--trials", str(data / "trials"), "--source",
                          "registered controls", "--output", str(norms)], capsys)
    assert code == 0, err
    assert "marked invalid: patient distracted" in out
    assert "23 assessment trials of 23 people" in out
    model = load_norms(norms)
    assert model.figures["range_area_m2"].regression.n == 23
    # the ages of the 23 whose trials were used, in the sessions' year
    used = [year for code, year in born.items() if code != marked]
    assert model.covariates.age_range == (2026 - max(used), 2026 - min(used))
