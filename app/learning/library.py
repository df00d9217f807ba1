"""The learned robot models a trial may run on: model files (app.learning.modelfile) in the
data folder's models/ folder, each named by its file's stem, offered by the Parameters
tab as "CT-PID (learned: <name>)" and checked when the trial is built.

A model is refused, by its fault's name (ModelFileError.reason), when its file is missing,
is not a model file (`format`), does not match its content hash (`content hash`), has
weights that do not fit its sizes or takes other than the robot's two joint coordinates
(`input size`), was trained on another system's data (`system`: a pendulum model is not a
robot model), or is a recurrent model (`kind`: its state ran away in closed loop,
docs/validation.md, "Learned inverse dynamics in the computed-torque PID").

On a real robot only a model of that robot may drive it (`another robot`): its data must
come from trials on that robot alone (`system` rehab-robot-quanser:<the robot's name>,
the name its hardware settings give it: two robots of one design differ in their belts,
friction and handle). A model trained on
simulated trials has learned the simulator's dynamics (the ideal plant's or a realistic
one drawn around the nominal model), not the robot's belts, friction and handle, and its
computed-torque PID would command that model's torques on the robot; trials of both
backends mixed are refused as well. On the simulator any robot model may run: that harms
no one and is how a model of the robot is compared with the simulator.
"""

from __future__ import annotations

from pathlib import Path

from app.learning.modelfile import ModelFile, ModelFileError, read_model
from app.learning.workflow import ROBOT_SYSTEM_PREFIX, robot_system
from core.learning.tick import LearnedInverseDynamics
from core.trial import MODEL_NAME

SUFFIX = ".json"
CONTROL_KINDS = ("delan", "fnn")
"""The model kinds the computed-torque PID may run on."""


def learned_label(name: str) -> str:
    """How the console names the controller on a learned model, in the Parameters tab's
    choice and in the report: 'CT-PID (learned: <name>)'."""
    return f"CT-PID (learned: {name})"


def model_names(folder: str | Path) -> list[str]:
    """The names of the model files in `folder` (none when it does not exist), sorted; a
    file whose stem is no model name (core.trial.MODEL_NAME: letters, digits, . _ -) is
    left out, as a trial could not name it."""
    folder = Path(folder)
    if not folder.is_dir():
        return []
    return sorted(p.stem for p in folder.iterdir()
                  if p.suffix == SUFFIX and p.is_file() and MODEL_NAME.fullmatch(p.stem))


def model_path(folder: str | Path, name: str) -> Path:
    return Path(folder) / f"{name}{SUFFIX}"


SIMULATOR_BACKEND = "simulator"


def robot_model(folder: str | Path, name: str,
                backend: str = SIMULATOR_BACKEND, robot_name: str = "") -> ModelFile:
    """The model file `name` in `folder`, read and checked as a model of the robot's
    inverse dynamics for the computed-torque PID on `backend` (a BackendConfig's kind:
    "simulator" or "quanser"; on a real robot `robot_name` is its settings' name);
    ModelFileError otherwise."""
    path = model_path(folder, name)
    model = read_model(path)
    if model.spec.get("dof") != 2:
        raise ModelFileError(path, "input size", f"the model takes {model.spec.get('dof')} "
                             "coordinates, the robot has 2 joints",
                             "Choose a model trained on the robot's trials.")
    system = str(model.data.get("system", ""))
    if not system.startswith(ROBOT_SYSTEM_PREFIX):
        raise ModelFileError(path, "system", f"the model was trained on '{system}', not on "
                             "the robot", "Choose a model trained on the robot's trials "
                             "(`rehab learn robot-data`).")
    if model.spec.get("kind") not in CONTROL_KINDS:
        raise ModelFileError(path, "kind", f"a {model.spec.get('kind')} model cannot drive "
                             "the robot (a recurrent model's state ran away in closed loop)",
                             "Choose a DeLaN or FNN model.")
    own = robot_system(f"{backend}:{robot_name}")
    if backend != SIMULATOR_BACKEND and system != own:
        unnamed = (" (its trials were recorded before robots were named, so which robot "
                   "they ran on is unknown)" if system == robot_system(backend) else "")
        raise ModelFileError(path, "another robot", f"the model was trained on '{system}', "
                             f"not on this robot's own trials ('{own}'){unnamed}",
                             "Train a model on trials recorded on this robot "
                             "(`rehab learn robot-data`), or run on the simulator.")
    return model


def robot_of(model: ModelFile) -> str:
    """The name of the real robot a model of the robot may drive besides the simulator
    (its data's `system` rehab-robot-quanser:<name>), '' when none."""
    system, prefix = str(model.data.get("system", "")), robot_system("quanser:")
    return system[len(prefix):] if system.startswith(prefix) else ""


def inverse_dynamics(model: ModelFile) -> LearnedInverseDynamics:
    """The checked model as the computed-torque PID's model (core.learning.tick)."""
    return LearnedInverseDynamics(model.spec, model.params, model.name,
                                  content_sha256=model.content_sha256)
