"""`rehab norms show|fit|use|mdc` end to end, and every refusal in one line with exit 2."""

from __future__ import annotations

import json

import pytest

from app.norms import in_use, load_norms
from app.records.datadir import DataDir
from app.records.registry import Registry
from tests.app.cli.running import run
from tests.app.norms.controls import write_controls, write_retest
from tests.app.norms.handmade import handmade

pytestmark = pytest.mark.usefixtures("no_shipped_norms")  # only the norms each test uses


def test_fit_show_use_mdc(tmp_path, data, capsys):
    controls = write_controls(tmp_path / "controls.csv", n=200)
    norms = tmp_path / "norms.json"
    code, out, err = run(["norms", "fit", "--controls", str(controls), "--source",
                          "200 virtual controls, test, 3 Dec 2026", "--simulated",
                          "--output", str(norms)], capsys)
    assert code == 0, err
    assert "fitted norms on 200 controls: 4 figures, 1 task scores" in out
    assert "task:range" in out
    assert "5-fold cross-validation over 200 controls" in out
    assert "left out task:reaching: lacks" in out
    model = load_norms(norms)
    assert model.simulated
    assert set(model.tasks) == {"range"}
    held = model.calibration["held_out"]
    assert abs(held["vgr_max_speed_m_s"]["mean"]) < 0.3

    code, out, err = run(["norms", "show", str(norms)], capsys)
    assert code == 0, err
    assert "SIMULATED — for demonstration and tests only" in out
    assert "vgr_reaction_time_s" in out
    assert "calibration:" in out

    code, _, err = run(["norms", "show"], capsys)
    assert code == 2
    assert "uses no norms" in err
    code, out, err = run(["norms", "use", str(norms)], capsys)
    assert code == 0, err
    assert "simulated — for demonstration and tests only" in out
    code, out, err = run(["norms", "show"], capsys)
    assert code == 0
    assert "200 virtual controls" in out

    retest = write_retest(tmp_path / "retest.csv", n=40)
    with_mdc = tmp_path / "norms-mdc.json"
    code, out, err = run(["norms", "mdc", str(retest), "--norms", str(norms), "--output",
                          str(with_mdc)], capsys)
    assert code == 0, err
    assert "ICC(2,1)" in out
    assert "task:range" in out
    model = load_norms(with_mdc)
    assert all(f.mdc95 is not None and f.mdc95 > 0 for f in model.figures.values())
    assert model.tasks["range"].mdc95 > 0

    # using other norms keeps the ones before
    code, out, err = run(["norms", "use", str(with_mdc)], capsys)
    assert code == 0, err
    assert "kept as" in out
    kept = list((data / "models" / "norms").glob("replaced-*.json"))
    assert len(kept) == 1
    assert load_norms(kept[0]).content_sha256 == load_norms(
        norms).content_sha256


def _left_handers(path, *, n: int, left: int):
    """n controls (write_controls, seed 2) of whom the first `left` are left-handed and
    the others right-handed: a rare level of a covariate."""
    import csv

    controls = write_controls(path, n=n, seed=2)
    with controls.open() as f:
        header, *body = list(csv.reader(f))
    hand = header.index("handedness")
    for i, row in enumerate(body):
        row[hand] = "left" if i < left else "right"
    with controls.open("w", newline="") as f:
        csv.writer(f).writerows([header, *body])
    return controls


def _refused(capsys, args, words):
    code, out, err = run(args, capsys)
    assert code == 2, (out, err)
    assert words in err, err
    assert err.count("\n") == 1
    return err


def test_fit_refusals(tmp_path, data, capsys):
    controls = write_controls(tmp_path / "controls.csv", n=60)
    out = str(tmp_path / "n.json")
    base = ["norms", "fit", "--source", "s", "--output", out]
    _refused(capsys, [*base, "--controls", str(tmp_path / "none.csv")], "does not exist")
    _refused(capsys, [*base, "--controls", str(controls), "--folds", "1"], "--folds 1")
    bad = tmp_path / "bad.csv"
    bad.write_text(controls.read_text().replace("simulator-realistic", "", 1))
    _refused(capsys, [*base, "--controls", str(bad)], "line 2: robot")
    bad.write_text(controls.read_text().replace("range_area_m2", "range_area_cm2"))
    _refused(capsys, [*base, "--controls", str(bad)], "column 'range_area_cm2' is neither")
    # a misspelt figure gets the figure it is closest to, and where the keys are listed
    bad.write_text(controls.read_text().replace("vgr_reaction_time_s", "reaction_time_s"))
    _refused(capsys, [*base, "--controls", str(bad)], "did you mean 'vgr_reaction_time_s'? "
             "the figure keys: `rehab assess tasks`")
    # a spreadsheet's "CSV" with semicolons (or tabs) and decimal commas: refused as
    # lacking 'subject' before, the column it had first
    for separator, name in ((";", "semicolons"), ("\t", "tabs")):
        bad.write_text(controls.read_text().replace(".", ",").replace(",", separator))
        _refused(capsys, [*base, "--controls", str(bad)], f"its columns are separated by "
                 f"{name}, not commas; save it as CSV with commas (and '.' as the decimal "
                 "point)")
    lines = controls.read_text().splitlines()
    bad.write_text("\n".join([lines[0], lines[1].replace(",female,", ",f,").replace(
        ",male,", ",m,"), *lines[2:]]))
    _refused(capsys, [*base, "--controls", str(bad)], "line 2: sex")
    bad.write_text("\n".join([lines[0], lines[1], lines[1]]))
    _refused(capsys, [*base, "--controls", str(bad)], "appears twice")
    bad.write_text("\n".join(lines[:5]))
    _refused(capsys, [*base, "--controls", str(bad)], "nothing to fit")
    bad.write_text(lines[0].replace("age_years,", ""))
    _refused(capsys, [*base, "--controls", str(bad)], "the header lacks 'age_years'")
    bad.write_text(controls.read_text().replace(lines[3].split(",")[6], "fast", 1))
    _refused(capsys, [*base, "--controls", str(bad)], "'fast' is not a number")
    # values a figure cannot take by its definition: fitted as if measured before (an area
    # below 0 switched its transform to Yeo-Johnson; a share of 1.5)
    cells = lines[3].split(",")
    for column, value, span in (("range_area_m2", "-0.01", "at least 0"),
                                ("range_area_ratio", "1.5", "from 0 to 1")):
        row = list(cells)
        row[lines[0].split(",").index(column)] = value
        bad.write_text("\n".join([*lines[:3], ",".join(row), *lines[4:]]))
        err = _refused(capsys, [*base, "--controls", str(bad)],
                       f"line 4, {column}: '{value}' is not a value this figure can take "
                       f"({span}")
        assert not (tmp_path / "n.json").exists(), err
    _refused(capsys, ["norms", "fit", "--source", " ", "--output", out, "--controls",
                      str(controls)], "source is empty")
    _refused(capsys, [*base[:-1], str(tmp_path / "n.txt"), "--controls", str(controls)],
             "ending in .json")
    (tmp_path / "n.json").write_text("{}")
    _refused(capsys, [*base, "--controls", str(controls)], "exists")
    data.mkdir(parents=True, exist_ok=True)
    (data / "registry.sqlite3").write_text("")
    _refused(capsys, ["norms", "fit", "--source", "s", "--controls", str(controls),
                      "--output", str(data / "models" / "x.json")], "data folder")


def test_use_show_mdc_refusals(tmp_path, data, capsys):
    broken = tmp_path / "broken.json"
    document = handmade()
    document["figures"]["vgr_reaction_time_s"]["residual_sd"] = -1
    broken.write_text(json.dumps(document))
    _refused(capsys, ["norms", "use", str(broken)], "residual_sd")
    _refused(capsys, ["norms", "show", str(broken)], "residual_sd")
    _refused(capsys, ["norms", "show", str(tmp_path / "none.json")], "no such file")
    assert not (data / "models" / "norms" / "in-use.json").exists()

    good = tmp_path / "good.json"
    good.write_text(json.dumps(handmade()))
    few = write_retest(tmp_path / "few.csv", n=5)
    _refused(capsys, ["norms", "mdc", str(few), "--norms", str(good), "--output",
                      str(tmp_path / "m.json")], "fewer than 10")
    controls = write_controls(tmp_path / "controls.csv", n=30)
    _refused(capsys, ["norms", "mdc", str(controls), "--norms", str(good), "--output",
                      str(tmp_path / "m.json")], "lacks 'session'")
    _refused(capsys, ["norms", "bogus"], "invalid choice")

    # a damaged file in use is refused, never replaced by other norms in silence
    run(["norms", "use", str(good)], capsys)
    (data / "models" / "norms" / "in-use.json").write_text("{")
    _refused(capsys, ["norms", "show"], "is not a JSON norms file")


def test_a_lambda_at_its_bound_is_said(tmp_path, data, capsys):
    """A figure no power transform the search allows makes normal (here 30 − e^(1.2z), a
    long tail on the low side: λ = 2 is as far as the search goes,
    core.norms.transforms.lambda_range): the fit says so beside its calibration. A figure
    held at a bound its controls do not reject (a speed 0.3 ± 0.02 m/s, lower worse, held at
    λ = 0) is not noted: 25 virtual controls' fit printed 35 such notes of 39 figures (none now)."""
    import csv

    import numpy as np

    rng = np.random.default_rng(0)
    path = tmp_path / "c.csv"
    with path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["subject", "age_years", "sex", "handedness", "tested_side", "robot",
                         "vgr_movement_time_s", "vgr_max_speed_m_s"])
        for i in range(80):
            writer.writerow([f"C{i}", 40 + i % 30, ["female", "male"][i % 2], "right",
                             ["right", "left"][i % 3 == 0], "simulator-realistic",
                             float(30 - np.exp(1.2 * rng.standard_normal())),
                             float(0.3 + 0.02 * rng.standard_normal())])
    code, out, err = run(["norms", "fit", "--controls", str(path), "--source", "s", "--output",
                          str(tmp_path / "n.json")], capsys)
    assert code == 0, err
    assert ("note vgr_movement_time_s: its λ is held at the search's bound 2, which the "
            "controls reject (they would take ") in out
    assert "note vgr_max_speed_m_s" not in out
    speed = json.loads((tmp_path / "n.json").read_text())["figures"]["vgr_max_speed_m_s"]
    assert speed["transform"]["lambda"] == 0.0


def test_a_failed_use_leaves_the_norms_in_use(tmp_path, data, capsys, monkeypatch):
    """The norms in use are replaced in one atomic step: a write that fails (the disk full)
    leaves them in use, never a data folder without norms (which would score against the
    shipped simulated ones)."""
    from app.records import safewrite

    first = tmp_path / "first.json"
    first.write_text(json.dumps(handmade()))
    code, _, err = run(["norms", "use", str(first)], capsys)
    assert code == 0, err
    in_use_file = data / "models" / "norms" / "in-use.json"
    before = in_use_file.read_bytes()
    second = handmade()
    second["source"] = "other norms"
    other = tmp_path / "second.json"
    other.write_text(json.dumps(second))

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(safewrite, "write_text", full)
    code, _, err = run(["norms", "use", str(other)], capsys)
    assert code == 2
    assert "No space left" in err
    assert in_use_file.read_bytes() == before
    assert in_use.norms_in_use(type("D", (), {"models_dir": data / "models"})()).source == (
        "hand-made for the tests, 3 Dec 2026")


def test_what_is_not_a_file_is_refused_as_such(tmp_path, capsys):
    import os

    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    _refused(capsys, ["norms", "show", str(fifo)], "not a plain file")
    err = _refused(capsys, ["norms", "show", str(tmp_path)], "is a folder")
    assert err.rstrip().endswith("is a folder: give a file."), err  # said once, not twice


def test_a_rare_level_is_left_out_and_said(tmp_path, data, capsys):
    """3 left-handers among 60 controls cannot give the left-handers' coefficient: they are
    left out, said, and the norms refuse a left-handed patient instead of scoring them by
    three people."""
    controls = _left_handers(tmp_path / "controls.csv", n=60, left=3)
    norms = tmp_path / "n.json"
    code, out, err = run(["norms", "fit", "--controls", str(controls), "--source", "s",
                          "--output", str(norms)], capsys)
    assert code == 0, err
    assert "left out handedness=left: 3 controls with it, fewer than 5" in out
    model = load_norms(norms)
    assert model.covariates.levels["handedness"] == ("right",)
    assert model.figures["range_area_m2"].regression.n == 57
    from app.norms import Covariates, NormsError

    with pytest.raises(NormsError, match="handedness 'left'"):
        model.z("range_area_m2", 0.05, Covariates(50, "male", "left", "right",
                                                  "simulator-realistic"))


def _fitted_and_retest(tmp_path, capsys, controls):
    """Norms fitted on `controls` (a CSV) and 40 people's test-retest table beside them."""
    norms = tmp_path / "n.json"
    code, _, err = run(["norms", "fit", "--controls", str(controls), "--source", "s",
                        "--output", str(norms)], capsys)
    assert code == 0, err
    return norms, write_retest(tmp_path / "retest.csv", n=40)


def test_mdc_says_who_the_norms_could_not_score(tmp_path, data, capsys):
    """Norms without left-handers (3 of 60, left out of the fit) cannot score a
    left-hander's task: `rehab norms mdc` left them out of the task's MDC95 and said
    nothing (37 pairs printed, of 40 people). Their figures' MDC95s use them; the task's
    says who was left out and why, in one line."""
    import csv

    controls = _left_handers(tmp_path / "controls.csv", n=60, left=3)
    norms, retest = _fitted_and_retest(tmp_path, capsys, controls)
    with retest.open() as f:
        left = sorted({r["subject"] for r in csv.DictReader(f) if r["handedness"] == "left"})
    assert left
    code, out, err = run(["norms", "mdc", str(retest), "--norms", str(norms), "--output",
                          str(tmp_path / "mdc.json")], capsys)
    assert code == 0, err
    pairs = {line.split()[0]: int(line.split()[1]) for line in out.splitlines()
             if line.startswith(("range_", "task:range "))}
    assert pairs == {"range_area_m2": 40, "range_area_ratio": 40, "task:range": 40 - len(left)}
    said = [line for line in out.splitlines() if line.startswith("task:range: ")]
    assert len(said) == 1, out
    assert f"{len(left)} of 40 people left out: " in said[0]
    assert "handedness 'left'" in said[0]
    assert all(person in said[0] for person in left)


def test_mdc_with_no_reliability_says_so_and_its_sem_is_the_sd(tmp_path, data, capsys):
    """Each figure's second session ranked against the first (the best of session 1 the
    worst of session 2): every ICC(2,1) negative. `rehab norms mdc` prints the ICC as it
    is, marks it, and the SEM is the SD of the measurements, not SD·√(1 − ICC) above it.
    `rehab norms show` of the file says the same beside those MDC95s (it printed them as
    any other: the file's ICC was read and dropped)."""
    import csv
    import statistics

    from app.norms.model import NO_RELIABILITY, NO_RELIABILITY_SAID

    controls = write_controls(tmp_path / "controls.csv", n=200)
    norms, retest = _fitted_and_retest(tmp_path, capsys, controls)
    with retest.open() as f:
        rows = list(csv.DictReader(f))
    keys = ["vgr_reaction_time_s", "vgr_max_speed_m_s", "range_area_m2"]
    kept = "range_area_ratio"  # measured again as it was: its ICC above 0
    first = [r for r in rows if r["session"] == "1"]
    second = {r["subject"]: r for r in rows if r["session"] == "2"}
    for key in keys:
        ranked = sorted(first, key=lambda r: float(r[key]))
        values = sorted((second[r["subject"]][key] for r in ranked), key=float, reverse=True)
        for r, value in zip(ranked, values, strict=True):
            second[r["subject"]][key] = value
    with retest.open("w", newline="") as f:
        writer = csv.DictWriter(f, list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    code, out, err = run(["norms", "mdc", str(retest), "--norms", str(norms), "--output",
                          str(tmp_path / "mdc.json")], capsys)
    assert code == 0, err
    for key in keys:
        line = next(line for line in out.splitlines() if line.startswith(key + " "))
        _, pairs, icc, sem, _mdc, *note = line.split()
        assert int(pairs) == 40, line
        assert float(icc) < 0, line
        assert " ".join(note) == NO_RELIABILITY, line
        sd = statistics.stdev(float(r[key]) for r in rows)
        assert float(sem) == pytest.approx(sd, rel=1e-3), line
    assert out.count(NO_RELIABILITY_SAID) == 1  # what it means, once under the table
    code, out, err = run(["norms", "show", str(tmp_path / "mdc.json")], capsys)
    assert code == 0, err
    shown = {}  # each figure's first line: the figures' table (the calibration's follows)
    for line in out.splitlines():
        if line.strip():
            shown.setdefault(line.split()[0], line)
    for key in keys:
        assert shown[key].endswith(f"  {NO_RELIABILITY}"), shown[key]
        assert float(shown[key].split()[-len(NO_RELIABILITY.split()) - 1]) < 0, shown[key]
    assert float(shown[kept].split()[-1]) > 0, shown[kept]
    assert NO_RELIABILITY not in shown[kept]
    assert out.count(NO_RELIABILITY_SAID) == 1


def test_too_few_after_a_rare_level_says_the_level_first(tmp_path, data, capsys):
    """22 controls, 4 of them left-handed: the 4 are left out, 18 remain, and the refusal
    said only '18 controls have it, fewer than 20' of three figures, never why 18."""
    controls = _left_handers(tmp_path / "controls.csv", n=22, left=4)
    err = _refused(capsys, ["norms", "fit", "--controls", str(controls), "--source", "s",
                            "--output", str(tmp_path / "n.json")], "nothing to fit")
    assert ("nothing to fit (18 controls kept; handedness=left: 4 controls with it, fewer "
            "than 5") in err


def test_a_patient_at_zero_gets_a_z_score(tmp_path, data, capsys):
    """Every healthy control has some area; a patient who does not move has none. The
    fitted Box-Cox is shifted (1 % of the controls' median), so 0 scores as far beyond the
    controls as it is instead of being refused (a passive patient's circle speed of 0 was
    refused: 'outside the norms' Box-Cox domain')."""
    from app.norms import Covariates

    controls = write_controls(tmp_path / "controls.csv", n=120)
    norms = tmp_path / "n.json"
    code, _, err = run(["norms", "fit", "--controls", str(controls), "--source", "s",
                        "--output", str(norms)], capsys)
    assert code == 0, err
    model = load_norms(norms)
    transform = model.figures["range_area_m2"].transform
    assert transform.kind == "box-cox"
    assert transform.shift > 0
    who = Covariates(50, "male", "right", "right", "simulator-realistic")
    z = model.z("range_area_m2", 0.0, who)
    assert z.worse_z > 3
    assert model.task_score("range", {"range_area_m2": 0.0, "range_area_ratio": 0.0},
                            who).score > 3


def test_fit_from_trials_says_why_no_assessment_could_be_used(tmp_path, data, patient,
                                                             capsys):
    """A folder whose assessments are all a simulated weak patient's said 'no assessment
    trials found', as if it held none, and the reasons were never printed."""
    code, _, err = run(["assess", "run", patient, "--task", "range", "--patient", "weak"],
                       capsys)
    assert code == 0, err
    code, _, err = run(["run", "--code", patient, "--repetitions", "1", "--seed", "1"], capsys)
    assert code == 0, err
    base = ["norms", "fit", "--source", "s", "--output", str(tmp_path / "n.json")]
    err = _refused(capsys, [*base, "--trials", str(data / "trials")],
                   "no assessment trial below")
    assert "can be used: 1 left out, e.g. " in err
    assert "a simulated weak patient" in err
    assert "not a healthy control" in err
    empty = tmp_path / "empty"
    empty.mkdir()
    _refused(capsys, [*base, "--trials", str(empty)],
             f"no assessment trial below {empty} (0 trial file(s), none an assessment's)")


def test_score_takes_a_registered_trials_id_as_rehab_pose_does(data, patient, tmp_path,
                                                               capsys):
    """`rehab norms score 11` read a file named '11' and said it did not exist."""
    code, _, err = run(["assess", "run", patient, "--task", "reaching"], capsys)
    assert code == 0, err
    (trial,) = Registry(DataDir(data)).trials_for_patient(patient)
    norms = tmp_path / "norms.json"
    norms.write_text(json.dumps(handmade()))
    person = ["--norms", str(norms), "--birth-year", "1960", "--sex", "female",
              "--handedness", "right"]
    code, by_id, err = run(["norms", "score", str(trial.id), *person], capsys)
    assert code == 0, err
    path = Registry(DataDir(data)).trial_path(trial)
    code, by_path, err = run(["norms", "score", str(path), *person], capsys)
    assert code == 0, err
    assert by_id == by_path
    _refused(capsys, ["norms", "score", "99", *person], "no trial has the id 99")
