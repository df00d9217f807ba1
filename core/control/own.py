"""The part of the motors' torque that only carries the robot's own dynamics.

Eq. 3.26 splits the motors' torque τ_R in two: what moves the robot itself (its inertia,
Coriolis terms, cable stiffness and friction, the left-hand side) and J_Rᵀ F_I, what
reaches the patient's hand through the handle (eq. 3.34's τ_Subject). Only the second is
help: a motor torque that carries the robot's own friction and mass moves nothing of the
patient. Every mode compensates some of the robot's own dynamics from its model, each a
share of each term (core.control.transparent's law):

    τ_own = c_m (M̂_R θ̈̂ + Ĉ_R θ̇̂) + c_f f̂(θ̇̂) + c_k K̂_R (θ − θ_R0)

* `thesis` (the tracking SMC or CT-PID of Fig. 3.6, with its reduce-only cut): the tracker
  carries the robot's whole model, c_m = c_f = c_k = 1, so what is left, τ_R − τ_own, is
  what eq. 3.26 says reaches the hand: the pull to the reference.
* `as-needed` (core.control.guidance, law 7): the cables' stiffness in full and the share
  `friction_compensation` of the friction, no inertia; the rest is the channel's and the
  help's J_Rᵀ (F_n + F_t ĥ), the pull toward the path and along it.
* `transparent`: its own shares (`inertia`, `friction`, `stiffness`); the motors give
  nothing else, so no help (τ_R − τ_own is only what the safety supervisor took off).

θ, θ̇̂ and θ̈̂ are the recorded `robot_angle`, `robot_rate` and `robot_acceleration`: the
measured angles and the same rate tracker's estimates the controllers used, so τ_own is
what the mode computed, recomputed from the trial's file (old files too) on the model
the trial ran (RobotModel, device.loop.plan).
"""

from __future__ import annotations

from functools import cache

import numpy as np

from core.control.gains import built
from core.control.transparent import (
    TC_FRICTION,
    TC_INERTIA,
    TC_SIZE,
    TC_STIFFNESS,
    transparent_torques,
)
from core.kernels import ARRAYS

WHOLE_MODEL = (1.0, 1.0, 1.0)
"""(inertia, friction, stiffness) shares of a tracker that carries the robot's whole model."""


@cache  # the live view asks at every batch; the gains line parses the same each time
def own_shares(assist: str, gains: str) -> tuple[float, float, float]:
    """(c_m, c_f, c_k), the shares of the robot's inertia, friction and stiffness the
    trial's mode (`TrialParameters.assist`) compensated, with its gains line."""
    if assist == "transparent":
        shares = built("transparent", gains)
        return (shares.inertia, shares.friction, shares.stiffness)
    if assist == "as-needed":
        return (0.0, built("guidance", gains).friction_compensation, 1.0)
    return WHOLE_MODEL


def own_torque(robot_constants, shares, angle_rad, rate_rad_s, acceleration_rad_s2):
    """τ_own (N, 2; N·m) of the module notes for the samples' angles, rates and
    accelerations (N, 2 each), on the robot model's constants (RobotModel.constants)."""
    x = [0.0] * TC_SIZE
    x[TC_INERTIA], x[TC_FRICTION], x[TC_STIFFNESS] = shares
    q = np.asarray(angle_rad, dtype=float)
    qd = np.asarray(rate_rad_s, dtype=float)
    qdd = np.asarray(acceleration_rad_s2, dtype=float)
    tau1, tau2 = ARRAYS.of(transparent_torques)(
        robot_constants, x, q[:, 0], q[:, 1], qd[:, 0], qd[:, 1], qdd[:, 0], qdd[:, 1])
    return np.column_stack((np.broadcast_to(tau1, len(q)), np.broadcast_to(tau2, len(q))))
