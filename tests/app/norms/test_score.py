"""`rehab norms score`: an assessment trial file's Z-scores and task score against a norms
file, equal to the hand computation of tests/app/norms/test_model.py, for a person given on
the command line or found in the registry."""

from __future__ import annotations

import datetime
import json
import math
from statistics import NormalDist

import pytest

from tests.app.cli.running import run
from tests.app.norms.handmade import handmade
from tests.app.norms.test_controls import trial_file

N = NormalDist()
WHEN = datetime.datetime.now(datetime.UTC)
BORN = WHEN.year - 60  # 60 in the trial's year, as test_model's person


def half_normal_quantile(z: float) -> float:
    return N.inv_cdf((1.0 + N.cdf(z)) / 2.0)


pytestmark = pytest.mark.usefixtures("no_shipped_norms")  # only the norms each test uses


@pytest.fixture
def files(tmp_path):
    norms = tmp_path / "norms.json"
    norms.write_text(json.dumps(handmade()))
    trial = trial_file(tmp_path / "t", "SIM", 1, 1, WHEN, {
        "vgr_reaction_time_s": 0.49, "vgr_max_speed_m_s": 0.3, "rmse_m": 0.01},
        task="reaching", side="left")
    return norms, trial


def test_score_by_hand(files, data, capsys):
    norms, trial = files
    code, out, err = run(["norms", "score", str(trial), "--norms", str(norms), "--birth-year",
                          str(BORN), "--sex", "male", "--handedness", "right", "--json"],
                         capsys)
    assert code == 0, err
    result = json.loads(out)
    assert result["person"] == {"age_years": 60.0, "sex": "male", "handedness": "right",
                                "tested_side": "left", "robot": "simulator-realistic"}
    assert result["figures"]["vgr_reaction_time_s"]["z"] == pytest.approx(-2.7)
    assert result["figures"]["vgr_max_speed_m_s"]["worse_z"] == pytest.approx(1.6)
    d = math.hypot(half_normal_quantile(-2.7), half_normal_quantile(1.6))
    z_task = ((math.sqrt(d) - 1.0) / 0.5 - 1.0) / 0.4
    assert result["task_score"]["score"] == pytest.approx(half_normal_quantile(z_task))
    assert result["norms"] == "Norms: hand-made for the tests, 3 Dec 2026"
    code, out, err = run(["norms", "score", str(trial), "--norms", str(norms), "--birth-year",
                          str(BORN), "--sex", "male", "--handedness", "right"], capsys)
    assert code == 0, err
    assert "vgr_reaction_time_s" in out
    assert "task score reaching:" in out
    assert out.rstrip().endswith("Norms: hand-made for the tests, 3 Dec 2026")


def test_score_refusals(tmp_path, files, data, capsys):
    norms, trial = files
    exercise = trial_file(tmp_path / "e", "SIM", 1, 2, WHEN, {"rmse_m": 0.01}, task="")
    person = ["--birth-year", str(BORN), "--sex", "male", "--handedness", "right"]
    for args, words in [
        ([str(exercise), "--norms", str(norms), *person], "is not an assessment trial"),
        ([str(trial), "--norms", str(norms), "--sex", "male"], "together"),
        ([str(trial), *person], "uses no norms"),
        ([str(trial), "--norms", str(norms)], "its subject 'SIM' is no registered patient"),
        # not an assessment, said first: the registry's covariates were asked for before
        ([str(exercise), "--norms", str(norms)], "is not an assessment trial"),
        ([str(tmp_path / "none.h5"), "--norms", str(norms), *person], "none.h5"),
    ]:
        code, out, err = run(["norms", "score", *args], capsys)
        assert code == 2, (args, out, err)
        assert words in err
        assert err.count("\n") == 1


def test_the_person_from_the_registry(tmp_path, files, registry, capsys):
    norms, _ = files
    patient = registry.create_patient("Ann", "Example", birth_year=BORN, side="left",
                                      sex="male", handedness="right")
    trial = trial_file(tmp_path / "r", patient.code, 1, 1, WHEN, {
        "vgr_reaction_time_s": 0.49, "vgr_max_speed_m_s": 0.3}, task="reaching", side="left")
    code, out, err = run(["norms", "score", str(trial), "--norms", str(norms), "--json"],
                         capsys)
    assert code == 0, err
    assert json.loads(out)["figures"]["vgr_reaction_time_s"]["z"] == pytest.approx(-2.7)
    unknown = registry.create_patient("Bo", "Example", birth_year=BORN)  # no sex, handedness
    trial = trial_file(tmp_path / "u", unknown.code, 1, 1, WHEN, {"vgr_reaction_time_s": 0.5},
                       task="reaching")
    code, _, err = run(["norms", "score", str(trial), "--norms", str(norms)], capsys)
    assert code == 2
    assert "has no birth year, sex and handedness in the registry" in err
    assert f"`rehab correct {unknown.code} birth_year YEAR" in err  # a command that exists


def test_one_figure_beyond_the_norms_leaves_the_others_scored(tmp_path, files, data, capsys):
    norms, _ = files
    trial = trial_file(tmp_path / "b", "SIM", 1, 1, WHEN, {
        "vgr_reaction_time_s": -0.1, "vgr_max_speed_m_s": 0.3}, task="reaching", side="left")
    code, out, err = run(["norms", "score", str(trial), "--norms", str(norms), "--birth-year",
                          str(BORN), "--sex", "male", "--handedness", "right", "--json"],
                         capsys)
    assert code == 0, err
    result = json.loads(out)
    assert result["figures"]["vgr_max_speed_m_s"]["worse_z"] == pytest.approx(1.6)
    assert "Box-Cox domain" in result["unscored"]["vgr_reaction_time_s"]
    assert result["task_score"] is None


def test_norms_of_another_robot_refuse_the_person_in_one_line(tmp_path, files, data, capsys):
    """A person the norms hold no controls like (another robot) is refused once, exit 2,
    not once per figure with exit 0 (docs/norms.md: refused in one line)."""
    _, trial = files
    other = handmade()
    other["covariates"]["robot"] = ["hardware"]
    path = tmp_path / "hardware.json"
    path.write_text(json.dumps(other))
    code, out, err = run(["norms", "score", str(trial), "--norms", str(path), "--birth-year",
                          str(BORN), "--sex", "male", "--handedness", "right"], capsys)
    assert code == 2, out
    assert "hold no healthy people with robot 'simulator-realistic'" in err
    assert err.count("\n") == 1
    assert out == ""


def test_a_task_score_beyond_the_bound_prints_as_one(files, data, capsys, monkeypatch):
    """`rehab norms score` prints a task score beyond Z_SHOWN as "> 10" (its number stays
    in --json), as the reports do."""
    from app.norms import model

    norms, trial = files
    monkeypatch.setattr(model.scores, "task_score", lambda z: 13184793.06)
    args = ["norms", "score", str(trial), "--norms", str(norms), "--birth-year", str(BORN),
            "--sex", "male", "--handedness", "right"]
    code, out, err = run(args, capsys)
    assert code == 0, err
    assert "task score reaching: > 10 (0 best" in out
    code, out, err = run([*args, "--json"], capsys)
    assert json.loads(out)["task_score"]["score"] == pytest.approx(13184793.06)
