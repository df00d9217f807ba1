"""The controller choice "CT-PID (learned: <name>)", as a researcher and a therapist meet
it: model files saved in the data folder's models/ appear by name; Build refuses a missing,
corrupt, another system's or another size's model, and on the robot a model of simulated
trials, with one line naming the reason; a good
model's trial runs on the simulator with the model in the loop, and its trial file records
the model's name and content hash. The real loop and recorder processes run behind the
window.

The model here is fitted without JAX (the suite keeps JAX for its last tests): an FNN of
one tanh layer with fixed random input weights whose output layer is the least-squares fit
to the nominal robot's inverse dynamics, written as `rehab learn train` writes models."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from app.learning.library import inverse_dynamics, robot_model
from app.learning.modelfile import read_model, write_model
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.trials.reader import read_trial
from core.control.ctpid import ComputedTorquePID, CTPIDGains
from core.learning import networks as nw
from core.robot import RobotModel
from device.loop.states import State
from tests.ui.session import build_connect_start, click, register_patient, short_trial
from ui.main_window import MainWindow

EXAMPLE_SETTINGS = Path(__file__).resolve().parents[2] / "resources" / "hardware.example.toml"

pytestmark = pytest.mark.slow

ROBOT_DATA = {"system": "rehab-robot-simulator", "samples": 4000, "dof": 2}


def fitted_fnn(robot: RobotModel, hidden: int = 48) -> tuple[dict, dict]:
    """An FNN of the robot's inverse dynamics (friction included) around the exercise."""
    rng = np.random.default_rng(0)
    n = 4000
    q = np.asarray(robot.ik([-0.30, 0.30])) + rng.uniform(-0.5, 0.5, (n, 2))
    qd, qdd = rng.normal(0.0, 1.0, (n, 2)), rng.normal(0.0, 8.0, (n, 2))
    tau = np.stack(robot.inverse_dynamics_terms(*q.T, *qd.T, *qdd.T), axis=-1)
    x = np.hstack([q, qd, qdd])
    spec = {"kind": "fnn", "dof": 2, "hidden": [hidden], "position_inputs": [0, 1],
            "input_mean": x.mean(0).tolist(), "input_std": x.std(0).tolist(),
            "output_mean": tau.mean(0).tolist(), "output_std": tau.std(0).tolist()}
    W0 = rng.normal(0.0, 0.5, (6, hidden))
    b0 = rng.normal(0.0, 0.5, hidden)
    features = np.tanh((x - x.mean(0)) / x.std(0) @ W0 + b0)
    design = np.hstack([features, np.ones((n, 1))])
    target = (tau - tau.mean(0)) / tau.std(0)
    solution = np.linalg.lstsq(design, target, rcond=None)[0]
    params = {"net.0.W": W0, "net.0.b": b0, "net.1.W": solution[:-1], "net.1.b": solution[-1]}
    assert {k: v.shape for k, v in params.items()} == nw.param_shapes(spec)
    return spec, params


@pytest.fixture
def models(tmp_path, monkeypatch):
    # written (signed) with this installation's key: the config folder the window will use
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    folder = tmp_path / "data" / "models"
    folder.mkdir(parents=True)
    spec, params = fitted_fnn(RobotModel())
    write_model(folder / "fnn-robot.json", "fnn-robot", spec, params, ROBOT_DATA, {}, {})
    write_model(folder / "pendulum.json", "pendulum", spec, params,
                {"system": "sliding-inverted-pendulum", "dof": 2}, {}, {})
    three = {**spec, "dof": 3, "input_mean": [0.0] * 9, "input_std": [1.0] * 9,
             "output_mean": [0.0] * 3, "output_std": [1.0] * 3}
    write_model(folder / "three-joints.json", "three-joints", three,
                {k: np.zeros(s) for k, s in nw.param_shapes(three).items()}, ROBOT_DATA, {}, {})
    write_model(folder / "edited.json", "edited", spec, params, ROBOT_DATA, {}, {})
    document = json.loads((folder / "edited.json").read_text())
    document["weights"]["net.1.b"]["values"][0] += 0.5  # a weight changed by hand
    (folder / "edited.json").write_text(json.dumps(document))
    write_model(folder / "deleted.json", "deleted", spec, params, ROBOT_DATA, {}, {})
    gru = {**spec, "kind": "rnn", "hidden": [4]}
    write_model(folder / "gru.json", "gru", gru,
                {k: np.zeros(s) for k, s in nw.param_shapes(gru).items()}, ROBOT_DATA, {}, {})
    return folder


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch, models):
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    registry = Registry(DataDir(tmp_path / "data", "test"))
    win = MainWindow(registry, settings_path=tmp_path / "config" / "settings.json")
    qtbot.addWidget(win)
    win.show()
    win.start_device()
    yield win
    win.close()


def choose(win, label: str) -> None:
    p = win.parameters_tab
    index = p.controller.findText(label)
    assert index >= 0, [p.controller.itemText(i) for i in range(p.controller.count())]
    p.controller.setCurrentIndex(index)
    p.refresh()


def refused(qtbot, win, label: str, reason: str) -> str:
    choose(win, label)
    click(qtbot, win.robot.buttons["build"])
    text = win.message.text()
    assert "Build refused" in text, text
    assert reason in text, text
    assert "\n" not in text
    assert win.state == State.IDLE
    return text


def test_saved_models_appear_and_bad_ones_refuse_the_build(qtbot, window, models):
    win = window
    p = win.parameters_tab
    win.tabs.setCurrentWidget(p)
    labels = [p.controller.itemText(i) for i in range(p.controller.count())]
    assert labels == ["Sliding mode (SMC)", "Computed-torque PID",
                      *(f"CT-PID (learned: {n})" for n in
                        ("deleted", "edited", "fnn-robot", "gru", "pendulum", "three-joints"))]
    short_trial(win)

    # the file went after it was listed: the choice stays, the Build says it is missing
    choose(win, "CT-PID (learned: deleted)")
    (models / "deleted.json").unlink()
    assert "missing: no such file" in refused(qtbot, win, "CT-PID (learned: deleted)",
                                              "deleted.json")
    assert "content hash" in refused(qtbot, win, "CT-PID (learned: edited)", "edited.json")
    assert "trained on 'sliding-inverted-pendulum', not on the robot" in refused(
        qtbot, win, "CT-PID (learned: pendulum)", "system")
    assert "the model takes 3 coordinates, the robot has 2 joints" in refused(
        qtbot, win, "CT-PID (learned: three-joints)", "input size")
    assert "a rnn model cannot drive the robot" in refused(
        qtbot, win, "CT-PID (learned: gru)", "kind")
    # on the robot, a model of simulated trials would command the simulator's dynamics
    p.hardware.click()
    p.settings_path.setText(str(models.parent / "robot.toml"))
    assert "robot.toml does not exist" in refused(  # which robot is its settings' to say
        qtbot, win, "CT-PID (learned: fnn-robot)", "robot.toml")
    shutil.copy(EXAMPLE_SETTINGS, models.parent / "robot.toml")
    assert "not on this robot's own trials ('rehab-robot-quanser:rehab-robot-1')" in refused(
        qtbot, win, "CT-PID (learned: fnn-robot)", "another robot")
    p.simulator.click()
    # a model saved while the console runs appears when the Parameters tab is shown again
    spec, params = fitted_fnn(RobotModel(), hidden=8)
    write_model(models / "later.json", "later", spec, params, ROBOT_DATA, {}, {}, owned=True)
    win.tabs.setCurrentWidget(win.instructions)
    win.tabs.setCurrentWidget(p)
    assert p.controller.findText("CT-PID (learned: later)") >= 0


def test_a_trial_runs_on_a_learned_model_and_its_file_names_it(qtbot, window, models):
    win = window
    register_patient(qtbot, win)
    win.tabs.setCurrentWidget(win.parameters_tab)
    short_trial(win)
    p = win.parameters_tab
    p.assist.setCurrentIndex(p.assist.findData("thesis"))  # the reference on the clock
    choose(win, "CT-PID (learned: fnn-robot)")
    assert win.parameters_tab.parameters().learned_model == "fnn-robot"
    build_connect_start(qtbot, win)
    qtbot.waitUntil(lambda: win.unsaved_trial is not None, timeout=60000)

    trial = win.registry.trials_for_patient(win.patient.code)[0]
    assert trial.status == "complete"
    data = read_trial(win.registry.trial_path(trial))
    expected = read_model(models / "fnn-robot.json").content_sha256
    assert data.parameters.controller == "ctpid"
    assert data.parameters.learned_model == "fnn-robot"
    assert data.parameters.learned_model_sha256 == expected
    # the model drove the robot: its CT-PID, replayed on the recorded ticks, gives the
    # recorded controller torque, and the analytic model's does not; the D was followed
    model = inverse_dynamics(robot_model(models, "fnn-robot"))
    assert replayed_error(data, model) < 1e-6  # the loop ran it compiled
    assert replayed_error(data, RobotModel()) > 1e-3
    assert trial.metrics["rmse_x_m"] < 0.01
    assert trial.metrics["rmse_y_m"] < 0.01


def replayed_error(data, model, ticks: int = 500) -> float:
    """Largest difference (N·m) between the recorded controller torque of the trial's first
    ticks and eq. 4.8 on `model` run on the same recorded inputs."""
    c = data.channels
    controller = ComputedTorquePID(model, CTPIDGains(),
                                   torque_limit_Nm=RobotModel().max_joint_torque_Nm)
    worst = 0.0
    for k in range(ticks):
        tau = controller.step(0.002, *c["robot_angle"][k], *c["robot_rate"][k],
                              *c["robot_angle_desired"][k], *c["robot_rate_desired"][k],
                              *c["robot_acceleration_desired"][k])
        worst = max(worst, float(np.max(np.abs(np.subtract(tau, c["torque_controller"][k])))))
    return worst
