"""The one interface every joint-torque controller offers the 2 ms loop, and its factory.

Every controller offers, once per tick,

    tau1, tau2 = controller.step(dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2)

with the measured joint angles and rates (θ_R, θ̇_R; rad, rad/s) and the
reference joint angle, rate and acceleration (θ_d, θ̇_d, θ̈_d; rad, rad/s,
rad/s²) from `Trajectory.joint_reference` (eq. 3.1, 3.4, 3.5), all plain floats.
It returns the joint torques τ_R (N·m) the motors should apply, already limited
to the controller's `torque_limit_Nm`. `dt_s` is the time since the previous
tick (the loop's pipeline passes its nominal period, 0.002 s) and only integrating
controllers use it. `reset()` forgets any internal state (an integral), for a new trial or
after the safety supervisor has held the robot in its safe state.

The loop's pipeline (device.loop.pipeline) runs the two controllers here, on a
RobotModel, through their kernels on the controller's `constants` (the law their `step`
runs); any other controller, such as the computed-torque PID on a learned model, it runs
interpreted through `step`.

Why plain floats: a call through numpy costs ~1 µs per operation on scalars,
so a controller written with numpy spends more time dispatching than computing.
Every controller here keeps its per-tick work to float arithmetic and `math`,
and allocates nothing but its small result tuples.

The controller's order in the tick is fixed by the thesis's scheme (Fig. 3.6):
controller → performance-based assistance (`core.control.assistance`, which can
only reduce the torque) → safety supervisor → motors.
"""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

from core.errors import ParameterError, check_positive

CONTROLLER_NAMES = ("smc", "ctpid")
"""Names `make_controller` accepts (the `controller` field of a trial)."""

LOOP_PERIOD_S = 0.002
"""The control loop's nominal period; gains are chosen for it."""


@runtime_checkable
class Controller(Protocol):
    """A joint-space tracking controller run once per tick of the 2 ms loop."""

    name: str

    def reset(self) -> None:
        """Forget internal state (integrals) before a trial or after a safe stop."""
        ...

    def step(
        self,
        dt_s: float,
        q1: float,
        q2: float,
        qd1: float,
        qd2: float,
        r1: float,
        r2: float,
        rd1: float,
        rd2: float,
        rdd1: float,
        rdd2: float,
    ) -> tuple[float, float]:
        """Joint torques (N·m) for the measured state and the reference of this tick."""
        ...


@runtime_checkable
class InverseDynamicsModel(Protocol):
    """Anything that maps (θ, θ̇, θ̈) to the joint torques that produce them (eq. 3.6).

    `core.robot.RobotModel` is one; a learned model (chapter 4) with the same
    method plugs into the computed-torque controller unchanged.
    """

    def inverse_dynamics_terms(self, q1, q2, qd1, qd2, qdd1, qdd2, fx=0.0, fy=0.0): ...


def check_torque_limit(torque_limit_Nm) -> tuple[float, float]:
    """Validate a per-joint output limit (N·m) and return it as two floats."""
    try:
        first, second = torque_limit_Nm
    except (TypeError, ValueError):
        raise ParameterError(
            "torque_limit_Nm", torque_limit_Nm, "a pair (joint 1, joint 2) in N·m"
        ) from None
    return (
        check_positive("torque_limit_Nm[0]", first, "N·m", "the largest torque joint 1 may get"),
        check_positive("torque_limit_Nm[1]", second, "N·m", "the largest torque joint 2 may get"),
    )


def check_pair(
    field: str, value, unit: str, low: float, high: float, why: str, *, low_open: bool
) -> tuple[float, float]:
    """Validate a per-joint gain pair against [low, high] (or (low, high]) by name."""
    try:
        first, second = value
    except (TypeError, ValueError):
        raise ParameterError(field, value, f"a pair (joint 1, joint 2) in {unit}") from None
    out = []
    for i, number in enumerate((first, second)):
        name = f"{field}[{i}]"
        try:
            x = float(number)
        except (TypeError, ValueError):
            raise ParameterError(name, number, f"a finite number in {unit}") from None
        below = x <= low if low_open else x < low
        if not math.isfinite(x) or below or x > high:
            bracket = "(" if low_open else "["
            raise ParameterError(name, x, f"{bracket}{low:g}, {high:g}] {unit}", why)
        out.append(x)
    return (out[0], out[1])


def make_controller(
    name: str,
    model,
    *,
    torque_limit_Nm: tuple[float, float] | None = None,
    gains=None,
) -> Controller:
    """Build the controller called `name` ("smc" or "ctpid") on a dynamics `model`.

    `torque_limit_Nm` defaults to the model's drive limit
    (`model.max_joint_torque_Nm`, 2.21 N·m per joint for the thesis robot).
    `gains` defaults to the controller's tuned defaults and must be that
    controller's gain type (`SMCGains` or `CTPIDGains`).
    """
    # Imported here because both modules build on this one.
    from core.control.ctpid import ComputedTorquePID, CTPIDGains
    from core.control.smc import SlidingModeController, SMCGains

    kinds = {
        "smc": (SlidingModeController, SMCGains),
        "ctpid": (ComputedTorquePID, CTPIDGains),
    }
    if name not in kinds:
        raise ParameterError(
            "controller", name, "one of " + ", ".join(CONTROLLER_NAMES),
            "unknown controller name",
        )
    cls, gains_type = kinds[name]
    if gains is None:
        gains = gains_type()
    elif not isinstance(gains, gains_type):
        raise ParameterError(
            "gains", type(gains).__name__, f"a {gains_type.__name__} for controller '{name}'"
        )
    if torque_limit_Nm is None:
        try:
            torque_limit_Nm = model.max_joint_torque_Nm
        except AttributeError:
            raise ParameterError(
                "torque_limit_Nm", None, "a pair (joint 1, joint 2) in N·m",
                f"{type(model).__name__} has no max_joint_torque_Nm to default to",
            ) from None
    return cls(model, gains, torque_limit_Nm=torque_limit_Nm)
