"""Which backend the loop drives: built inside the loop process from a BackendConfig at
Connect (a simulator with its virtual patient, or the Quanser hardware with its settings
file, either perhaps wrapped in fault injection), and what the supervisor takes from it.
"""

from __future__ import annotations

import time

from core.trial import TrialParameters
from device.backend import SIMULATED, TIMINGS, Backend
from device.errors import BackendError
from device.loop.messages import BackendConfig
from device.loop.pipeline import TrialPlan
from device.safety.limits import SafetyLimits


def make_backend(config: BackendConfig, params: TrialParameters, plan: TrialPlan,
                 sleep=time.sleep, compiled: bool = True) -> Backend:
    """The backend a BackendConfig names, built inside the loop process. `sleep` is how a
    fault-injected slow read waits (the loop's clock's); `compiled` runs a simulator's
    physics compiled (else interpreted, as LoopConfig(compiled=False) asks)."""
    if config.timing not in (None, *TIMINGS):
        raise BackendError(f"unknown timing {config.timing!r}; use {' or '.join(TIMINGS)}")
    if config.kind == "simulator":
        from device.sim.seeds import draw_seed
        from device.sim.simulator import SimulatorBackend

        # the loop draws the trial's seed itself, to name it (BackendConfig.seed None)
        seed = draw_seed() if config.seed is None else config.seed
        backend: Backend = SimulatorBackend.from_trial(
            params, config.patient, seed=seed, robot=plan.robot, patient_waits=True,
            timing=config.timing or SIMULATED, compiled=compiled, plant=config.plant,
            robot_seed=config.robot_seed,
            push_at_connect_N=config.push_at_connect_N,
        )
    elif config.kind == "quanser":
        if config.timing == SIMULATED:
            raise BackendError("the real robot moves on the wall clock; simulated timing "
                               "is only for the simulator")
        from device.hardware.quanser import QuanserBackend
        from device.hardware.settings import load_hardware_settings

        if not config.hardware_settings:
            raise BackendError("the hardware backend needs its settings file "
                               "(docs/hardware.md); choose it in the Parameters tab")
        settings = load_hardware_settings(config.hardware_settings)
        backend = QuanserBackend(settings, plan.robot.motors)
    else:
        raise BackendError(f"unknown backend {config.kind!r}; use simulator or quanser")
    if config.fault_scenario:
        from device.sim.faultinjection import FaultInjectingBackend

        backend = FaultInjectingBackend(backend, config.fault_scenario, at_s=config.fault_at_s,
                                        sleep=sleep, **dict(config.fault_options))
    return backend


SIMULATED_HEARTBEAT_TIMEOUT_S = 5.0
"""The heartbeat limit on a simulated robot. A console that dies is seen at once, through
its pipe closing; what the 0.5 s limit adds is a window that hangs. On a shared clinic PC
the window's thread is held for more than 0.5 s now and then (seen at 0.54–0.57 s under
load), and on the simulator that must not end a trial: no one is driven by it. The real
robot keeps 0.5 s (SafetyLimits), as it keeps the late-tick watchdog."""


def limits_for_backend(limits: SafetyLimits, backend: Backend) -> SafetyLimits:
    """The supervisor's limits for `backend`: the force sensor's rated range where the
    backend knows it from the sensor's calibration (the hardware backend, once open); the
    simulated robot's heartbeat limit on SIMULATED timing."""
    if backend.timing == SIMULATED:
        limits = limits.replace(heartbeat_timeout_s=max(limits.heartbeat_timeout_s,
                                                        SIMULATED_HEARTBEAT_TIMEOUT_S))
    inner = getattr(backend, "inner", backend)  # under a FaultInjectingBackend
    rated = getattr(inner, "force_sensor_range_N", None)
    if rated is None:
        return limits
    return limits.for_sensor(*rated)
