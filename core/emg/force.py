"""What an EMG-to-torque model's torques are worth to the assistance: the force on the
handle they imply (eq. 5.1, the thesis's cHRI model: M_A θ̈_A + C_A θ̇_A = τ_A(u_A) +
J_Aᵀ F_I, solved for the hand's force) against the force sensor's, and how often the
performance-based scheme's cone test (section 3.5) judges the two alike.

A torque R² says little about that. The hand's force is the small difference between
the muscles' torque and what moving the arm itself takes, and J_A⁻ᵀ turns a torque error
into a force error of several newtons per N·m, so a model with a held-out R² of 0.9 can
still point the force outside the 20° cone when the sensor's is inside (measured:
docs/validation.md, "EMG in place of the force sensor"). A model may therefore feed the
assistance only if, held out, it also judges the push as the sensor does on at least
`USABLE_CONE_AGREEMENT` of the exercise's samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.control.assistance import PerformanceAssistance, cone_test
from core.emg.synthetic import absolute_torques
from core.errors import ParameterError
from core.interaction import subject_hand_force
from core.robot import RobotModel

USABLE_CONE_AGREEMENT = 0.8
"""The share of held-out samples on which the estimate's cone test must agree with the
sensor's (inside or outside the tolerance cone, or too weak to tell): four in five."""


@dataclass(frozen=True, slots=True, eq=False)
class ForceContext:
    """What a trial's samples need for the force an estimate implies: the subject's arm
    model, its absolute angles, rates and accelerations (N, 2 each), the sensor's force
    on the handle (global frame, N, (N, 2)), the path's desired direction (N, 2) and the
    trial's cone (tolerance, rad)."""

    arm: object
    angles: np.ndarray
    rates: np.ndarray
    accelerations: np.ndarray
    force_N: np.ndarray
    direction: np.ndarray
    tolerance_rad: float

    def __post_init__(self) -> None:
        n = self.angles.shape[0]
        for name in ("angles", "rates", "accelerations", "force_N", "direction"):
            if getattr(self, name).shape != (n, 2):
                raise ParameterError(name, getattr(self, name).shape, f"({n}, 2)")

    def __len__(self) -> int:
        return self.angles.shape[0]


def joined(contexts) -> ForceContext:
    """Several trials' contexts as one (each sample keeps its own trial's cone; trials of
    one subject share the arm, which is the first's)."""
    contexts = list(contexts)
    if len({round(c.tolerance_rad, 12) for c in contexts}) > 1:
        raise ParameterError("tolerance_rad", sorted({c.tolerance_rad for c in contexts}),
                             "one tolerance for the trials scored together")
    return ForceContext(contexts[0].arm, *(np.concatenate([getattr(c, k) for c in contexts])
                                           for k in ("angles", "rates", "accelerations",
                                                     "force_N", "direction")),
                        contexts[0].tolerance_rad)


def implied_force(torques_Nm, context: ForceContext) -> np.ndarray:
    """The hand's force (N, 2) that anatomical (shoulder, elbow) torques imply at the
    context's arm states (eq. 5.1)."""
    tau = absolute_torques(torques_Nm)
    a, r, c = context.angles, context.rates, context.accelerations
    fx, fy, _ = subject_hand_force(context.arm, a[:, 0], a[:, 1], r[:, 0], r[:, 1], c[:, 0],
                                   c[:, 1], tau[:, 0], tau[:, 1])
    return np.column_stack((fx, fy))


@dataclass(frozen=True, slots=True)
class ForceScore:
    """The implied force against the sensor's: RMSE per axis (N), the share of samples
    whose cone test agrees, and each one's share inside the cone."""

    rmse_N: tuple[float, float]
    cone_agreement: float
    sensor_in_cone: float
    estimate_in_cone: float
    tolerance_rad: float
    """The cone's half-angle it was judged with: a model is shown to judge cones that
    wide, not narrower ones."""

    def to_dict(self) -> dict:
        return {"rmse_N": list(self.rmse_N), "cone_agreement": self.cone_agreement,
                "sensor_in_cone": self.sensor_in_cone,
                "estimate_in_cone": self.estimate_in_cone, "tolerance_rad": self.tolerance_rad}

    @classmethod
    def from_dict(cls, d: dict) -> ForceScore:
        rmse = tuple(float(v) for v in d["rmse_N"])
        if len(rmse) != 2:
            raise ParameterError("rmse_N", list(rmse), "two values (x, y)")
        return cls(rmse, float(d["cone_agreement"]), float(d["sensor_in_cone"]),
                   float(d["estimate_in_cone"]), float(d["tolerance_rad"]))


def in_cone(force_N, direction, tolerance_rad: float) -> np.ndarray:
    """The scheme's cone test (core.control.assistance.cone_test, its default minimum
    force) on each sample: True where the force lies within the cone."""
    constants = PerformanceAssistance(RobotModel(), tolerance_rad=tolerance_rad).constants
    return np.array([cone_test(constants, fx, fy, dx, dy)[0]
                     for (fx, fy), (dx, dy) in zip(np.asarray(force_N, dtype=float).tolist(),
                                                   np.asarray(direction, dtype=float).tolist(),
                                                   strict=True)], dtype=bool)


def compared(estimate_N, force_N, direction, tolerance_rad: float) -> ForceScore:
    """Estimated forces (K, 2) against the sensor's at the same samples, judged by the
    cone about `direction`. A lost estimate (NaN) counts as a push outside the cone, as
    the scheme treats it."""
    estimate = np.asarray(estimate_N, dtype=float)
    force = np.asarray(force_N, dtype=float)
    if estimate.shape != force.shape or estimate.ndim != 2 or not len(estimate):
        raise ParameterError("estimate_N", estimate.shape, f"{force.shape}, at least one")
    error = (estimate - force)[np.isfinite(estimate).all(axis=1)]
    rmse = np.sqrt(np.mean(error * error, axis=0)) if len(error) else np.full(2, np.nan)
    sensor = in_cone(force, direction, tolerance_rad)
    judged = in_cone(estimate, direction, tolerance_rad)
    return ForceScore((float(rmse[0]), float(rmse[1])), float(np.mean(sensor == judged)),
                      float(sensor.mean()), float(judged.mean()), float(tolerance_rad))


def force_score(torques_Nm, context: ForceContext) -> ForceScore:
    """The force the torques imply against the context's sensor force, sample by sample
    (the torques aligned with the samples: an offline score; the console judges a model
    for the assistance by the estimate it would have made live, app.emg.validation)."""
    return compared(implied_force(torques_Nm, context), context.force_N, context.direction,
                    context.tolerance_rad)
