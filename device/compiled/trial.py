"""A headless trial's ticks, compiled: simulator → pipeline → supervisor → record.

`run` takes the very objects a Python headless run uses (the SimulatorBackend, the
TickPipeline and the SafetySupervisor), reads their constants, runs every tick in
one compiled loop and returns the records, identical to what the Python loop of
app.trials.headless would have produced. It returns an `Abandoned` (the tick and the
reason) when the configuration has no compiled form (`unsupported` says why) or when
a tick leaves the ordinary: a safety check trips, the simulated arm goes straight,
the force sensor saturates. The caller then runs the trial in Python from the start
(open and begin reset the objects), which replays it deterministically and reports
the event exactly.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from device.compiled import control as ctl
from device.compiled import dynamics as dyn
from device.compiled import guard
from device.compiled.jit import kernel
from device.loop.states import State
from device.recording.record import RECORD_DTYPE
from device.sim.patients import VirtualPatient

TRIPPED = 10  # beyond the simulator's own failure codes (device.compiled.dynamics)
_RUNNING = int(State.RUNNING)
_CHUNKS = 100  # progress is reported this many times per trial


@dataclass(frozen=True, slots=True)
class Abandoned:
    """Why a compiled run handed the trial back: the tick and what happened there."""

    tick: int
    reason: str


def unsupported(backend, pipeline, supervisor, *, patient_may_wait: bool = False) -> str:
    """Why this trial cannot run compiled, or '' when it can. A headless run needs a
    patient who starts at once; the live loop cues its patient (patient_may_wait)."""
    from device.sim.simulator import SimulatorBackend  # the simulator imports nothing from here

    if type(backend) is not SimulatorBackend:
        return f"the backend is a {type(backend).__name__}, not the simulator"
    if backend.integrator != "semi_implicit_euler" or backend.dynamics != "fused":
        return f"the simulator runs {backend.integrator} with {backend.dynamics} dynamics"
    if backend.patient_waits and not patient_may_wait:
        return "the simulated patient waits for a cue"
    if type(backend.patient) is not VirtualPatient:
        return f"the patient is a {type(backend.patient).__name__}, not a VirtualPatient"
    if backend.robot is not pipeline.robot or supervisor.robot is not pipeline.robot:
        return "the simulator, the pipeline and the supervisor use different robot models"
    return ctl.unsupported_controller(pipeline)


def run(backend, pipeline, supervisor,
        progress: Callable[[float], None] | None = None) -> np.ndarray | Abandoned:
    """Every tick of the trial, compiled. Returns the records (subject channels NaN,
    as the Python loop leaves them for fill_subject_channels) or why it gave up."""
    reason = unsupported(backend, pipeline, supervisor)
    if reason:
        return Abandoned(0, reason)
    sc = dyn.simulator_constants(backend)
    p, table, episodes = dyn.patient_arrays(backend.patient)
    period = pipeline.period_s
    q1_0, q2_0 = backend.start_angles_rad
    # The Python run's first reading decides the approach; take it the same way.
    noise_rng = backend.noise_generator()
    x = np.zeros(dyn.X_SIZE)
    noise = noise_rng.standard_normal((1, 3))
    status = dyn.reset(sc, p, table, episodes, q1_0, q2_0, noise, x)
    if status != dyn.OK:
        return Abandoned(0, _REASONS[status])
    q1, q2 = x[dyn.X_READING + 1], x[dyn.X_READING + 2]
    pipeline.begin(q1, q2)
    rows = pipeline.reference_rows
    total = pipeline.total_ticks
    # ticks advance the simulator once each: one noise triple per tick, and a spare
    noise = np.vstack((noise, noise_rng.standard_normal((total + 1, 3))))
    kc = ctl.controller_constants(pipeline)
    z = ctl.initial_state(pipeline, q1, q2)
    gc = guard.supervisor_constants(supervisor)
    w = guard.initial_state()
    c = np.zeros(ctl.C_SIZE)
    scratch = np.zeros(15)
    out = np.empty(total, dtype=RECORD_DTYPE)
    step = max(1, -(-total // _CHUNKS))
    for k0 in range(0, total, step):
        if progress is not None:
            progress(k0 / total)
        done, status = run_ticks(
            k0, min(total, k0 + step), period, rows, pipeline.approach_ticks,
            sc, p, table, episodes, x, noise, kc, z, gc, w, c, scratch, out,
        )
        if status != dyn.OK:
            return Abandoned(int(done), _REASONS[status])
    return out


_REASONS = {
    dyn.ARM_STRAIGHT: "the simulated arm went straight",
    dyn.NOT_FINITE: "the simulation's state became non-finite",
    dyn.SENSOR_RANGE: "the force sensor read beyond its range",
    dyn.NO_NOISE: "the sensor noise ran out",
    TRIPPED: "a safety check tripped",
}


@kernel
def run_ticks(k0, k1, period, rows, approach_ticks, sc, p, table, episodes, x, noise,
              kc, z, gc, w, c, scratch, out):
    """Ticks k0..k1−1 of app.trials.headless.simulate's loop: (next tick, status)."""
    nan = math.nan
    for k in range(k0, k1):
        now = k * period
        if k:
            status = dyn.read(sc, p, table, episodes, x, now, noise, scratch)
            if status != dyn.OK:
                return k, status
        r = dyn.X_READING
        t = x[r]
        q1 = x[r + 1]
        q2 = x[r + 2]
        fxs = x[r + 3]
        fys = x[r + 4]
        fzs = x[r + 5]
        ctl.control(kc, z, k, rows, approach_ticks, q1, q2, fxs, fys, c)
        out1, out2, tripped = guard.check(gc, w, now, t, q1, q2, fxs, fys, fzs,
                                          c[ctl.C_QD1], c[ctl.C_QD2],
                                          c[ctl.C_OUT1], c[ctl.C_OUT2], 0.0, 0.0, False,
                                          False)
        if tripped != guard.CLEAR:
            return k, TRIPPED
        dyn.write(sc, x, out1, out2)
        o = out[k]
        o["tick"] = k
        o["time"] = k * period
        o["wall_time"] = now
        o["phase"] = int(c[ctl.C_PHASE])
        o["lateness"] = 0.0
        o["compute_time"] = 0.0
        o["robot_angle"][0] = q1
        o["robot_angle"][1] = q2
        o["robot_rate"][0] = c[ctl.C_QD1]
        o["robot_rate"][1] = c[ctl.C_QD2]
        o["robot_acceleration"][0] = c[ctl.C_QDD1]
        o["robot_acceleration"][1] = c[ctl.C_QDD2]
        o["robot_angle_desired"][0] = c[ctl.C_R1]
        o["robot_angle_desired"][1] = c[ctl.C_R2]
        o["robot_rate_desired"][0] = c[ctl.C_RD1]
        o["robot_rate_desired"][1] = c[ctl.C_RD2]
        o["robot_acceleration_desired"][0] = c[ctl.C_RDD1]
        o["robot_acceleration_desired"][1] = c[ctl.C_RDD2]
        o["torque_controller"][0] = c[ctl.C_TAU1]
        o["torque_controller"][1] = c[ctl.C_TAU2]
        o["torque_commanded"][0] = c[ctl.C_OUT1]
        o["torque_commanded"][1] = c[ctl.C_OUT2]
        o["torque_applied"][0] = out1
        o["torque_applied"][1] = out2
        o["position"][0] = sc[dyn.S_L2] * math.cos(q2) + sc[dyn.S_L4] * math.cos(q1)
        o["position"][1] = sc[dyn.S_L2] * math.sin(q2) + sc[dyn.S_L4] * math.sin(q1)
        o["position_desired"][0] = c[ctl.C_XD]
        o["position_desired"][1] = c[ctl.C_YD]
        o["velocity_desired"][0] = c[ctl.C_VXD]
        o["velocity_desired"][1] = c[ctl.C_VYD]
        o["direction_desired"][0] = c[ctl.C_DX]
        o["direction_desired"][1] = c[ctl.C_DY]
        o["force_sensor"][0] = fxs
        o["force_sensor"][1] = fys
        o["force_sensor"][2] = fzs
        o["force"][0] = c[ctl.C_FX]
        o["force"][1] = c[ctl.C_FY]
        o["force_angle"] = c[ctl.C_ANGLE]
        o["assistance_active"] = int(c[ctl.C_ACTIVE])
        # the subject's channels are filled afterwards for the whole trial, vectorised
        for j in range(2):
            o["subject_angle"][j] = nan
            o["subject_rate"][j] = nan
            o["subject_acceleration"][j] = nan
            o["subject_torque"][j] = nan
            o["subject_angle_isb"][j] = nan
        o["singular"] = 0
        o["state"] = _RUNNING
        o["fault"] = 0
    return k1, dyn.OK
