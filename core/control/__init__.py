"""Joint-torque controllers for the 2 ms loop, the performance-based assistance and the
as-needed guidance.

* `base`: the `Controller` protocol every controller offers the loop, and
  `make_controller(name, model, ...)` for the names a trial may choose.
* `smc`: sliding-mode tracking control (the thesis's controller, section 3.6); the
  law is the kernel `smc_torques`.
* `ctpid`: computed-torque PID, eq. 4.1–4.8 (section 4.2); the kernels
  `ctpid_acceleration`, `ctpid_limit` and, on a RobotModel, `ctpid_torques`.
* `assistance`: the performance-based scheme of section 3.5 / Fig. 3.6,
  applied to a controller's torques (reduce only): the `thesis` assistance mode; the
  kernels `cone_test` and `assisted_torques`.
* `guidance`: the `as-needed` mode: a compliant channel whose reference moves with the
  patient, help along the path the patient earns back, a feedforward learned over the
  repetitions with forgetting; the kernel `guidance_command`, its gains `GuidanceGains`.
* `hold`: the robot holding the hand still or moving it in the assessment tasks it leads
  (isometric strength, position sense; core.holdtasks): the computed-torque PID with the
  hold's gains, what the drives can hold along a direction, the held windows and the
  take-over from where the patient left the hand (the kernels `held_at`, `taken_over`).

The laws are kernels (core.kernels): the classes validate their parameters, hold them
as constants vectors, and their `step` (the assistance's `apply`) runs the kernels
interpreted. The loop's pipeline (device.loop.pipeline) runs the same kernels on those
vectors, compiled in the loop process and in headless runs, and a controller the
kernels do not know through its own `step`.
"""

from core.control.assistance import DEFAULT_MIN_FORCE_N, PerformanceAssistance
from core.control.base import (
    CONTROLLER_NAMES,
    LOOP_PERIOD_S,
    Controller,
    InverseDynamicsModel,
    make_controller,
)
from core.control.ctpid import ComputedTorquePID, CTPIDGains
from core.control.guidance import GuidanceGains
from core.control.smc import SlidingModeController, SMCGains

__all__ = [
    "CONTROLLER_NAMES",
    "DEFAULT_MIN_FORCE_N",
    "LOOP_PERIOD_S",
    "CTPIDGains",
    "ComputedTorquePID",
    "Controller",
    "GuidanceGains",
    "InverseDynamicsModel",
    "PerformanceAssistance",
    "SMCGains",
    "SlidingModeController",
    "make_controller",
]
