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

from typing import NamedTuple, Protocol, runtime_checkable

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
