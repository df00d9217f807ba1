"""A learned model inside the computed-torque PID on the simulator's realistic plant
(thesis chapter 4, eq. 4.8–4.9): the one "unknown" robot the comparison runs on, the
trials it learns from and is judged on, and a trial run with any controller.

The unknown robot is `device.sim.plant.Plant.realistic` drawn once by `UNKNOWN_SEED`
around the controller's nominal model: its own link masses and inertias, friction 1.5–3
times the model's, joint stiffness, drive gain and a one-tick drive delay, none of which
the nominal model knows (the f_RJ, K_R and J_Rᵀ f_RE of eq. 4.9). Its joint stiffness
rests at the workspace's centre `REST_M` for every trial, as a real robot's cables do
whatever the exercise.

The training trials run the console's sliding-mode controller (as the thesis's section
4.3 trials did) with a passive virtual patient on the handle; the torque learned is the
applied torque with the hand's J_Rᵀ F added back (app.learning.workflow.robot_samples):
what the robot alone needed. The held-out trials are shapes, places and speeds none of the
training trials has.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from app.learning.workflow import EXERCISE_PHASE, robot_samples
from core.control.ctpid import ComputedTorquePID, CTPIDGains, DiagonalInertia
from core.metrics import rmse_xy
from core.robot import Link, RobotModel
from core.trial import TrialParameters
from device.loop.engine import run_trial
from device.loop.pipeline import TickPipeline, TrialPlan
from device.safety.supervisor import SafetySupervisor
from device.sim.patients import make_patient
from device.sim.plant import Plant
from device.sim.simulator import SimulatorBackend

UNKNOWN_SEED = 15
"""Draws the unknown robot's parameters (device.sim.plant.SPREAD)."""
REST_M = (-0.30, 0.30)
"""Where the unknown robot's joint stiffness rests: the thesis exercise's centre (m)."""
PATIENT = "passive"
"""The virtual patient on the handle in every trial here: the arm's weight and tissue,
no effort (device.sim.patients)."""

_BASE = TrialParameters(repetitions=2)


def _trial(shape, centre, radius, duration, clockwise=True) -> TrialParameters:
    return _BASE.replace(shape=shape, centre_m=centre, radius_m=radius, duration_s=duration,
                         clockwise=clockwise)


TRAINING_TRIALS: tuple[TrialParameters, ...] = (
    _trial("d", (-0.30, 0.30), 0.10, 3.0),
    _trial("d", (-0.30, 0.30), 0.10, 6.0, clockwise=False),
    _trial("circle", (-0.30, 0.30), 0.08, 4.0),
    _trial("circle", (-0.28, 0.33), 0.05, 2.5, clockwise=False),
    _trial("targets", (-0.30, 0.30), 0.10, 8.0),
    _trial("reach", (-0.30, 0.36), 0.07, 3.0),
)
"""What the models learn from: shapes, places and speeds across the exercise's area."""

HELD_OUT_TRIALS: tuple[TrialParameters, ...] = (
    _trial("figure8", (-0.30, 0.31), 0.08, 5.0),
    _trial("circle", (-0.26, 0.28), 0.07, 3.5),
    _trial("d", (-0.31, 0.32), 0.08, 4.5, clockwise=False),
)
"""What the models are judged on: a shape never trained on (the figure eight), a circle
and a D at places, sizes and speeds none of the training trials has."""


def soft_gains(omega_rad_s: float) -> CTPIDGains:
    """CT-PID gains with the outer loop's triple pole at −ω (the module notes of
    core.control.ctpid): K_d = 3ω, K_p = 3ω², K_i = ω³."""
    w = float(omega_rad_s)
    return CTPIDGains(kp_1_s2=(3 * w * w,) * 2, ki_1_s3=(w**3,) * 2, kd_1_s=(3 * w,) * 2)


def unknown_plant(nominal: RobotModel | None = None, seed: int = UNKNOWN_SEED) -> Plant:
    """The simulated robot the models learn: realistic, drawn by `seed` around `nominal`."""
    nominal = nominal or RobotModel()
    return Plant.realistic(nominal, seed, tuple(float(v) for v in nominal.ik(REST_M)))


def inertia_scaled(robot: RobotModel, factor: float) -> RobotModel:
    """`robot` with every link's mass and inertia times `factor`: its M_R and C_R (eq. 3.7,
    3.8, linear in them) are `factor` times the model's; friction and stiffness kept."""
    links = tuple(Link(link.mass_kg * factor, link.inertia_kgm2 * factor, link.cg_x_m,
                       link.cg_y_m) for link in robot.links)
    return replace(robot, links=links)


def pid_alone(robot: RobotModel) -> DiagonalInertia:
    """The no-model comparison: M's diagonal at the rest posture, no C, no f."""
    return DiagonalInertia(robot, robot.ik(REST_M))


def ctpid(model, gains: CTPIDGains, robot: RobotModel) -> ComputedTorquePID:
    """The computed-torque PID on `model`, limited to `robot`'s drives."""
    return ComputedTorquePID(model, gains, torque_limit_Nm=robot.max_joint_torque_Nm)


@dataclass(frozen=True)
class Run:
    """One trial on the plant: its records and how it ended ("complete" or "faulted")."""

    records: np.ndarray
    status: str
    fault: str = ""


def run_on_plant(parameters: TrialParameters, plant: Plant, controller=None, *,
                 robot: RobotModel | None = None, seed: int = 0,
                 compiled: bool = False, patient: str = PATIENT) -> Run:
    """One trial on `plant` with the passive patient, headless, through the console's own
    pipeline, safety supervisor and simulator: interpreted (any controller; a learned model
    through its numpy tick) or `compiled` (numba: the analytic controllers, and an FNN or a
    DeLaN through core.learning.kernel). `controller` defaults to the trial's own (its
    `controller` field) on `robot`, the controller's nominal model; `patient` is the
    virtual patient's kind (device.sim.patients)."""
    robot = robot or RobotModel()
    plan = TrialPlan.build(parameters, robot)
    subject = make_patient(patient, parameters.arm(), parameters.trajectory(), seed=seed)
    backend = SimulatorBackend(subject, seed=seed, plant=plant, compiled=compiled)
    pipeline = TickPipeline(plan, controller=controller, compiled=compiled)
    outcome = run_trial(backend, pipeline, SafetySupervisor(plan.robot))
    return Run(outcome.records, outcome.status, outcome.fault_message)


def training_runs(plant: Plant, trials: Sequence[TrialParameters] = TRAINING_TRIALS, *,
                  robot: RobotModel | None = None, patient: str = PATIENT) -> list[Run]:
    """`trials` run on `plant` by their own controller (the sliding-mode one by default),
    each with its own sensor-noise seed; refused if one faults (no data to learn from)."""
    runs = []
    for index, parameters in enumerate(trials):
        run = run_on_plant(parameters, plant, robot=robot, seed=index, patient=patient)
        if run.status != "complete":
            raise RuntimeError(f"training trial {index} ({describe(parameters)}) faulted: "
                               f"{run.fault}")
        runs.append(run)
    return runs


def samples_of(runs: Sequence[Run], robot: RobotModel, *, without_hand_force: bool,
               acceleration: str = "estimated"):
    """(q, qd, qdd, tau, cycle) of the runs' exercise, one cycle per run; with
    `without_hand_force` the torque is the robot's alone (the hand's J_Rᵀ F added back),
    else the robot's and the arm's on its handle together."""
    parts = []
    for index, run in enumerate(runs):
        samples = robot_samples(run.records, robot, acceleration=acceleration,
                                without_hand_force=without_hand_force)
        parts.append((*samples, np.full(len(samples[0]), index)))
    return tuple(np.concatenate([p[i] for p in parts]) for i in range(5))


def describe(parameters: TrialParameters) -> str:
    """A trial in a few words: shape, radius, period, centre."""
    x, y = parameters.centre_m
    turn = "" if parameters.clockwise else " ccw"
    return (f"{parameters.shape}{turn} r {parameters.radius_m * 100:g} cm "
            f"{parameters.duration_s:g} s at ({x:g}, {y:g}) m")


@dataclass(frozen=True)
class Tracking:
    """A trial's exercise: RMS position error per axis (m) and RMS torque per joint
    (N·m); NaN when the trial faulted before its exercise ended."""

    rmse_m: tuple[float, float]
    torque_rms_Nm: tuple[float, float]
    status: str

    @classmethod
    def of(cls, run: Run) -> Tracking:
        r = run.records
        rows = r["phase"] == EXERCISE_PHASE
        if run.status != "complete" or not rows.any():
            return cls((np.nan, np.nan), (np.nan, np.nan), run.status)
        torque = np.sqrt(np.mean(np.square(r["torque_applied"][rows]), axis=0))
        return cls(rmse_xy(r["position"][rows], r["position_desired"][rows]),
                   (float(torque[0]), float(torque[1])), run.status)
