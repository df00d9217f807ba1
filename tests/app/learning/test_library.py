"""The learned robot models a trial may run on (app.learning.library): listed by name from
the models folder, each refusal by its reason, and the checked model as CT-PID's model."""

import numpy as np
import pytest

from app.learning.library import inverse_dynamics, model_names, robot_model
from app.learning.modelfile import ModelFileError, write_model
from core.learning import networks as nw

ROBOT = {"system": "rehab-robot-simulator", "dof": 2}


def spec_of(kind: str, dof: int = 2) -> dict:
    spec = {"kind": kind, "dof": dof, "hidden": [3], "position_inputs": list(range(dof)),
            "input_mean": [0.0] * 3 * dof, "input_std": [1.0] * 3 * dof,
            "output_mean": [0.0] * dof, "output_std": [1.0] * dof}
    if kind == "delan":
        spec.update(dissipation_hidden=[2], activation="tanh", mass_scale=0.5,
                    potential_scale=1.0, coulomb_speed_fraction=0.01)
    return spec


def save(folder, name, kind="fnn", data=ROBOT, dof=2):
    spec = spec_of(kind, dof)
    rng = np.random.default_rng(0)
    params = {k: rng.normal(size=s) for k, s in nw.param_shapes(spec).items()}
    return write_model(folder / f"{name}.json", name, spec, params, data, {}, {})


def test_the_folder_lists_its_model_files_by_name(tmp_path):
    assert model_names(tmp_path / "models") == []  # no folder yet: none
    folder = tmp_path / "models"
    folder.mkdir()
    save(folder, "fnn-b")
    save(folder, "delan-a", "delan")
    (folder / "notes.txt").write_text("not a model")
    save(folder, "with space")  # no trial could name it
    (folder / "sub.json").mkdir()
    assert model_names(folder) == ["delan-a", "fnn-b"]


def test_a_good_model_drives_the_ctpid(tmp_path):
    save(tmp_path, "delan-a", "delan")
    model = robot_model(tmp_path, "delan-a")
    learned = inverse_dynamics(model)
    assert learned.name == "delan-a"
    assert learned.content_sha256 == model.content_sha256
    tau = learned.inverse_dynamics_terms(2.0, 1.0, 0.1, -0.1, 1.0, 2.0)
    assert np.all(np.isfinite(tau))


@pytest.mark.parametrize(("name", "kind", "data", "dof", "reason", "words"), [
    ("gone", None, None, 2, "missing", "no such file"),
    ("pendulum", "fnn", {"system": "sliding-inverted-pendulum"}, 2, "system",
     "trained on 'sliding-inverted-pendulum', not on the robot"),
    ("three", "fnn", ROBOT, 3, "input size", "takes 3 coordinates, the robot has 2 joints"),
    ("gru", "rnn", ROBOT, 2, "kind", "a rnn model cannot drive the robot"),
])
def test_a_model_that_cannot_drive_the_robot_is_refused_by_its_reason(
        tmp_path, name, kind, data, dof, reason, words):
    if kind is not None:
        save(tmp_path, name, kind, data, dof)
    with pytest.raises(ModelFileError) as caught:
        robot_model(tmp_path, name)
    assert caught.value.reason == reason
    assert words in str(caught.value)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(("system", "on_robot"), [
    ("rehab-robot-quanser:R1", True),
    ("rehab-robot-quanser:R2", False),  # another robot of the same design
    ("rehab-robot-quanser", False),  # trials recorded before robots were named
    ("rehab-robot-simulator", False),
    ("rehab-robot-quanser:R1-simulator", False),  # simulated trials mixed in
    ("rehab-robot-lab", False),  # a name given by hand says nothing of the trials
])
def test_on_the_robot_only_a_model_of_its_own_trials_drives_it(tmp_path, system, on_robot):
    save(tmp_path, "m", "fnn", {"system": system, "dof": 2})
    assert robot_model(tmp_path, "m").name == "m"  # the simulator takes any robot model
    if on_robot:
        assert robot_model(tmp_path, "m", "quanser", "R1").name == "m"
        return
    with pytest.raises(ModelFileError) as caught:
        robot_model(tmp_path, "m", "quanser", "R1")
    assert caught.value.reason == "another robot"
    text = str(caught.value)
    assert (f"trained on '{system}', not on this robot's own trials "
            "('rehab-robot-quanser:R1')") in text
    assert ("recorded before robots were named" in text) == (system == "rehab-robot-quanser")
    assert "rehab learn robot-data" in text
    assert "\n" not in text


@pytest.mark.parametrize(("backend", "values", "ran_on"), [
    ("simulator (weak, seed 1)", {"seed": 1, "robot_seed": 0}, "simulator"),
    ("quanser (robot R1, /etc/rehab/robot.toml)", {"robot": "R1"}, "quanser:R1"),
    ("quanser (/etc/rehab/robot.toml)", {"approach_ticks": 0}, "quanser"),  # before names
])
def test_what_a_trial_ran_on_is_its_robot_by_name(backend, values, ran_on):
    from app.learning.workflow import ran_on_of, robot_system

    events = [{"kind": "start", "values": values}, {"kind": "stop", "values": {}}]
    assert ran_on_of(backend, events) == ran_on
    # trials of two robots make data of neither: its system is no one robot's
    mixed = robot_system("-".join(sorted({"quanser:R1", "quanser:R2"})))
    assert mixed not in (robot_system("quanser:R1"), robot_system("quanser:R2"))
