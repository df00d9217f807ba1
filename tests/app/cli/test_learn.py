"""`rehab learn` as a researcher types it: make the pendulum's data, train each model,
evaluate it (text and JSON), and bad input as one line with exit code 2."""

import json
import re
import subprocess
import sys

import h5py
import numpy as np
import pytest

from app.cli.main import main
from tests.app.cli.running import run

SPEEDS = ["1", "2", "3", "4", "5", "6", "7", "8"]



@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("learn")
    assert main(["learn", "pendulum", "--output", str(folder / "p.h5"), "--speeds", *SPEEDS,
                 "--held-out", "5"]) == 0
    return folder


@pytest.fixture(scope="module")
def trained(files):
    """One tiny model of each kind, trained from the command line."""
    paths = {}
    for kind in ("fnn", "rnn", "delan"):
        paths[kind] = files / f"{kind}.json"
        assert main(["learn", "train", "--model", kind, "--data", str(files / "p.h5"),
                     "--output", str(paths[kind]), "--epochs", "4", "--folds", "2",
                     "--hidden", "6"]) == 0
    return paths


def test_pendulum_writes_the_thesis_data_set(tmp_path, capsys):
    code, out, _ = run(["learn", "pendulum", "--output", str(tmp_path / "p.h5")], capsys)
    assert code == 0
    assert "101,000 samples, 1,000 cycles, cycle at 5 rad/s held out" in out
    with h5py.File(tmp_path / "p.h5") as f:
        assert f["q"].shape == (101_000, 2)
        assert f.attrs["system"] == "sliding-inverted-pendulum"


@pytest.mark.parametrize("kind", ["fnn", "rnn", "delan"])
def test_train_then_evaluate(files, trained, kind, capsys):
    document = json.loads(trained[kind].read_text())
    assert document["model"]["kind"] == kind
    assert document["data"]["samples"] == 707  # 7 cycles, the 5 rad/s one held out
    assert document["data"]["held_out_cycles"] == [4]
    assert document["hyper_parameters"]["folds"] == 2
    assert len(document["metrics"]["folds"]) == 2
    code, out, _ = run(["learn", "evaluate", "--model", str(trained[kind]),
                        "--data", str(files / "p.h5")], capsys)
    assert code == 0
    # units on every figure, one cycle said so ('1 cycles', RMSEs without a unit before)
    assert "101 samples, 1 held-out cycle; " in out
    assert re.search(r"RMSE f    [0-9.e+-]+ N\n", out), out
    assert re.search(r"RMSE tau  [0-9.e+-]+ N·m\n", out), out
    code, out, _ = run(["learn", "evaluate", "--model", str(trained[kind]),
                        "--data", str(files / "p.h5"), "--json"], capsys)
    result = json.loads(out)
    assert set(result) == {"rmse", "units", "parameters"}
    assert set(result["rmse"]) == {"f", "tau"}
    assert result["units"] == {"f": "N", "tau": "N·m"}
    assert result["parameters"] == document["parameters"]
    assert all(np.isfinite(v) and v > 0 for v in result["rmse"].values())


def test_evaluate_computes_the_rmse(files, trained, capsys):
    """The printed RMSE is the model's error on the held-out cycle, recomputed here."""
    from app.learning.dataset import read_dataset
    from app.learning.modelfile import read_model
    from core.learning.inference import predict

    data, model = read_dataset(files / "p.h5"), read_model(trained["fnn"])
    rows = data.cycle == 4
    pred = predict(model.spec, model.params, data.q[rows], data.qd[rows], data.qdd[rows])
    expected = np.sqrt(np.mean((pred - data.tau[rows]) ** 2, axis=0))
    _, out, _ = run(["learn", "evaluate", "--model", str(trained["fnn"]), "--data",
                     str(files / "p.h5"), "--json"], capsys)
    np.testing.assert_allclose([json.loads(out)["rmse"][k] for k in ("f", "tau")], expected,
                               rtol=1e-12)
    _, out, _ = run(["learn", "evaluate", "--model", str(trained["fnn"]), "--data",
                     str(files / "p.h5"), "--all-cycles"], capsys)
    assert "808 samples, 8 cycles, the whole file; " in out


def test_evaluate_a_researchers_file_by_its_force_names(files, trained, tmp_path, capsys):
    with h5py.File(files / "p.h5") as src, h5py.File(tmp_path / "own.h5", "w") as f:
        for name in ("q", "qd", "qdd", "tau", "cycle"):
            f[name] = src[name][:202]
        f.attrs["system"] = "sliding-inverted-pendulum"
        f.attrs["forces"] = '["push", "torque"]'
    code, out, _ = run(["learn", "evaluate", "--model", str(trained["delan"]), "--data",
                        str(tmp_path / "own.h5"), "--json"], capsys)
    assert code == 0
    assert set(json.loads(out)["rmse"]) == {"push", "torque"}
    # the pendulum's units by position, whatever the forces' names
    assert json.loads(out)["units"] == {"push": "N", "torque": "N·m"}
    # the same samples as a system the console has no model of: SI, N or N·m unknown
    with h5py.File(tmp_path / "own.h5", "r+") as f:
        f.attrs["system"] = "a-lab-arm"
    from app.learning.dataset import read_dataset
    from app.learning.workflow import force_units

    assert force_units(read_dataset(tmp_path / "own.h5")) == {"push": "SI", "torque": "SI"}


def test_bad_input_is_one_line_and_exit_2(files, trained, tmp_path, capsys):
    p = str(files / "p.h5")
    cases = [
        (["learn", "train", "--model", "svm", "--data", p, "--output", "m.json"],
         "invalid choice: 'svm'"),
        (["learn", "train", "--model", "fnn", "--data", str(tmp_path / "none.h5"),
          "--output", str(tmp_path / "m.json")], "no such file"),
        (["learn", "train", "--model", "fnn", "--data", p, "--output",
          str(tmp_path / "m.json"), "--epochs", "0"], "must be 1 or more"),
        (["learn", "train", "--model", "fnn", "--data", p, "--output",
          str(tmp_path / "m.json"), "--folds", "9"], "has 7 training cycles; 9-fold"),
        (["learn", "train", "--model", "fnn", "--data", p, "--output",
          str(tmp_path / "m.json"), "--cyclic", "y9"], "has no coordinate y9"),
        (["learn", "train", "--model", "fnn", "--data", p, "--output",
          str(tmp_path / "m.json"), "--cyclic", "x1", "theta2"], "at least one must remain"),
        (["learn", "train", "--model", "fnn", "--data", p, "--output",
          str(tmp_path / "m.json"), "--hidden", "8,x"], "is not sizes such as 16,16"),
        (["learn", "train", "--model", "fnn", "--data", p, "--output",
          str(tmp_path / "m.json"), "--learning-rate", "-1"], "must be a finite number > 0"),
        # accepted before: 1e9 saved a diverged model (cross-validation RMSE 1e8), 1e8
        # epochs would have trained for years, a mass scale a network has none of was
        # dropped without a word
        (["learn", "train", "--model", "fnn", "--data", p, "--output",
          str(tmp_path / "m.json"), "--learning-rate", "1e9"],
         "--learning-rate 1e+09: give at most 1"),
        (["learn", "train", "--model", "fnn", "--data", p, "--output",
          str(tmp_path / "m.json"), "--epochs", "100000000"],
         "--epochs 100000000: give at most 10,000"),
        (["learn", "train", "--model", "fnn", "--data", p, "--output",
          str(tmp_path / "m.json"), "--mass-scale", "0.5"],
         "--mass-scale is the DeLaN's (its mass matrix's unit); a fnn has none"),
        (["learn", "train", "--model", "delan", "--data", p, "--output",
          str(tmp_path / "m.json"), "--mass-scale", "1e9"], "--mass-scale 1e+09: give 0.001"),
        (["learn", "evaluate", "--model", str(tmp_path / "none.json"), "--data", p],
         "missing: no such file"),
        (["learn", "evaluate", "--model", p, "--data", p], "is not a JSON model file"),
        (["learn", "pendulum", "--output", str(tmp_path / "x.h5"), "--speeds", "1", "2",
          "--held-out", "5"], "--held-out 5 is none of --speeds"),
        (["learn", "pendulum", "--output", str(tmp_path / "x.h5"), "--speeds", "0"],
         "must be a finite number > 0"),
        (["learn", "pendulum", "--output", str(tmp_path / "no" / "x.h5")], "does not exist"),
        # a speed no pendulum on a track is driven at: the base would slide faster than a
        # bullet (fast) or run away under the friction's push (slow)
        (["learn", "pendulum", "--output", str(tmp_path / "x.h5"), "--speeds", "2", "1e9"],
         "--speeds 1e+09: at 1e+09 rad/s the base would slide at 1.31e+08 m/s"),
        (["learn", "pendulum", "--output", str(tmp_path / "x.h5"), "--speeds", "0.01"],
         "give speeds from 0.47 to 76.7 rad/s"),
        (["learn", "pendulum", "--output", str(tmp_path / "x.h5"), "--speeds", "1e200"],
         "more m/s than a number holds"),
        # held out of the thesis's speeds, it must be one of them: no cycle was held out
        # while the line said one was
        (["learn", "pendulum", "--output", str(tmp_path / "x.h5"), "--held-out", "5.5"],
         "--held-out 5.5 is none of the thesis's speeds"),
    ]
    for args, message in cases:
        code, _, err = run(args, capsys)
        assert code == 2, args
        assert message in err, (args, err)
        assert len(err.strip().splitlines()) == 1, err
        assert "Traceback" not in err


def test_a_corrupt_or_foreign_model_is_refused_by_name(files, trained, tmp_path, capsys):
    text = trained["fnn"].read_text().replace('"epochs": 4', '"epochs": 5')
    (tmp_path / "edited.json").write_text(text)
    code, _, err = run(["learn", "evaluate", "--model", str(tmp_path / "edited.json"),
                        "--data", str(files / "p.h5")], capsys)
    assert code == 2
    assert "content hash" in err
    with h5py.File(files / "p.h5") as src, h5py.File(tmp_path / "robot.h5", "w") as f:
        for name in ("q", "qd", "qdd", "tau", "cycle"):
            f[name] = src[name][:101]
        f.attrs["system"] = "rehab-robot"
    code, _, err = run(["learn", "evaluate", "--model", str(trained["fnn"]),
                        "--data", str(tmp_path / "robot.h5")], capsys)
    assert code == 2
    assert "system: the model was trained on 'sliding-inverted-pendulum'" in err


def test_console_starts_without_jax():
    """The CLI, the window's modules and the loop import no JAX (import contract in
    pyproject.toml); only `rehab learn train` loads it, when it runs."""
    code = ("import sys, app.cli.main, app.cli.learn, app.learning.workflow, "
            "app.learning.modelfile, app.learning.library, app.learning.closedloop, "
            "core.learning.inference, core.learning.kernel, ui.launcher, ui.main_window, "
            "device.loop.process, core.control; "
            "bad = sorted(m for m in sys.modules if m.split('.')[0] in ('jax', 'jaxlib', "
            "'optax')); print(bad); sys.exit(1 if bad else 0)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            env={"QT_QPA_PLATFORM": "offscreen", "PATH": "/usr/bin:/bin"},
                            check=False)
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.fixture(scope="module")
def trials(tmp_path_factory):
    folder = tmp_path_factory.mktemp("trials")
    for shape in ("d", "circle"):
        assert main(["run", "--patient", "weak", "--trajectory", shape, "--repetitions", "1",
                     "--output", str(folder / f"{shape}.h5")]) == 0
    return folder


def test_robot_data_from_recorded_trials(trials, tmp_path, capsys):
    """The exercise's samples of each trial, one cycle each; the torque applied, or with
    the hand force's share J_Rᵀ F (eq. 3.34) taken out."""
    from app.learning.dataset import read_dataset
    from app.trials.reader import read_trial
    from core.robot import RobotModel

    paths = [str(trials / "d.h5"), str(trials / "circle.h5")]
    code, out, _ = run(["learn", "robot-data", "--trials", *paths, "--output",
                        str(tmp_path / "r.h5")], capsys)
    assert code == 0
    assert "2 trials, system rehab-robot-simulator" in out
    code, out, _ = run(["learn", "robot-data", "--trials", paths[0], "--output",
                        str(tmp_path / "one.h5")], capsys)
    assert "1 trial, system" in out  # not '1 trials'
    from app.learning.workflow import force_units

    assert set(force_units(read_dataset(tmp_path / "one.h5")).values()) == {"N·m"}
    assert run(["learn", "robot-data", "--trials", *paths, "--output", str(tmp_path / "w.h5"),
                "--without-hand-force"], capsys)[0] == 0
    assert run(["learn", "robot-data", "--trials", *paths, "--output", str(tmp_path / "t.h5"),
                "--acceleration", "desired"], capsys)[0] == 0
    data, clean = read_dataset(tmp_path / "r.h5"), read_dataset(tmp_path / "w.h5")
    thesis = read_dataset(tmp_path / "t.h5")
    trial = read_trial(paths[0]).channels
    rows = trial["phase"] == 2
    first = data.cycle == 0
    assert first.sum() == rows.sum()
    np.testing.assert_array_equal(data.tau[first], trial["torque_applied"][rows])
    # the loop's estimates by default: the README's `robot-data` then `train` made a model
    # of the reference's accelerations, which tracked 19 / 60 mm in the loop (analytic 7 / 4)
    np.testing.assert_array_equal(data.qdd[first], trial["robot_acceleration"][rows])
    np.testing.assert_array_equal(clean.qdd[first], trial["robot_acceleration"][rows])
    np.testing.assert_array_equal(thesis.qdd[first], trial["robot_acceleration_desired"][rows])
    assert data.description["acceleration"] == "estimated"
    q, F = trial["robot_angle"][rows], trial["force"][rows]
    jtf = np.stack(RobotModel().joint_torque_terms(q[:, 0], q[:, 1], F[:, 0], F[:, 1]), -1)
    np.testing.assert_allclose(clean.tau[first] - data.tau[first], jtf, rtol=1e-12, atol=1e-12)
    assert np.abs(jtf).max() > 0.05  # the weak patient's push is in the torque
    assert data.forces == ("tau_R1", "tau_R2")


def test_robot_data_refuses_a_missing_trial(tmp_path, capsys):
    code, _, err = run(["learn", "robot-data", "--trials", str(tmp_path / "none.h5"),
                        "--output", str(tmp_path / "r.h5")], capsys)
    assert code == 2
    assert "none.h5" in err


def test_robot_data_does_not_name_simulated_trials_as_the_robot(trials, tmp_path, capsys):
    """The real robot's Build refuses a model not of its own trials by the data's system
    name: simulated trials cannot be given the robot's ('rehab-robot-quanser')."""
    paths = [str(trials / "d.h5")]
    code, _, err = run(["learn", "robot-data", "--trials", *paths, "--output",
                        str(tmp_path / "r.h5"), "--system", "rehab-robot-quanser"], capsys)
    assert code == 2
    assert "'rehab-robot-quanser' is not what these trials ran on" in err
    assert "'rehab-robot-simulator'" in err
    assert not (tmp_path / "r.h5").exists()
    code, out, _ = run(["learn", "robot-data", "--trials", *paths, "--output",
                        str(tmp_path / "r.h5"), "--system", "bench-a"], capsys)
    assert code == 0
    assert "system bench-a" in out


def test_train_writes_into_the_data_folders_models_by_default(trials, tmp_path, capsys,
                                                                monkeypatch):
    """A robot model trained without --output lands where the Parameters tab offers it."""
    from app.learning.library import model_names, robot_model

    monkeypatch.setenv("REHAB_DATA_DIR", str(tmp_path / "data"))
    paths = [str(trials / "d.h5"), str(trials / "circle.h5")]
    assert run(["learn", "robot-data", "--trials", *paths, "--output", str(tmp_path / "r.h5"),
                "--without-hand-force", "--acceleration", "estimated"], capsys)[0] == 0
    args = ["learn", "train", "--model", "fnn", "--data", str(tmp_path / "r.h5"),
            "--epochs", "2", "--folds", "1", "--hidden", "4"]
    # refused data (two trials, five folds) made the data folder and its models/ all the same
    code, _, err = run([*args, "--folds", "5"], capsys)  # the last --folds counts
    assert code == 2
    assert "5-fold cross-validation needs 5" in err
    assert not (tmp_path / "data").exists()
    code, out, _ = run(args, capsys)
    assert code == 0
    folder = tmp_path / "data" / "models"
    assert model_names(folder) == ["fnn-r"]
    assert str(folder / "fnn-r.json") in out
    assert re.search(r"cross-validation RMSE tau_R1 \S+ N·m, tau_R2 \S+ N·m$", out.strip()), out
    assert robot_model(folder, "fnn-r").spec["kind"] == "fnn"
    code, _, err = run(args, capsys)  # the same name again: refused, not replaced
    assert code == 2
    assert "fnn-r.json already exists and is kept (trials may name it); give another --name" \
        in err
    code, _, err = run([*args, "--name", "my model"], capsys)
    assert code == 2
    assert "is not a model name" in err
    # a headless trial on it: its file names the model and its hash
    from app.learning.modelfile import read_model
    from app.trials.reader import read_trial

    trial = tmp_path / "t.h5"
    code, out, err = run(["run", "--learned-model", "fnn-r", "--repetitions", "1",
                          "--output", str(trial)], capsys)
    assert code == 0, err
    parameters = read_trial(trial).parameters
    assert (parameters.controller, parameters.learned_model) == ("ctpid", "fnn-r")
    assert parameters.learned_model_sha256 == read_model(folder / "fnn-r.json").content_sha256
    code, _, err = run(["run", "--learned-model", "nothing", "--output",
                        str(tmp_path / "u.h5")], capsys)
    assert code == 2
    assert "nothing.json: missing: no such file" in err
    # sliding mode asked for beside the model: refused, not run as the CT-PID unsaid
    code, _, err = run(["run", "--learned-model", "fnn-r", "--controller", "smc",
                        "--output", str(tmp_path / "v.h5")], capsys)
    assert code == 2
    assert err.count("\n") == 1
    assert "--learned-model runs the computed-torque PID" in err
    assert "leave out --controller smc" in err
    assert not (tmp_path / "v.h5").exists()
    code, _, err = run(["run", "--learned-model", "fnn-r", "--controller", "ctpid",
                        "--repetitions", "1", "--output", str(tmp_path / "w.h5")], capsys)
    assert code == 0, err


def test_components_of_a_delan_against_the_analytic_model(files, trained, tmp_path, capsys):
    """`rehab learn components`: the DeLaN's inertial, Coriolis, potential and dissipative
    torques against the pendulum's own (eq. 2.36), RMSE printed, plot written; the learned
    components add up to the model's output and the analytic ones to the data."""
    from app.learning.components import COMPONENTS, components_file

    out = tmp_path / "components.png"
    code, text, err = run(["learn", "components", "--model", str(trained["delan"]),
                           "--data", str(files / "p.h5"), "--output", str(out)], capsys)
    assert code == 0, err
    assert out.read_bytes().startswith(b"\x89PNG")
    assert "sliding-inverted-pendulum: RMSE against the analytic model" in text
    assert "f (N)" in text  # each force's column with its unit
    assert "tau (N·m)" in text
    for name in (*COMPONENTS, "total (data)"):
        assert f"  {name}" in text
    c = components_file(trained["delan"], files / "p.h5")
    np.testing.assert_allclose(sum(c.learned[n] for n in COMPONENTS), c.total, atol=1e-9)
    np.testing.assert_allclose(sum(c.analytic[n] for n in COMPONENTS), c.tau, atol=1e-6)
    assert np.all(c.rmse()["total"] > 0)
    code, _, err = run(["learn", "components", "--model", str(trained["delan"]), "--data",
                        str(files / "p.h5"), "--output", str(out)], capsys)
    assert code == 2
    assert "already exists" in err
    code, _, err = run(["learn", "components", "--model", str(trained["fnn"]), "--data",
                        str(files / "p.h5"), "--output", str(tmp_path / "f.png")], capsys)
    assert code == 2
    assert "only a DeLaN separates its torque into components" in err
    code, _, err = run(["learn", "components", "--model", str(trained["delan"]), "--data",
                        str(files / "p.h5"), "--output", str(tmp_path / "c.png"),
                        "--cycle", "99"], capsys)
    assert code == 2
    assert "has no cycle 99" in err


def test_the_robots_analytic_components_are_its_inverse_dynamics(trials, tmp_path, capsys):
    """For robot data the analytic side is the nominal robot (eq. 3.6-3.8): its four
    components add up to its inverse dynamics with no hand force."""
    from app.learning.components import COMPONENTS, analytic_components
    from app.learning.dataset import read_dataset
    from core.robot import RobotModel

    assert run(["learn", "robot-data", "--trials", str(trials / "d.h5"), "--output",
                str(tmp_path / "r.h5")], capsys)[0] == 0
    data = read_dataset(tmp_path / "r.h5")
    parts = analytic_components(data.system, data.q, data.qd, data.qdd)
    np.testing.assert_allclose(sum(parts[n] for n in COMPONENTS),
                               RobotModel().inverse_dynamics(data.q, data.qd, data.qdd),
                               rtol=1e-12, atol=1e-12)
    assert np.abs(parts["dissipative"]).max() > 0  # the robot's friction is in it
