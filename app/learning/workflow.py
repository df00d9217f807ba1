"""The researcher's three steps on files: make the pendulum's data (thesis section 2.5),
train a model on a dynamics data file, evaluate a model file on one."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from app.learning.dataset import (
    Dataset,
    DatasetError,
    pendulum_dataset,
    read_dataset,
    write_dataset,
)
from app.learning.modelfile import ModelFile, read_model, write_model
from core.learning import inference, pendulum as pd


def make_pendulum_file(path: str | Path, speeds_rad_s: Sequence[float] | None = None,
                       held_out_speed_rad_s: float | None = pd.HELD_OUT_SPEED_RAD_S, *,
                       overwrite: bool = False) -> Dataset:
    """The pendulum's data (eq. 2.36–2.39) written to `path`: by default the thesis's 1,000
    cycles with the 5 rad/s cycle marked held out (the file's `held_out_cycles`); an
    existing file is replaced only with `overwrite` (app.records.safewrite)."""
    speeds = pd.THESIS_SPEEDS_RAD_S if speeds_rad_s is None else np.asarray(speeds_rad_s, float)
    pendulum = pd.Pendulum()
    samples = pd.generate(speeds, pendulum)
    data = pendulum_dataset(samples, pendulum)
    description = dict(data.description)
    description["cyclic"] = ["x1"]  # the dynamics does not depend on the base's position
    if held_out_speed_rad_s is not None:
        matches = np.flatnonzero(np.isclose(speeds, held_out_speed_rad_s, rtol=0, atol=1e-9))
        description["held_out_cycles"] = [int(samples.cycle[0] + i) for i in matches]
    data = replace(data, description=description)
    write_dataset(path, data, overwrite=overwrite)
    return data


def held_out(data: Dataset) -> np.ndarray:
    """True for the samples of the cycles the file marks held out (none: all False)."""
    return np.isin(data.cycle, data.description.get("held_out_cycles", []))


def cyclic_indices(data: Dataset, names: Sequence[str] | None) -> tuple[int, ...]:
    """The coordinates a model leaves out of its positions: those named, else those the
    file names (`description.cyclic`)."""
    names = data.description.get("cyclic", []) if names is None else names
    unknown = [n for n in names if n not in data.coordinates]
    if unknown:
        raise DatasetError("", f"has no coordinate {', '.join(unknown)} (its coordinates: "
                           f"{', '.join(data.coordinates)})", "Name one of its coordinates.")
    return tuple(data.coordinates.index(n) for n in names)


@dataclass(frozen=True)
class TrainedModel:
    path: Path
    parameters: int
    cross_validation_rmse: dict[str, float]
    training_seconds: float
    samples: int
    units: dict[str, str]  # each force's (force_units)


def train_file(data_path: str | Path, output: str | Path, kind: str, *,
               cyclic: Sequence[str] | None = None, name: str | None = None,
               progress: Callable[[float], None] | None = None, overwrite: bool = False,
               owned: bool = False, checked: Callable[[], object] | None = None,
               **options) -> TrainedModel:
    """Train a `kind` model on the file's samples (its held-out cycles left out) and write
    the model file (`overwrite`, `owned`: app.learning.modelfile.write_model's).
    `checked` is called once the data and the options are found trainable, before the
    training (the command line makes the data folder's models/ there, so a refused run
    makes nothing). `options` are core.learning.training.TrainingOptions' fields."""
    data = read_dataset(data_path)
    try:
        indices = cyclic_indices(data, cyclic)
    except DatasetError as exc:
        raise DatasetError(data_path, exc.problem, exc.advice) from None
    keep = ~held_out(data)
    train_data = data.select(keep)
    from core.learning.training import TrainingOptions, train  # JAX: only now

    try:
        opts = TrainingOptions(kind=kind, cyclic=indices, **options)
    except ValueError as exc:
        raise DatasetError(data_path, f"cannot train on it: {exc}", "Change the options.") \
            from None
    needed = max(opts.folds, 2)
    if np.unique(train_data.cycle).size < needed:
        raise DatasetError(data_path, f"has {np.unique(train_data.cycle).size} training "
                           f"cycles; {opts.folds}-fold cross-validation needs {needed}",
                           "Give more cycles, or fewer --folds.")
    if checked is not None:
        checked()
    try:
        result = train(train_data.q, train_data.qd, train_data.qdd, train_data.tau,
                       train_data.cycle, opts, progress=progress)
    except ValueError as exc:  # options that do not fit these data (core.learning.training)
        raise DatasetError(data_path, f"cannot train on it: {exc}",
                           "Change the options or the data.") from None
    summary = train_data.summary()
    summary["file"] = Path(data_path).name
    summary["held_out_cycles"] = data.description.get("held_out_cycles", [])
    metrics = dict(result.metrics)
    metrics["cross_validation_rmse"] = dict(zip(data.forces,
                                                result.metrics["cross_validation_rmse"],
                                                strict=True))
    path = write_model(output, name or Path(output).stem, result.spec, result.params,
                       summary, opts.hyper_parameters(), metrics, overwrite=overwrite,
                       owned=owned)
    return TrainedModel(path, metrics["parameters"], metrics["cross_validation_rmse"],
                        metrics["training_seconds"], len(train_data), force_units(data))


@dataclass(frozen=True)
class Evaluation:
    rmse: dict[str, float]
    parameters: int
    samples: int
    cycles: int
    held_out: bool  # the file's held-out cycles, else all its cycles
    units: dict[str, str]  # each force's (force_units)


def evaluate_file(model_path: str | Path, data_path: str | Path,
                  all_cycles: bool = False) -> Evaluation:
    """RMSE of each generalised force of the file (its held-out cycles if it marks some and
    `all_cycles` is false), with the model's numpy inference."""
    model: ModelFile = read_model(model_path)
    data = read_dataset(data_path)
    model.check_data(data)
    mask = held_out(data)
    held = not all_cycles and mask.any()
    if not held:
        mask = np.ones(len(data), bool)
    part = data.select(mask)
    predicted = inference.predict(model.spec, model.params, part.q, part.qd, part.qdd,
                                  part.cycle)
    rmse = np.sqrt(np.mean((predicted - part.tau) ** 2, axis=0))
    return Evaluation(dict(zip(data.forces, map(float, rmse), strict=True)),
                      model.parameters, len(part), int(np.unique(part.cycle).size), bool(held),
                      force_units(data))


ROBOT_SYSTEM_PREFIX = "rehab-robot"
"""What the `system` of robot data begins with (`robot_dataset` names it `robot_system`
of what its trials ran on): a model trained on such data is a model of the robot."""


ROBOT_FORCE_UNIT = "N·m"
"""The robot's generalised forces are its joints' torques."""
SI_FORCE_UNIT = "SI"
"""A force of a system the console has no model of: SI as the format asks, but the file
does not say whether it is a force (N) or a torque (N·m)."""


def force_units(data: Dataset) -> dict[str, str]:
    """Each generalised force's SI unit, by its name in `data`: the pendulum's N and N·m
    (by position: a researcher may rename them), a robot's N·m, another system's 'SI'."""
    if data.system == pd.SYSTEM and data.dof == len(pd.FORCE_UNITS):
        units = pd.FORCE_UNITS
    elif data.system.startswith(ROBOT_SYSTEM_PREFIX):
        units = (ROBOT_FORCE_UNIT,) * data.dof
    else:
        units = (SI_FORCE_UNIT,) * data.dof
    return dict(zip(data.forces, units, strict=True))


def robot_system(ran_on: str) -> str:
    """The `system` of data from trials that ran on `ran_on` (`ran_on_of`):
    rehab-robot-simulator, rehab-robot-quanser:<the robot's name>."""
    return f"{ROBOT_SYSTEM_PREFIX}-{ran_on}"


def ran_on_of(backend: str, events) -> str:
    """What a trial ran on, from its file's `backend` and events: 'simulator', or on a real
    robot its kind and the name its settings gave it ('quanser:<name>', the `start`
    event's `robot`, device.hardware.settings.RobotIdentity); a robot's trial recorded
    before robots were named says only its kind ('quanser'): which robot is unknown."""
    kind = backend.split(" (")[0]
    if kind == "simulator":
        return kind
    for event in events:
        if event.get("kind") == "start":
            name = (event.get("values") or {}).get("robot")
            if isinstance(name, str) and name:
                return f"{kind}:{name}"
    return kind
ROBOT_COORDINATES = ("theta_R1", "theta_R2")
ROBOT_FORCES = ("tau_R1", "tau_R2")
EXERCISE_PHASE = 2  # the `phase` channel: 2 while the exercise runs (docs/data-format.md)


def robot_samples(channels, robot, *, acceleration: str = "desired",
                  without_hand_force: bool = False):
    """One trial's exercise samples (q, qd, qdd, tau), each (N, 2), from its channels by
    record name (a trial file's, or a headless run's records): see `robot_dataset`.
    Samples with a missing value are left out."""
    if acceleration not in ("desired", "estimated"):
        raise DatasetError("", f"acceleration {acceleration!r} is neither 'desired' nor "
                           "'estimated'", "Choose one.")
    rows = np.asarray(channels["phase"]) == EXERCISE_PHASE
    if not rows.any():
        raise DatasetError("", "has no exercise samples", "Give a trial that ran.")
    q, qd = channels["robot_angle"][rows], channels["robot_rate"][rows]
    qdd = channels["robot_acceleration_desired" if acceleration == "desired"
                   else "robot_acceleration"][rows]
    tau = np.array(channels["torque_applied"][rows], dtype=float)
    if without_hand_force:
        # eq. 3.26: τ_R = M θ̈ + h − J_Rᵀ F, so the robot alone would have needed
        # τ_R + J_Rᵀ F (J_Rᵀ F of eq. 3.34, the hand's force on the handle)
        F = channels["force"][rows]
        tau += np.stack(robot.joint_torque_terms(q[:, 0], q[:, 1], F[:, 0], F[:, 1]), axis=-1)
    keep = np.all(np.isfinite(np.hstack([q, qd, qdd, tau])), axis=1)
    return q[keep], qd[keep], qdd[keep], tau[keep]


def robot_dataset(trial_paths: Sequence[str | Path], *, acceleration: str = "desired",
                  without_hand_force: bool = False, system: str | None = None) -> Dataset:
    """Recorded trials as robot dynamics data (thesis section 4.3): the exercise's joint
    angles, rates, accelerations (the reference's, as the thesis trained on, or the
    estimated ones) and the torque applied, one cycle per trial. With `without_hand_force`
    the hand force's share, J_Rᵀ F (eq. 3.34), is taken out of the torque: what section
    4.4.1 asks of eq. 4.9."""
    from app.trials.reader import read_trial
    from core.robot import RobotModel

    if acceleration not in ("desired", "estimated"):
        raise DatasetError("", f"acceleration {acceleration!r} is neither 'desired' nor "
                           "'estimated'", "Choose one.")
    if not trial_paths:
        raise DatasetError("", "no trial files given", "Give one or more trial files.")
    robot = RobotModel()
    parts, systems = [], set()
    for index, path in enumerate(trial_paths):
        trial = read_trial(path)
        try:
            q, qd, qdd, tau = robot_samples(trial.channels, robot, acceleration=acceleration,
                                            without_hand_force=without_hand_force)
        except DatasetError as exc:
            raise DatasetError(path, exc.problem, exc.advice) from None
        parts.append((q, qd, qdd, tau, np.full(len(q), index)))
        systems.add(ran_on_of(trial.backend, trial.events))
    own = robot_system("-".join(sorted(systems)))
    if system is not None and system != own and system.startswith(ROBOT_SYSTEM_PREFIX):
        # the robot's names are what the trials ran on: the Build on the real robot refuses
        # a model not of its own trials by this name (app.learning.library.robot_model), so
        # simulated trials named 'rehab-robot-quanser' would pass for the robot's
        raise DatasetError("", f"the system {system!r} is not what these trials ran on "
                           f"({own!r})", f"Leave --system out, or give a name that does not "
                           f"start with {ROBOT_SYSTEM_PREFIX!r}.")
    name = system or own
    arrays = [np.concatenate([p[i] for p in parts]) for i in range(5)]
    description = {"trials": [Path(p).name for p in trial_paths], "acceleration": acceleration,
                   "without_hand_force": without_hand_force}
    return Dataset(*arrays, name, ROBOT_COORDINATES, ROBOT_FORCES, description)
