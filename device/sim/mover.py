"""A virtual patient who moves the handle round a circle at a set speed, and the force the
hand feels doing it: how transparency is measured (bench/transparency.py, the transparent
mode's tests, docs/performance.md).

The mover is the healthy virtual patient of device.sim.patients with three changes, all
through its documented options: no push along the path (`drive_N` 0: the handle is moved
by the arm's own impedance about the desired motion and its feed-forward, so a perfectly
transparent robot would feel no force at all), no trial-to-trial variation
(`variability` 0: every speed is moved the same way), and its arm's active stiffness and
damping three times a healthy subject's reaching values (MOVER_IMPEDANCE_SCALE: a firm
arm that the robot's inertia and friction slow by little, so the speed is the one set:
bench/transparency.py prints the speed the handle kept beside each figure). Its desired
motion is the trial's path at the path's pace, which it follows with its own torques: the
robot does not move it (in the transparent mode the robot adds no guidance; motors off it
adds nothing).

The path is a circle run at constant speed (`circle_at_speed`): the speed is the same at
every point, so one figure per speed means something; a circle's radius sets the hand's
acceleration toward its centre, v²/r, which is what the robot's inertia resists. The felt
force (`felt_force`) is what the handle's force sensor read (the record's `force`, N,
the global frame: the sensor's noise and quantisation included, as a therapist's
instrument would see it) over the exercise after its first lap, where the arm has
settled into the circle: its RMS magnitude and its peak.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.trial import TrialParameters
from device.sim.patient_parameters import HEALTHY_IMPEDANCE

MOVER = "healthy"
"""The virtual patient the mover is (device.sim.patient_parameters.PATIENT_KINDS)."""
MOVER_IMPEDANCE_SCALE = 3.0
MOVER_OPTIONS = {
    "drive_N": 0.0,
    "variability": 0.0,
    "stiffness_Nm_rad": tuple(MOVER_IMPEDANCE_SCALE * v
                              for v in HEALTHY_IMPEDANCE.stiffness_Nm_rad),
    "damping_Nms_rad": tuple(MOVER_IMPEDANCE_SCALE * v for v in HEALTHY_IMPEDANCE.damping_Nms_rad),
}
"""`make_patient` options of the mover (the module notes)."""
CIRCLE_RADIUS_M = 0.08
"""The circle's radius: 0.5 m/s round it is a lap of 1.005 s, within the shortest
traversal a trial allows (1 s), and 3.1 m/s² toward its centre."""
LAPS = 3
"""Laps per trial: the first settles, the rest are measured."""
EXERCISE = 2  # the record's phase code of the exercise (device.loop.pipeline)


def circle_at_speed(base: TrialParameters, speed_m_s: float,
                    radius_m: float = CIRCLE_RADIUS_M, laps: int = LAPS) -> TrialParameters:
    """`base` (its subject, mode, gains, controller) on a circle about its centre run at
    `speed_m_s` (constant speed, `laps` laps)."""
    lap_s = 2.0 * math.pi * radius_m / speed_m_s
    # a hair longer, so that the path's peak speed is not read as a rounding over the
    # trial's limit (core.trial_check.MAX_PATH_SPEED_M_S)
    return base.replace(shape="circle", radius_m=radius_m, duration_s=lap_s * (1.0 + 1e-9),
                        repetitions=laps, timing="constant_speed")


@dataclass(frozen=True, slots=True)
class FeltForce:
    """The force the hand felt over the measured laps: RMS and peak magnitude (N), and the
    handle's mean speed over them (m/s)."""

    rms_N: float
    peak_N: float
    speed_m_s: float


def felt_force(records: np.ndarray, parameters: TrialParameters) -> FeltForce:
    """The felt force of a trial's records (device.recording.record.RECORD_DTYPE) on the
    circle of `parameters` (`circle_at_speed`) over its exercise after the first lap (the
    module notes). The speed is the angle the handle swept round the circle's centre times
    its mean distance from it, per second: the pace along the circle, which the encoders'
    quantisation does not inflate as a sum of tick-to-tick steps would."""
    lap_s = parameters.duration_s
    exercise = np.flatnonzero(records["phase"] == EXERCISE)
    if exercise.size == 0:
        raise ValueError("the records hold no exercise")
    times = records["time"][exercise]
    kept = exercise[times - times[0] >= lap_s]
    if kept.size < 2:
        raise ValueError("the records hold no exercise after its first lap")
    force = np.hypot(records["force"][kept, 0], records["force"][kept, 1])
    dx = records["position"][kept, 0] - parameters.centre_m[0]
    dy = records["position"][kept, 1] - parameters.centre_m[1]
    swept = abs(float(np.unwrap(np.arctan2(dy, dx))[-1] - math.atan2(dy[0], dx[0])))
    duration = float(records["time"][kept[-1]] - records["time"][kept[0]])
    return FeltForce(float(np.sqrt(np.mean(force ** 2))), float(force.max()),
                     swept * float(np.mean(np.hypot(dx, dy))) / duration)
