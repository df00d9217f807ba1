"""The tick engine: a connection's ticks, and a headless trial's, written once.

Each tick, in the order of the thesis's scheme (Fig. 3.6): the backend's sensors →
(while a trial runs) rate estimate → reference → controller → performance-based
assistance (device.loop.pipeline.control) → safety supervisor (device.safety.checks) →
the backend's motors → the record. Everything between the sensors and the motors is
one kernel, `supervised_command` (core.kernels), run compiled by numba or interpreted:
the same code either way, so the same numbers.

* `TickEngine.step` runs one tick of the live loop: the backend's `read` and `write`
  (the simulator's own kernels, or a vendor's API) around the compiled kernel.
* `run_ticks` runs a headless trial's ticks on the simulator in one call, the
  simulator's physics included (compiled: about a thousand times real time), and
  `run_trial` turns them into the trial's records and events.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.lib.recfunctions import unstructured_to_structured

from core.interaction import SubjectState
from core.kernels import interpreted, kernel
from device.backend import SensorReading
from device.errors import BackendError
from device.loop.pipeline import (
    C_OUT1,
    C_OUT2,
    C_QD1,
    C_QD2,
    C_SIZE,
    TickPipeline,
    control,
    idle_record,
    record_values,
)
from device.loop.states import State
from device.recording.record import RECORD_DTYPE
from device.safety.checks import W_FAULT, supervise
from device.safety.faults import Fault
from device.safety.supervisor import SafetySupervisor
from device.sim import physics
from device.sim.physics import X_READING, read, write

FAULT_LATCHED = 10
"""`run_ticks` stopped because the supervisor latched a fault (beyond the simulator's own
failure codes, device.sim.physics)."""

# One headless tick's row in `run_ticks`' output: the reading, what `control` left, the
# torques written and the fault code.
ROW_READING = 0
ROW_LAST = ROW_READING + 6
ROW_APPLIED = ROW_LAST + C_SIZE
ROW_FAULT = ROW_APPLIED + 2
ROW_SIZE = ROW_FAULT + 1
_CHUNKS = 100  # a headless run reports its progress this many times


@kernel
def supervised_command(kind, robot, model, tracker, gains, assist, rates, integral, tick,
                       rows, approach_ticks, period_s, sensor_offset_rad, last, g, w, now_s,
                       t, q1, q2, fx, fy, fz, lateness_s, heartbeat_age_s, estop,
                       recording_lost):
    """A running tick between the sensors and the motors: the pipeline's command
    (writes `last`) through the supervisor: (torque1, torque2, fault) to write."""
    control(kind, robot, model, tracker, gains, assist, rates, integral, tick, rows,
            approach_ticks, period_s, sensor_offset_rad, q1, q2, fx, fy, last)
    return supervise(robot, g, w, now_s, t, q1, q2, fx, fy, fz, last[C_QD1], last[C_QD2],
                     last[C_OUT1], last[C_OUT2], lateness_s, heartbeat_age_s, estop,
                     recording_lost, 0)


@dataclass(frozen=True, slots=True)
class Tick:
    """What one tick did: the torques written, the latched fault, the sensor reading (or
    the exception the read raised) and the compute time from the read to the write."""

    torque1_Nm: float
    torque2_Nm: float
    fault: Fault
    reading: SensorReading | BaseException
    compute_s: float


class TickEngine:
    """One connection's tick: the backend, the trial's pipeline and the supervisor.

    `compiled` runs `supervised_command` and `supervise` compiled, which needs the
    pipeline built with `compiled=True` (its vectors are then float arrays); otherwise
    both run interpreted. The objects keep their state: the engine only runs the
    kernels on their vectors.
    """

    def __init__(self, backend, pipeline: TickPipeline, supervisor: SafetySupervisor) -> None:
        self.backend = backend
        self.pipeline = pipeline
        self.supervisor = supervisor
        self.compiled = pipeline.compiled
        if self.compiled:
            from device.compiled.jit import compiled  # numba only in the loop process

            self._command = compiled(supervised_command)
            self._supervise = compiled(supervise)
        else:
            self._command = interpreted(supervised_command, pipeline.replacements)
            self._supervise = supervise
        self._robot = (np.asarray(supervisor.robot.constants, dtype=float) if self.compiled
                       else supervisor.robot.constants)

    def step(self, tick: int | None, now_s: float, lateness_s: float, heartbeat_age_s: float,
             estop: bool, recording_lost: bool, clock: Callable[[], float] = time.perf_counter,
             ) -> Tick:
        """One tick at robot time `now_s`: trial tick `tick` of the pipeline, or None while
        no trial runs (zero torque; the supervisor still watches)."""
        started = clock()
        backend, sup, v = self.backend, self.supervisor, self.pipeline.vectors
        try:
            reading = backend.read(now_s)
        except BackendError as exc:
            reading = exc
        values, read_error = sup.read_values(reading)
        before = sup.state[W_FAULT]
        if tick is not None and not read_error:
            p = self.pipeline
            out1, out2, code = self._command(
                p.kind, v.robot, v.model, v.tracker, v.gains, v.assist, v.rates, v.integral,
                tick, v.rows, p.approach_ticks, p.period_s, p.sensor_offset_rad, v.last,
                sup.constants, sup.state, now_s, *values, lateness_s, heartbeat_age_s, estop,
                recording_lost)
            p.ticked()
        else:
            out1, out2, code = self._supervise(
                self._robot, sup.constants, sup.state, now_s, *values, 0.0, 0.0, 0.0, 0.0,
                lateness_s, heartbeat_age_s, estop, recording_lost, read_error)
        sup.after_tick(before)
        try:
            backend.write(out1, out2)
        except BackendError:
            backend.safe_state()
        return Tick(out1, out2, Fault(code), reading, clock() - started)

    def record(self, done: Tick, tick: int, wall_s: float, lateness_s: float, state: int,
               running: bool) -> tuple:
        """The record of a tick `step` did (flat_names order): the pipeline's while a
        trial runs, else the sensors and the subject's posture at zero torque."""
        reading = done.reading
        if running and isinstance(reading, SensorReading):
            return self.pipeline.record(tick, reading, wall_s, lateness_s, done.compute_s,
                                        (done.torque1_Nm, done.torque2_Nm), state,
                                        int(done.fault))
        if not isinstance(reading, SensorReading):
            reading = NO_READING  # a failed read still leaves its tick in the record
        p = self.pipeline
        return idle_record(p.robot, p.arm, tick, reading, wall_s, lateness_s, done.compute_s,
                           state, int(done.fault), p.period_s, p.sensor_offset_rad)


NO_READING = SensorReading(math.nan, math.nan, math.nan, math.nan, math.nan, math.nan)


# ------------------------------------------------------------------- headless
@kernel
def run_ticks(k0, k1, period_s, r, a, c, p, table, episodes, x, noise, scratch, kind, robot,
              model, tracker, gains, assist, rates, integral, rows, approach_ticks,
              sensor_offset_rad, last, g, w, out):
    """Ticks k0…k1−1 of a headless trial on the simulator (device.sim.physics' vectors
    r…scratch), at robot time k × period: each reads the sensors (tick 0 takes the
    reading made before it), runs `supervised_command` and writes the torque, and
    leaves its row (ROW_*) in out[k]. Returns (the next tick, status): the simulator's
    failure, FAULT_LATCHED after the row of the tick that latched a fault, or OK."""
    for k in range(k0, k1):
        now_s = k * period_s
        if k:
            status = read(r, a, c, p, table, episodes, x, now_s, noise, scratch)
            if status != physics.OK:
                return k, status
        t = x[X_READING]
        q1 = x[X_READING + 1]
        q2 = x[X_READING + 2]
        fx = x[X_READING + 3]
        fy = x[X_READING + 4]
        fz = x[X_READING + 5]
        out1, out2, code = supervised_command(
            kind, robot, model, tracker, gains, assist, rates, integral, k, rows,
            approach_ticks, period_s, sensor_offset_rad, last, g, w, now_s, t, q1, q2, fx, fy,
            fz, 0.0, 0.0, False, False)
        write(c, x, out1, out2)
        row = out[k]
        for j in range(6):
            row[ROW_READING + j] = x[X_READING + j]
        for j in range(C_SIZE):
            row[ROW_LAST + j] = last[j]
        row[ROW_APPLIED] = out1
        row[ROW_APPLIED + 1] = out2
        row[ROW_FAULT] = code
        if code != 0:
            return k + 1, FAULT_LATCHED
    return k1, physics.OK


@dataclass(frozen=True, slots=True)
class HeadlessOutcome:
    """A headless trial's records (subject channels still NaN: fill_subject_channels),
    its status, and the fault's message and detail when it faulted."""

    records: np.ndarray
    status: str
    fault_tick: int = -1
    fault_message: str = ""
    fault_detail: dict | None = None


def run_trial(simulator, pipeline: TickPipeline, supervisor: SafetySupervisor,
              progress: Callable[[float], None] | None = None) -> HeadlessOutcome:
    """A whole trial on `simulator` without a clock: robot time k × period, run by
    `run_ticks` in the pipeline's flavour (compiled with a compiled pipeline and
    simulator, interpreted otherwise)."""
    if pipeline.compiled != simulator.compiled:
        raise ValueError("a headless run needs the simulator and the pipeline in one flavour "
                         "(both compiled or both interpreted)")
    period = pipeline.period_s
    simulator.open()
    reading = simulator.read(0.0)
    pipeline.begin(reading.q1_rad, reading.q2_rad)
    total = pipeline.total_ticks
    simulator.top_up_noise(total + 1)  # one noise row per tick: none is drawn in the loop
    (r, a, c, p, table, episodes), flavour, scratch = simulator.physics
    if pipeline.compiled:
        ticks = flavour(run_ticks)
    else:
        ticks = interpreted(run_ticks, {**simulator.replacements, **pipeline.replacements})
    v = pipeline.vectors
    out = np.full((total, ROW_SIZE), math.nan)
    step = max(1, -(-total // _CHUNKS))
    done, status = 0, physics.OK
    try:
        while done < total and status == physics.OK:
            if progress is not None:
                progress(done / total)
            done, status = ticks(
                done, min(total, done + step), period, r, a, c, p, table, episodes,
                simulator.state, simulator.noise, scratch, pipeline.kind, v.robot, v.model,
                v.tracker, v.gains, v.assist, v.rates, v.integral, v.rows,
                pipeline.approach_ticks, pipeline.sensor_offset_rad, v.last,
                supervisor.constants, supervisor.state, out)
        if done:
            pipeline.ticked()
        if status == FAULT_LATCHED:
            supervisor.after_tick(0.0)
            return HeadlessOutcome(records_from_rows(out[:done], pipeline), "faulted", done - 1,
                                   supervisor.fault_message, supervisor.fault_detail)
        if status != physics.OK:
            # the simulator failed to read tick `done`: the supervisor turns it into its
            # fault (no record: there was no reading)
            error = simulator.failure(status, done * period)
            supervisor.step(done * period, error, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, False, False)
            return HeadlessOutcome(records_from_rows(out[:done], pipeline), "faulted", done,
                                   supervisor.fault_message, supervisor.fault_detail)
    finally:
        simulator.safe_state()
        simulator.close()
    return HeadlessOutcome(records_from_rows(out, pipeline), "complete")


def records_from_rows(rows: np.ndarray, pipeline: TickPipeline) -> np.ndarray:
    """`run_ticks`' rows as records (record_values, column by column): wall time the
    robot's time, no lateness or compute time, the subject's channels NaN."""
    n = len(rows)
    tick = np.arange(n)
    time_s = tick * pipeline.period_s
    reading = SensorReading(*rows[:, ROW_READING:ROW_READING + 6].T)
    fault = rows[:, ROW_FAULT]
    state = np.where(fault != 0, int(State.FAULTED), int(State.RUNNING))
    nan = np.full(n, math.nan)
    subject = SubjectState(*(nan,) * 12, np.zeros(n, dtype=bool))
    zeros = np.zeros(n)
    values = record_values(tick, time_s, time_s, zeros, zeros, reading,
                           rows[:, ROW_LAST:ROW_LAST + C_SIZE].T,
                           rows[:, ROW_APPLIED:ROW_APPLIED + 2].T,
                           pipeline.robot.position(reading.q1_rad, reading.q2_rad), subject,
                           state, fault)
    flat = np.column_stack([np.broadcast_to(np.asarray(v, dtype=float), n) for v in values])
    return unstructured_to_structured(flat, dtype=RECORD_DTYPE)
