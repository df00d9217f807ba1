"""Who did the work of moving the handle over a trial or a stretch of it: the motors' net
work, the hand's, the robot's braking and the robot's help, and the help's share
(`MechanicalWork`). The thesis's eq. 3.6 (the motors' torque on the robot), 3.26 (its own
dynamics against what reaches the hand) and 3.34 (the hand's force through J_R).

In SI units (J, N·m, rad, N, m); computed from plain arrays sampled evenly in time, the
trial's (core.metrics.compute_metrics) or a block's (core.blockwise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class MechanicalWork:
    """Who did the work over a stretch of a trial (J).

    robot_J: net work of the motors on the robot, Σ τ_R · Δθ_R (eq. 3.6's input).
    patient_J: net work of the hand on the handle, Σ F · Δp (F the hand's force on the
        handle, global frame, eq. 3.34's F).
    robot_negative_J: the robot's braking, Σ min(τ_R · Δθ_R, 0) summed per sample over
        both joints together (≤ 0): work the robot took out of the motion.
    help_J: net work of the robot's help, Σ (τ_R − τ_own) · Δθ_R: τ_own the torque the
        mode spent on the robot's own inertia, friction and stiffness (core.control.own,
        eq. 3.26's left-hand side), so τ_R − τ_own is what reaches the hand (eq. 3.34's
        J_Rᵀ F_I): the pull toward the path and along it. NaN without τ_own.
    robot_share: max(help_J, 0) / (max(help_J, 0) + max(patient_J, 0)), the robot's
        share of the positive net work of moving the handle (NaN when neither did any).
        Why the help and not robot_J: the motors' work on the robot's own friction and
        mass moves nothing of the patient; counted, a transparent trial (no help at all)
        said "the robot did 40 %" and a healthy patient's as-needed one 14 % (the
        simulator, docs/validation.md), where the help did none.
    """

    robot_J: float
    patient_J: float
    robot_negative_J: float
    robot_share: float
    help_J: float = math.nan


def drop_old_share(metrics: dict) -> dict:
    """`metrics` (a trial's, as stored) with a robot_work_share of the definition before
    the share counted the help alone (MechanicalWork.robot_share; such a record has no
    robot_help_work_J) made NaN, in place: that share also counted the motors' work on the
    robot's own friction and mass (a transparent trial's "the robot did 40 %"), so an
    old record shows no share rather than that one. Its net works stand."""
    if "robot_work_share" in metrics and "robot_help_work_J" not in metrics:
        metrics["robot_work_share"] = math.nan
    return metrics


HELP_TORQUE_ZERO_NM = 1e-9
"""A help torque at or under this is none: the as-needed robot added nothing along the path
(the difference of two torques it computed, zero but for rounding when it did not help)."""


def helped_samples(help_torque_Nm) -> np.ndarray:
    """Per sample, whether the as-needed robot helped along the path: any joint's help
    torque (N, 2; core.control.guidance) beyond HELP_TORQUE_ZERO_NM. `led_pct` is the
    share of samples without."""
    return np.any(np.abs(np.asarray(help_torque_Nm, dtype=float)) > HELP_TORQUE_ZERO_NM,
                  axis=1)


def mechanical_work(torque_Nm, angle_rad, force_N, position_m,
                    own_torque_Nm=None) -> MechanicalWork:
    """The robot's and the patient's work from a trial's samples: torques (N, 2) held
    from each sample to the next (the drives' zero-order hold) times the joints' change
    of angle (N, 2), and the hand's force (N, 2) times the handle's displacement (N, 2),
    each force taken as the mean of the step's two samples; own_torque_Nm (N, 2) the
    part of the torques that carried the robot's own dynamics (core.control.own), for
    the help and the share (NaN without it)."""
    return work_shares(*work_terms(torque_Nm, angle_rad, force_N, position_m, own_torque_Nm))


def work_terms(torque_Nm, angle_rad, force_N, position_m,
               own_torque_Nm=None) -> tuple[float, float, float, float]:
    """`mechanical_work`'s sums over the steps between the samples given: (the robot's net
    work, the patient's, the robot's braking, the robot's help), J. Stretches that share
    their end samples add up to the whole trial's."""
    torque = np.asarray(torque_Nm, dtype=float)
    angle = np.asarray(angle_rad, dtype=float)
    force = np.asarray(force_N, dtype=float)
    position = np.asarray(position_m, dtype=float)
    step = np.diff(angle, axis=0)
    robot_power = np.sum(torque[:-1] * step, axis=1)
    patient = float(np.sum(0.5 * (force[1:] + force[:-1]) * np.diff(position, axis=0)))
    robot = float(np.sum(robot_power))
    negative = float(np.sum(np.minimum(robot_power, 0.0)))
    helped = math.nan
    if own_torque_Nm is not None:
        helped = float(np.sum((torque[:-1] - np.asarray(own_torque_Nm, dtype=float)[:-1])
                              * step))
    return robot, patient, negative, helped


def work_shares(robot: float, patient: float, negative: float,
                helped: float = math.nan) -> MechanicalWork:
    """`mechanical_work` from its sums (`work_terms`): the help's share of the positive
    net work of moving the handle (MechanicalWork.robot_share)."""
    positive = max(helped, 0.0) + max(patient, 0.0)
    share = (max(helped, 0.0) / positive if positive > 0.0 and math.isfinite(helped)
             else math.nan)
    return MechanicalWork(robot, patient, negative, share, helped)
