"""The protocol every robot backend speaks: simulator, Quanser hardware, or a fake.

    open() · read(now) -> SensorReading · write(torque1, torque2) · safe_state() · close()

`read` and `write` are called once per 2 ms tick; they must not allocate more
than a small tuple, log, or block beyond the hardware's own latency.

Every backend also says whose clock its robot lives on (`timing`):

* REAL_TIME: a real robot keeps moving while the loop stalls, with the last torque held
  and no one watching. The loop passes it the wall clock and the safety supervisor's
  late-tick watchdog guards it (device.safety.supervisor, docs/safety.md H13).
* SIMULATED: the robot exists only when the loop steps it. The loop passes it the
  nominal time (tick × period), so a tick that starts late steps it by one period like
  any other: a stall of the computer delays the simulation and pushes no one. The
  lateness is still measured, recorded and shown; it is never a fault.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np

REAL_TIME = "real"
"""A backend whose robot moves on the wall clock: the late-tick watchdog applies."""
SIMULATED = "simulated"
"""A backend the loop steps by the nominal period: lateness is recorded, never a fault."""
TIMINGS = (REAL_TIME, SIMULATED)


class SensorReading(NamedTuple):
    """One sample of the robot's sensors.

    time_s is the backend's own timestamp (hardware clock or simulated time); the
    supervisor treats a timestamp that stops advancing as stale data. Joint
    angles are the encoders' quantised readings converted to radians in the
    robot's joint convention (core.robot). Forces are the handle sensor's
    reading in its own frame (x', y' in the plane, z normal), tared at connect.
    """

    time_s: float
    q1_rad: float
    q2_rad: float
    force_x_N: float
    force_y_N: float
    force_z_N: float


@runtime_checkable
class Backend(Protocol):
    """A robot, real or simulated."""

    name: str
    timing: str
    """REAL_TIME or SIMULATED (see the module notes)."""

    def open(self) -> None:
        """Connect to the device and make it ready with zero torque. Raises BackendError."""

    def read(self, now_s: float) -> SensorReading:
        """Sample the sensors at loop time `now_s`. Raises BackendError."""

    def write(self, torque1_Nm: float, torque2_Nm: float) -> None:
        """Command joint torques (N·m at the joints). Raises BackendError."""

    def safe_state(self) -> None:
        """Zero the motor commands at once. Must not raise; called on every fault."""

    def close(self) -> None:
        """Zero the motors and release the device. Safe to call twice."""


# ------------------------------------------------------------------ the force sensor's zero
TARE_SPREAD_LIMIT_N = 0.18
"""How much the in-plane force may move (RMS about its mean) while the handle's force sensor
takes its zero at Connect: three times the noise of a still Nano25 in the plane (one count,
1/24 N, per axis: √2/24 ≈ 0.06 N; Table 3.1). A hand on the handle moves more than that
(a grip settling, physiological tremor), and a zero taken under it would read its push as
the patient's every tick after (docs/hardware.md, Tare)."""


@dataclass(frozen=True, slots=True)
class Tare:
    """How the force sensor's zero went at Connect: how long it averaged, how much the
    force in the plane moved meanwhile (RMS about its mean, N) and the limit it was held to."""

    duration_s: float
    spread_N: float
    limit_N: float

    @property
    def under_load(self) -> bool:
        return not self.spread_N <= self.limit_N

    def refusal(self) -> str:
        """One line for the therapist when the zero was taken under load, else ''."""
        if not self.under_load:
            return ""
        return (f"the force sensor's zero was taken with a force on the handle: the force "
                f"moved by {self.spread_N:.2f} N during the {self.duration_s:g} s zero at "
                f"Connect, beyond the sensor's noise ({self.limit_N:.2f} N). Take the hands "
                "off the handle and connect again")


def tare_of(force_x_N, force_y_N, duration_s: float, limit_N: float) -> Tare:
    """The Tare of the in-plane forces a sensor read during its zero (any frame turning
    with the plane: the spread does not depend on it)."""
    fx = np.asarray(force_x_N, dtype=float)
    fy = np.asarray(force_y_N, dtype=float)
    if not fx.size:
        return Tare(duration_s, math.nan, limit_N)
    spread = math.sqrt(float(np.mean((fx - fx.mean()) ** 2 + (fy - fy.mean()) ** 2)))
    return Tare(duration_s, spread, limit_N)
