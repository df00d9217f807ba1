"""`rehab assess show`: each figure's Z-score and the task score against the data folder's
norms in use, for the registry's patient (age from the birth year and the session's date,
sex, handedness, the tested side, the trial file's robot), equal to the hand computation
from a hand-made norms file; the norms' source (and "simulated" when they are) in one
line; no norms, covariates the registry lacks and a damaged norms file each said in one
line (the last with exit 2)."""

from __future__ import annotations

import json
import math
import re
from statistics import NormalDist

import pytest

from tests.app.assessments.registered import WHEN, register
from tests.app.cli.running import run
from tests.app.norms.handmade import handmade

BORN = WHEN.year - 60
METRICS = {"vgr_reaction_time_s": 0.49, "vgr_max_speed_m_s": 0.3, "vgr_sparc": -1.6}
SOURCE = "Norms: hand-made for the tests, 3 Dec 2026"


pytestmark = pytest.mark.usefixtures("no_shipped_norms")  # only the norms each test uses


def _patient(registry, **fields) -> str:
    who = {"birth_year": BORN, "side": "left", "sex": "male", "handedness": "right", **fields}
    return registry.create_patient("Ann", "Example", **who).code


def _use(tmp_path, capsys, document) -> None:
    path = tmp_path / "norms.json"
    path.write_text(json.dumps(document))
    code, _, err = run(["norms", "use", str(path)], capsys)
    assert code == 0, err


def _hand_z(figure: dict, value: float, age: float) -> float:
    """Z of the hand-made file's figure for a male, right-handed person tested on the left
    on the simulator's realistic robot (every covariate but age at its column's value)."""
    t = figure["transform"]
    x = (value ** t["lambda"] - 1.0) / t["lambda"] if t["kind"] == "box-cox" else value
    c = figure["coefficients"]
    predicted = (c["intercept"] + c["age_years"] * age + c["sex=male"]
                 + c["tested_side=left"])
    return (x - predicted) / figure["residual_sd"]


def _half_normal_quantile(z: float) -> float:
    n = NormalDist()
    return n.inv_cdf((1.0 + n.cdf(z)) / 2.0)


def test_each_figure_s_z_and_the_task_score_are_the_hand_computation(tmp_path, registry, capsys):
    document = handmade()
    _use(tmp_path, capsys, document)
    code = _patient(registry)
    register(registry, code, METRICS)
    status, out, err = run(["assess", "show", code], capsys)
    assert status == 0, err
    figures = document["figures"]
    age = float(WHEN.year - BORN)
    z_rt = _hand_z(figures["vgr_reaction_time_s"], 0.49, age)
    z_speed = _hand_z(figures["vgr_max_speed_m_s"], 0.3, age)
    assert (round(z_rt, 2), round(z_speed, 2)) == (-2.7, -1.6)  # test_model's values
    assert re.search(rf"Reaction time: 0\.49 s +Z {z_rt:+.2f}\n", out), out
    assert re.search(rf"Max speed: 300 mm/s +Z {z_speed:+.2f}\n", out), out
    assert re.search(r"SPARC: -1\.60\n", out), out  # the norms hold no SPARC: no Z
    # the task score: each deviation one-sided (worse higher for the reaction time, lower
    # for the speed), their root-sum-square, Box-Cox, standardised, mapped half-normal
    task = document["tasks"]["reaching"]
    d = math.hypot(_half_normal_quantile(z_rt), _half_normal_quantile(-z_speed))
    lam = task["transform"]["lambda"]
    z_task = ((d ** lam - 1.0) / lam - task["mean"]) / task["sd"]
    assert f"Task score {_half_normal_quantile(z_task):.2f} (0 is best" in out
    assert out.count(SOURCE) == 1
    assert out.rstrip().endswith(SOURCE)


def test_simulated_norms_say_so(tmp_path, registry, capsys):
    document = handmade()
    document["simulated"] = True
    _use(tmp_path, capsys, document)
    code = _patient(registry)
    register(registry, code, METRICS)
    status, out, _ = run(["assess", "show", code], capsys)
    assert status == 0
    assert out.rstrip().splitlines()[-1] == (
        f"{SOURCE} (simulated — for demonstration and tests only)")


NO_Z_COLUMN = re.compile(r"(^|\s)Z\s", re.M)
"""A Z-score column's header (not a Z ending a random patient code, as in 'P1ZZJCZ ')."""


def test_without_norms_one_line_says_how_to_choose_some(registry, capsys):
    code = _patient(registry)
    register(registry, code, METRICS)
    status, out, _ = run(["assess", "show", code], capsys)
    assert status == 0
    assert not NO_Z_COLUMN.search(out)
    assert "Task score" not in out
    last = out.rstrip().splitlines()[-1]
    assert "No normative model in use" in last
    assert "rehab norms use FILE" in last
    assert out.count("normative model") == 1


def test_covariates_the_registry_lacks_are_named_in_one_line(tmp_path, registry, capsys):
    _use(tmp_path, capsys, handmade())
    code = _patient(registry, sex=None, handedness=None)
    register(registry, code, METRICS)
    register(registry, code, METRICS)
    status, out, _ = run(["assess", "show", code], capsys)
    assert status == 0
    assert not NO_Z_COLUMN.search(out)
    lacking = [line for line in out.splitlines() if "lacks" in line]
    assert len(lacking) == 1, out  # once, not per trial
    assert "the patient's sex, handedness" in lacking[0]
    assert "birth year" not in lacking[0]
    assert out.rstrip().endswith(SOURCE)


def test_a_damaged_norms_file_is_one_line_and_exit_2(tmp_path, data, registry, capsys):
    _use(tmp_path, capsys, handmade())
    code = _patient(registry)
    register(registry, code, METRICS)
    in_use_file = data / "models" / "norms" / "in-use.json"
    text = in_use_file.read_text()
    in_use_file.write_text(text[: len(text) // 2])  # cut off
    status, out, err = run(["assess", "show", code], capsys)
    assert status == 2
    assert len(err.strip().splitlines()) == 1, err
    assert f"norms file {in_use_file}" in err
    assert "Traceback" not in out + err


def test_an_age_beyond_the_controls_is_said_on_each_figure(tmp_path, registry, capsys):
    """A patient older than the norms' controls (80 at most) is scored by extrapolation,
    and each figure's line says so, as `rehab norms score` does."""
    _use(tmp_path, capsys, handmade())
    code = _patient(registry, birth_year=WHEN.year - 90)
    register(registry, code, METRICS)
    status, out, err = run(["assess", "show", code], capsys)
    assert status == 0, err
    assert re.search(r"Reaction time: 0\.49 s +Z [-+]\d\.\d\d \(age beyond the controls'\)\n",
                     out), out
    assert re.search(r"Max speed: 300 mm/s +Z [-+]\d\.\d\d \(age beyond the controls'\)\n",
                     out), out
    assert re.search(r"SPARC: -1\.60\n", out), out  # no Z-score, nothing beyond
    code = _patient(registry)  # 60: within the controls' ages
    register(registry, code, METRICS)
    status, out, err = run(["assess", "show", code], capsys)
    assert status == 0, err
    assert "beyond" not in out


def test_a_registry_without_the_side_scores_with_the_trial_file_s(tmp_path, registry, capsys):
    """The registry lacks the side, the trial's file says left: Z-scores with the left arm,
    not "the registry lacks the patient's tested side"."""
    _use(tmp_path, capsys, handmade())
    code = _patient(registry)  # left
    register(registry, code, METRICS)
    registry.correct_patient(code, "side", None, reason="unknown", by="TH")
    status, out, err = run(["assess", "show", code], capsys)
    assert status == 0, err
    assert "lacks" not in out, out
    assert "Reaction time: 0.49 s   Z -2.70\n" in out, out


def test_the_tested_side_is_the_trial_file_s_as_rehab_norms_score_takes_it(tmp_path, registry,
                                                                            capsys):
    """The registry's side corrected after the trial ran (left → right): the trial file
    keeps the arm that was tested, and `rehab assess show` scores with it, the Z-score
    `rehab norms score` gives the same file."""
    _use(tmp_path, capsys, handmade())
    code = _patient(registry)  # left
    begun = register(registry, code, METRICS)
    registry.correct_patient(code, "side", "right", reason="entered wrongly", by="TH")
    status, out, err = run(["assess", "show", code], capsys)
    assert status == 0, err
    status, scored, err = run(["norms", "score", str(begun.path), "--json"], capsys)
    assert status == 0, err
    result = json.loads(scored)
    assert result["person"]["tested_side"] == "left"
    z = result["figures"]["vgr_reaction_time_s"]["z"]
    assert f"Reaction time: 0.49 s   Z {z:+.2f}\n" in out, out
    assert round(z, 2) == -2.7  # the left arm's: test_each_figure_s_z_…'s hand computation
