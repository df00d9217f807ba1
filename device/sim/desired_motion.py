"""A virtual patient's plan for one traversal of the path: the desired arm motion, the
feed-forward torque that makes it and the push along the path, tabulated every
TABLE_STEP_S for the torque kernel (device.sim.patient_torque) to interpolate, and the
first-order lag that turns the path's direction into the push (device.sim.patients'
module notes, effort).

Numpy only, and not scipy.signal: the loop process builds the table at Connect
(`_first_order_filter`).
"""

from __future__ import annotations

import math

import numpy as np

from core.arm import ArmModel
from core.arrays import joint_motion
from core.trajectory import Trajectory
from device.sim.patient_parameters import DRIVE_N, JointImpedance
from device.sim.patient_torque import TABLE_STEP_S, passive_tissue

DRIVE_LAG_S = 0.15
"""Time constant of the push's direction (activation and anticipation)."""


def passive_torque_terms(passive: JointImpedance, rest_rad, ts, phi, tsd, phid):
    """Generalised torques τ_A (absolute-angle convention) of passive tissue about the
    joint-coordinate rest posture `rest_rad` = (θ_s, φ), φ = θ_e − θ_s. Floats or arrays."""
    sh, el = passive_tissue(*passive.stiffness_Nm_rad, *passive.damping_Nms_rad,
                            rest_rad[0] - ts, rest_rad[1] - phi, tsd, phid)
    return (sh - el, el)


def desired_motion_table(
    arm: ArmModel, trajectory: Trajectory, passive: JointImpedance, rest_rad,
    drive_N: float = DRIVE_N, synergy: float = 0.0,
) -> np.ndarray:
    """The desired arm motion, its feed-forward torque and the push along the path for
    one traversal, every TABLE_STEP_S: rows of eight values (θ_s, φ, θ̇_s, φ̇,
    τ_ff,s, τ_ff,e, push F_x, F_y), their increments to the next row (for linear
    interpolation), and the direction (x, y).

    The push is `drive_N` along the path's direction passed through a first-order
    lag of DRIVE_LAG_S, run over two traversals so the table holds its periodic
    steady state (a repetition starts where the last one ended).

    The feed-forward is the arm's inverse dynamics along the desired motion less the
    passive tissue's torque there: a subject's command also overcomes their own
    tissue, or a healthy arm would lag the path by the passive torque over the
    active stiffness (about 2 cm on the thesis's D).

    With a `synergy` σ the plan's joints do not move apart: the elbow's angle moves by σ
    times the shoulder's change from the traversal's start, on top of what the path
    asks (its rates and accelerations likewise), so the arm's own plan strays from the
    path as a paretic arm's does (device.sim.patients' module notes, weak)."""
    n = max(1, math.ceil(trajectory.duration_s / TABLE_STEP_S))
    sample = trajectory.sample(np.arange(n + 1) * TABLE_STEP_S)
    # eq. 3.16 inverted (the anatomical branch), 3.18, 3.19
    theta, theta_dot, theta_ddot = joint_motion(arm, sample.position_m, sample.velocity_m_s,
                                                sample.acceleration_m_s2)
    if synergy:
        theta[:, 1] += synergy * (theta[:, 0] - theta[0, 0])
        theta_dot[:, 1] += synergy * theta_dot[:, 0]
        theta_ddot[:, 1] += synergy * theta_ddot[:, 0]
    feedforward = arm.inverse_dynamics(theta, theta_dot, theta_ddot)  # eq. 3.20
    phi = theta[:, 1] - theta[:, 0]
    phi_dot = theta_dot[:, 1] - theta_dot[:, 0]
    tissue_s, tissue_e = passive_torque_terms(
        passive, rest_rad, theta[:, 0], phi, theta_dot[:, 0], phi_dot
    )
    push = drive_N * _lagged(sample.direction, TABLE_STEP_S, DRIVE_LAG_S)
    values = np.column_stack((
        theta[:, 0], phi, theta_dot[:, 0], phi_dot,
        feedforward[:, 0] - tissue_s, feedforward[:, 1] - tissue_e, push,
    ))
    return np.column_stack((values[:-1], np.diff(values, axis=0), sample.direction[:-1]))


def _lagged(direction: np.ndarray, dt_s: float, lag_s: float) -> np.ndarray:
    """A first-order lag of a periodic (N, 2) signal, in its periodic steady state."""
    a = math.exp(-dt_s / lag_s)
    doubled = np.vstack((direction, direction))
    # y[i] = a·y[i−1] + (1 − a)·x[i] from y[−1] = x[0], run over two periods
    return _first_order_filter(doubled, a)[len(direction):]


def _first_order_filter(x: np.ndarray, a: float) -> np.ndarray:
    """scipy.signal.lfilter([1 − a], [1, −a], x, axis=0, zi=a·x[0]) of an (N, k) array,
    bit for bit: its products and sums in its order (y = z + b0·x; z = b1·x − a1·y with
    b1 = 0, a1 = −a), signed zeros included (tests/device/test_patients.py holds them
    equal). Not lfilter itself: importing scipy.signal (it imports scipy.stats) took
    1.5-6 s of the loop process's start, every Connect's wait, for a filter this loop
    runs in a few milliseconds (4 ms for a 4 s lap's table; lfilter 0.2 ms)."""
    b0, a1 = 1.0 - a, -a
    out = np.empty_like(x, dtype=float)
    for j in range(x.shape[1]):
        column = x[:, j]
        z = float(a * column[0])
        ys: list[float] = []
        append = ys.append
        for p, q in zip((b0 * column).tolist(), (0.0 * column).tolist(), strict=True):
            y = z + p
            append(y)
            z = q - a1 * y
        out[:, j] = ys
    return out

