"""`rehab models`: a model travels to another installation by export and import, checked
and signed there (issue 28 #11); a file edited on the way cannot pass for the console's."""

from __future__ import annotations

import json

import numpy as np

from app.learning.modelfile import content_hash, write_model
from core.learning import networks as nw
from tests.app.cli.running import run

ROBOT_DATA = {"system": "rehab-robot-simulator", "dof": 2}
SPEC = {"kind": "fnn", "dof": 2, "hidden": [3], "position_inputs": [0, 1],
        "input_mean": [0.0] * 6, "input_std": [1.0] * 6, "output_mean": [0.0] * 2,
        "output_std": [1.0] * 2}


def installation(monkeypatch, folder):
    """Use the console installed in `folder`: its data folder and its config (its key)."""
    monkeypatch.setenv("REHAB_DATA_DIR", str(folder / "data"))
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(folder / "config"))
    models = folder / "data" / "models"
    models.mkdir(parents=True, exist_ok=True)
    return models


def trained(models, name="fnn-robot"):
    params = {k: np.random.default_rng(0).normal(size=s)
              for k, s in nw.param_shapes(SPEC).items()}
    return write_model(models / f"{name}.json", name, SPEC, params, ROBOT_DATA, {}, {})


def test_a_model_travels_by_export_and_import(tmp_path, monkeypatch, capsys):
    here = installation(monkeypatch, tmp_path / "here")
    original = trained(here)
    code, out, _ = run(["models", "list"], capsys)
    assert code == 0
    assert "fnn-robot" in out
    assert "usable" in out
    exported = tmp_path / "fnn-robot.json"
    code, out, _ = run(["models", "export", "fnn-robot", "--output", str(exported)], capsys)
    assert code == 0
    assert "signature" not in json.loads(exported.read_text())

    there = installation(monkeypatch, tmp_path / "there")
    (there / "copied.json").write_text(original.read_text())  # copied by hand: not trusted
    code, out, _ = run(["models", "list"], capsys)
    assert "refused: signature" in out
    code, out, err = run(["models", "import", str(exported), "--name", "mine"], capsys)
    assert code == 0, err
    imported = json.loads((there / "mine.json").read_text())
    assert imported["content_sha256"] == json.loads(original.read_text())["content_sha256"]
    code, out, _ = run(["models", "list"], capsys)
    assert "mine" in out
    assert out.count("usable") == 1
    code, _, err = run(["models", "import", str(exported), "--name", "mine"], capsys)
    assert code == 2
    assert "already exists" in err
    assert err.count("\n") == 1


def test_import_refuses_what_the_console_would_not_run(tmp_path, monkeypatch, capsys):
    models = installation(monkeypatch, tmp_path / "here")
    path = trained(models)
    document = json.loads(path.read_text())
    damaged = tmp_path / "damaged.json"
    edit = json.loads(json.dumps(document))
    edit["weights"]["net.0.b"]["values"][0] = 2.0  # its hash no longer matches
    damaged.write_text(json.dumps(edit))
    huge = tmp_path / "huge.json"
    edit["weights"]["net.0.b"]["values"][0] = 1e308
    edit["content_sha256"] = content_hash(edit)
    huge.write_text(json.dumps(edit))
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 200_000 + "]" * 200_000)
    for file, expected in ((damaged, "content hash"), (huge, "weights"), (deep, "format"),
                           (tmp_path / "none.json", "none.json does not exist; check the"),
                           (tmp_path, "is not a file")):
        code, _, err = run(["models", "import", str(file)], capsys)
        assert code == 2, file
        assert expected in err
        assert err.count("\n") == 1
    assert sorted(p.name for p in models.iterdir()) == ["fnn-robot.json"]


def test_evaluate_refuses_a_model_with_a_weight_of_1e308(tmp_path, monkeypatch, capsys):
    """It printed RMSE inf with exit 0: a model edited to 1e308 and its hash recomputed."""
    models = installation(monkeypatch, tmp_path / "here")
    assert run(["learn", "pendulum", "--output", str(tmp_path / "p.h5"), "--speeds", "1", "2",
                "3"], capsys)[0] == 0
    path = tmp_path / "pendulum-fnn.json"
    spec = {**SPEC, "position_inputs": [1]}
    spec["input_mean"], spec["input_std"] = [0.0] * 5, [1.0] * 5
    params = {k: np.zeros(s) for k, s in nw.param_shapes(spec).items()}
    write_model(path, "p", spec, params, {"system": "sliding-inverted-pendulum", "dof": 2},
                {}, {})
    document = json.loads(path.read_text())
    document["weights"]["net.0.b"]["values"][0] = 1e308
    document["content_sha256"] = content_hash(document)
    path.write_text(json.dumps(document))
    code, out, err = run(["learn", "evaluate", "--model", str(path), "--data",
                          str(tmp_path / "p.h5")], capsys)
    assert code == 2
    assert "inf" not in out
    assert err.count("\n") == 1
    del models


def test_list_refuses_a_model_that_is_not_of_the_robot_as_a_trial_would(tmp_path, monkeypatch,
                                                                        capsys):
    """A pendulum's DeLaN imported into models/ was listed 'usable', while `rehab run
    --learned-model` and the Parameters tab refuse it: list now checks what they check."""
    models = installation(monkeypatch, tmp_path / "here")
    params = {k: np.random.default_rng(0).normal(size=s)
              for k, s in nw.param_shapes(SPEC).items()}
    write_model(models / "pendulum.json", "pendulum", SPEC, params,
                {"system": "sliding-inverted-pendulum", "dof": 2}, {}, {})
    trained(models)
    code, out, _ = run(["models", "list"], capsys)
    assert code == 0
    lines = dict(line.split(None, 2)[1:] for line in out.splitlines())
    assert lines["fnn-robot"] == "usable on the simulator"
    assert lines["pendulum"] == ("refused: system (the model was trained on "
                                 "'sliding-inverted-pendulum', not on the robot)")
    code, _, err = run(["run", "--learned-model", "pendulum", "--repetitions", "1",
                        "--output", str(tmp_path / "t.h5")], capsys)
    assert code == 2
    assert "not on the robot" in err


def test_list_says_which_robot_a_model_may_drive(tmp_path, monkeypatch, capsys):
    """Robots are told apart by their settings' name: a model of one robot's trials drives
    that robot (and the simulator), never another."""
    models = installation(monkeypatch, tmp_path / "here")
    params = {k: np.random.default_rng(0).normal(size=s)
              for k, s in nw.param_shapes(SPEC).items()}
    write_model(models / "lab-2.json", "lab-2", SPEC, params,
                {"system": "rehab-robot-quanser:Lab robot #2", "dof": 2}, {}, {})
    code, out, _ = run(["models", "list"], capsys)
    assert code == 0
    lines = dict(line.split(None, 2)[1:] for line in out.splitlines())
    assert lines["lab-2"] == "usable on the simulator and on robot Lab robot #2"
