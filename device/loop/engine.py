"""The tick engine: a connection's ticks, and a headless trial's, written once.

Each tick, in the order of the thesis's scheme (Fig. 3.6): the backend's sensors →
(while a trial runs) rate estimate → reference → controller → performance-based
assistance (device.loop.control_kernel.control) → safety supervisor (device.safety.checks) →
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
from typing import Protocol

import numpy as np

from core.interaction import subject_motion
from core.kernels import interpreted, kernel
from device.backend import SensorReading
from device.errors import BackendError
from device.loop.control_kernel import (
    C_OUT1,
    C_OUT2,
    C_QD1,
    C_QD2,
    C_QDD1,
    C_QDD2,
    C_SIZE,
    control,
    rows_needed,
)
from device.loop.pipeline import TickPipeline, idle_record
from device.loop.tickrows import (
    ROW_APPLIED,
    ROW_FAULT,
    ROW_LAST,
    ROW_READING,
    ROW_SIZE,
    ROW_SUBJECT,
    records_from_rows,
)
from device.recording.record import RECORD_DTYPE
from device.safety.checks import W_FAULT, supervise
from device.safety.faults import Fault
from device.safety.supervisor import SafetySupervisor
from device.sim import physics
from device.sim.physics import X_READING, last_reading, read, write
from device.sim.simulator import SimulatorBackend

FAULT_LATCHED = 10
"""`run_ticks` stopped because the supervisor latched a fault (beyond the simulator's own
failure codes, device.sim.physics)."""
NEED_ROWS = 11
"""`run_ticks` stopped before a tick that reads reference rows it was not given
(control_kernel.rows_needed): load them (TickPipeline.load_rows) and go on from that tick."""

_CHUNKS = 100  # a headless run reports its progress this many times
BLOCK_TICKS = 25_000
"""A headless run that streams its records holds this many ticks at once (50 s at 2 ms),
and this many rows of the reference: its memory stays the same whatever the trial's
length."""
ROWS_BEHIND = 500
"""Rows loaded before the lowest a tick needs: the as-needed guidance may search up to
BEHIND_FURTHEST_ROWS + WINDOW_BACK_ROWS (core.control.guidance) behind where it was."""


@kernel
def supervised_command(kind, robot, model, tracker, gains, assist, guide, rates, integral,
                       guided, tick, rows, rows_from, n_rows, approach_ticks, period_s,
                       sensor_offset_rad, last, g, w, now_s, t, q1, q2, fx, fy, fz, lateness_s,
                       heartbeat_age_s, estop, recording_lost):
    """A running tick between the sensors and the motors: the pipeline's command
    (writes `last`) through the supervisor: (torque1, torque2, fault) to write."""
    control(kind, robot, model, tracker, gains, assist, guide, rates, integral, guided, tick,
            rows, rows_from, n_rows, approach_ticks, period_s, sensor_offset_rad, q1, q2, fx,
            fy, last)
    return supervise(robot, g, w, now_s, t, q1, q2, fx, fy, fz, last[C_QD1], last[C_QD2],
                     last[C_OUT1], last[C_OUT2], lateness_s, heartbeat_age_s, estop,
                     recording_lost, 0.0, True)


@kernel
def simulated_tick(running, tick, now_s, r, a, c, p, table, episodes, x, noise, scratch, kind,
                   robot, model, tracker, gains, assist, guide, rates, integral, guided, rows,
                   rows_from, n_rows, approach_ticks, period_s, sensor_offset_rad, last, g, w,
                   lateness_s, heartbeat_age_s, estop, recording_lost):
    """One tick on the simulator in one call (what `TickEngine.step` does with a backend,
    with the simulator's own read and write): (status, torque1, torque2, fault), status
    the simulator's failure (then nothing else ran) or OK."""
    status = read(r, a, c, p, table, episodes, x, now_s, noise, scratch)
    if status != physics.OK:
        return status, 0.0, 0.0, 0
    t, q1, q2, fx, fy, fz = last_reading(x)
    if running:
        out1, out2, code = supervised_command(
            kind, robot, model, tracker, gains, assist, guide, rates, integral, guided, tick,
            rows, rows_from, n_rows, approach_ticks, period_s, sensor_offset_rad, last, g, w,
            now_s, t, q1, q2, fx, fy, fz, lateness_s, heartbeat_age_s, estop, recording_lost)
    else:
        out1, out2, code = supervise(robot, g, w, now_s, t, q1, q2, fx, fy, fz, 0.0, 0.0, 0.0,
                                     0.0, lateness_s, heartbeat_age_s, estop, recording_lost,
                                     0.0, False)
    write(c, x, out1, out2)
    return physics.OK, out1, out2, code


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
    kernels on their vectors. On a compiled simulator the whole tick, the simulator's
    read and write included, is one call (`simulated_tick`: the same kernels, without
    four trips between Python and compiled code), and `rehearse` runs the coming tick
    on copies of the state in the slack before its deadline, so that the tick itself
    finds its code and data in the caches.
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
        self._simulated = None
        if self.compiled and isinstance(backend, SimulatorBackend) and backend.compiled:
            from device.compiled.jit import compiled

            self._simulated = compiled(simulated_tick)
            self._shadow = {}

    def _simulated_arguments(self, running: bool, tick: int, now_s: float, shadow: bool):
        sim, p, sup = self.backend, self.pipeline, self.supervisor
        v = p.vectors
        (r, a, c, pt, table, episodes), _, scratch = sim.physics
        state = (sim.state, scratch, v.rates, v.integral, v.guided, v.last, sup.state)
        if shadow:
            copies = self._shadow.get("copies")
            if copies is None:
                copies = self._shadow["copies"] = tuple(np.empty_like(s) for s in state)
            for copy, original in zip(copies, state, strict=True):
                copy[:] = original
            state = copies
        x, scratch, rates, integral, guided, last, w = state
        return (running, tick, now_s, r, a, c, pt, table, episodes, x, sim.noise, scratch,
                p.kind, v.robot, v.model, v.tracker, v.gains, v.assist, v.guide, rates, integral,
                guided, v.rows, p.rows_from, p.n_rows, p.approach_ticks, p.period_s,
                p.sensor_offset_rad, last, sup.constants, w)

    def rehearse(self, tick: int | None, now_s: float) -> None:
        """Run the coming tick on copies of the state and throw the result away (on a
        compiled simulator; nothing otherwise): the real tick then finds its code and
        data warm in the caches. Call it in the slack before the deadline."""
        if self._simulated is None:
            return
        self.backend.top_up_noise(1)
        self._simulated(*self._simulated_arguments(tick is not None, tick or 0, now_s, True),
                        0.0, 0.0, False, False)

    def step(self, tick: int | None, now_s: float, lateness_s: float, heartbeat_age_s: float,
             estop: bool, recording_lost: bool, clock: Callable[[], float] = time.perf_counter,
             ) -> Tick:
        """One tick at robot time `now_s`: trial tick `tick` of the pipeline, or None while
        no trial runs (zero torque; the supervisor still watches)."""
        started = clock()
        if self._simulated is not None:
            return self._simulated_step(tick, now_s, lateness_s, heartbeat_age_s, estop,
                                        recording_lost, clock, started)
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
                p.kind, v.robot, v.model, v.tracker, v.gains, v.assist, v.guide, v.rates,
                v.integral, v.guided, tick, v.rows, p.rows_from, p.n_rows, p.approach_ticks,
                p.period_s, p.sensor_offset_rad, v.last, sup.constants, sup.state, now_s,
                *values, lateness_s, heartbeat_age_s, estop, recording_lost)
            p.ticked()
        else:
            out1, out2, code = self._supervise(
                self._robot, sup.constants, sup.state, now_s, *values, 0.0, 0.0, 0.0, 0.0,
                lateness_s, heartbeat_age_s, estop, recording_lost, float(read_error),
                tick is not None)
        sup.after_tick(before)
        try:
            backend.write(out1, out2)
        except BackendError:
            backend.safe_state()
        return Tick(out1, out2, Fault(code), reading, clock() - started)

    def _simulated_step(self, tick, now_s, lateness_s, heartbeat_age_s, estop, recording_lost,
                        clock, started) -> Tick:
        sim, sup = self.backend, self.supervisor
        before = sup.state[W_FAULT]
        sim.top_up_noise(1)
        status, out1, out2, code = self._simulated(
            *self._simulated_arguments(tick is not None, tick or 0, now_s, False), lateness_s,
            heartbeat_age_s, estop, recording_lost)
        if status == physics.OK:
            reading = sim.sampled()
            if tick is not None:
                self.pipeline.ticked()
        else:
            # the simulator could not read: as its `read` would have raised, the supervisor
            # turns the error into its fault and zero torque
            reading = sim.failure(status, now_s)
            _, read_error = sup.read_values(reading)
            out1, out2, code = self._supervise(
                self._robot, sup.constants, sup.state, now_s, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                0.0, 0.0, 0.0, 0.0, lateness_s, heartbeat_age_s, estop, recording_lost,
                float(read_error), tick is not None)
            sim.write(out1, out2)
        sup.after_tick(before)
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
                           state, int(done.fault), p.period_s, p.sensor_offset_rad,
                           p.assistance.level if running else math.nan)


NO_READING = SensorReading(math.nan, math.nan, math.nan, math.nan, math.nan, math.nan)


# ------------------------------------------------------------------- headless
@kernel
def store_subject(out, k, subject):
    """Row k's subject columns from one `subject_motion` result (SubjectState's order).
    Written out because the result mixes floats and a bool: compiled code cannot index
    such a tuple with a loop variable."""
    fx, fy, ts, te, tsd, ted, tsdd, tedd, tau_s, tau_e, isb_s, isb_e, damped = subject
    out[k, ROW_SUBJECT] = fx
    out[k, ROW_SUBJECT + 1] = fy
    out[k, ROW_SUBJECT + 2] = ts
    out[k, ROW_SUBJECT + 3] = te
    out[k, ROW_SUBJECT + 4] = tsd
    out[k, ROW_SUBJECT + 5] = ted
    out[k, ROW_SUBJECT + 6] = tsdd
    out[k, ROW_SUBJECT + 7] = tedd
    out[k, ROW_SUBJECT + 8] = tau_s
    out[k, ROW_SUBJECT + 9] = tau_e
    out[k, ROW_SUBJECT + 10] = isb_s
    out[k, ROW_SUBJECT + 11] = isb_e
    out[k, ROW_SUBJECT + 12] = 1.0 if damped else 0.0


@kernel
def run_ticks(k0, k1, period_s, r, a, c, p, table, episodes, x, noise, scratch, kind, robot,
              arm, model, tracker, gains, assist, guide, rates, integral, guided, rows,
              rows_from, n_rows, approach_ticks, sensor_offset_rad, last, g, w, out, base,
              estop, recording_lost):
    """Ticks k0…k1−1 of a headless trial on the simulator (device.sim.physics' vectors
    r…scratch), at robot time k × period: each reads the sensors (tick 0 takes the
    reading made before it), runs `supervised_command` and writes the torque, and
    leaves what it did in out[k − base] (ROW_*: `out` holds the block of ticks from
    `base`). `rows` holds the reference rows from row `rows_from` of the trial's
    n_rows. Returns (the next tick, status): the simulator's failure, FAULT_LATCHED
    after the tick that latched a fault, NEED_ROWS before a tick that would read a row
    `rows` does not hold (nothing of it ran), or OK."""
    held = rows_from + len(rows)
    for k in range(k0, k1):
        lo, hi = rows_needed(guide, guided, approach_ticks, k, n_rows)
        if lo < rows_from or hi >= held:
            return k, NEED_ROWS
        now_s = k * period_s
        if k:
            status = read(r, a, c, p, table, episodes, x, now_s, noise, scratch)
            if status != physics.OK:
                return k, status
        t, q1, q2, fx, fy, fz = last_reading(x)
        out1, out2, code = supervised_command(
            kind, robot, model, tracker, gains, assist, guide, rates, integral, guided, k,
            rows, rows_from, n_rows, approach_ticks, period_s, sensor_offset_rad, last, g, w,
            now_s, t, q1, q2, fx, fy, fz, 0.0, 0.0, estop, recording_lost)
        write(c, x, out1, out2)
        i = k - base
        for j in range(6):
            out[i, ROW_READING + j] = x[X_READING + j]
        for j in range(C_SIZE):
            out[i, ROW_LAST + j] = last[j]
        out[i, ROW_APPLIED] = out1
        out[i, ROW_APPLIED + 1] = out2
        out[i, ROW_FAULT] = code
        store_subject(out, i, subject_motion(
            robot, arm, q1, q2, last[C_QD1], last[C_QD2], last[C_QDD1], last[C_QDD2], fx, fy,
            sensor_offset_rad))
        if code != 0:
            return k + 1, FAULT_LATCHED
    return k1, physics.OK


@dataclass(frozen=True, slots=True)
class HeadlessOutcome:
    """A headless trial's records (none when they went to a sink), how many ticks ran,
    its status, and the fault's message and detail when it faulted."""

    records: np.ndarray
    status: str
    fault_tick: int = -1
    fault_message: str = ""
    fault_detail: dict | None = None
    n_ticks: int = 0


Sink = Callable[[np.ndarray], None]
"""Takes each block of a headless trial's records, in tick order (a trial file writer's
append)."""


class Feed(Protocol):
    """What a headless trial tells between its ticks, as a live console would between
    the loop's: called with each `every_ticks` ticks' records as they are made, it may
    set what the next ticks use (an estimate of the patient's force from EMG made from
    those ticks, app.emg.feed)."""

    every_ticks: int

    def __call__(self, records: np.ndarray) -> None: ...


def run_trial(simulator, pipeline: TickPipeline, supervisor: SafetySupervisor,
              progress: Callable[[float], None] | None = None,
              sink: Sink | None = None, feed: Feed | None = None) -> HeadlessOutcome:
    """A whole trial on `simulator` without a clock: robot time k × period, run by
    `run_ticks` in the pipeline's flavour (compiled with a compiled pipeline and
    simulator, interpreted otherwise).

    With a `sink`, the records go to it block by block (BLOCK_TICKS at a time, the last
    block up to the fault when there is one) and the outcome holds none: memory does not
    grow with the trial's length. Without one, the outcome holds them all. Either way the
    reference rows are loaded a block's worth at a time, when the ticks need them
    (NEED_ROWS), and the sensor noise is drawn before each call for its ticks. A `feed` is
    called with the records of every `feed.every_ticks` ticks before the next run."""
    if pipeline.compiled != simulator.compiled:
        raise ValueError("a headless run needs the simulator and the pipeline in one flavour "
                         "(both compiled or both interpreted)")
    period = pipeline.period_s
    simulator.open()
    reading = simulator.read(0.0)
    pipeline.begin(reading.q1_rad, reading.q2_rad, load=False)
    total = pipeline.total_ticks
    (r, a, c, p, table, episodes), flavour, scratch = simulator.physics
    if pipeline.compiled:
        ticks = flavour(run_ticks)
    else:
        ticks = interpreted(run_ticks, {**simulator.replacements, **pipeline.replacements})
    v = pipeline.vectors
    block = total if sink is None else min(total, BLOCK_TICKS)
    rows_at_once = min(total, BLOCK_TICKS)
    # every value of a tick's row is written by the tick (ROW_*), and only the ticks run
    # are made records: nothing to fill beforehand
    out = np.empty((block, ROW_SIZE))
    kept: list[np.ndarray] = []
    # a call of run_ticks for a block's worth of ticks (its noise drawn before it: the
    # noise held stays a block's whatever the trial's length) unless someone waits on the
    # progress; the calls cost their arguments' unboxing and a noise top-up each, and the
    # noise stream is the same however it is cut (SimulatorBackend.top_up_noise)
    step = (rows_at_once if progress is None
            else max(1, min(block, -(-total // _CHUNKS))))
    if feed is not None:
        step = max(1, min(step, int(feed.every_ticks)))
    base, done, status = 0, 0, physics.OK

    def hand_over(n: int) -> None:
        # the block's first n ticks as records, to the sink or kept
        records = records_from_rows(out[:n], pipeline, base)
        if sink is None:
            kept.append(records)
        else:
            sink(records)

    def outcome(status_name: str, fault_tick: int = -1) -> HeadlessOutcome:
        records = kept[0] if len(kept) == 1 else (
            np.concatenate(kept) if kept else np.empty(0, dtype=RECORD_DTYPE))
        if status_name == "complete":
            return HeadlessOutcome(records, status_name, n_ticks=done)
        return HeadlessOutcome(records, status_name, fault_tick, supervisor.fault_message,
                               supervisor.fault_detail, done)

    start = stop = 0  # the stretch of ticks one call runs (resumed after NEED_ROWS)
    try:
        while done < total and status == physics.OK:
            if done == stop:
                if progress is not None:
                    progress(done / total)
                start, stop = done, min(total, done + step, base + block)
                simulator.top_up_noise(stop - done + 1)  # a noise row a tick, none drawn in it
            done, status = ticks(
                done, stop, period, r, a, c, p, table, episodes, simulator.state,
                simulator.noise, scratch, pipeline.kind, v.robot, v.arm, v.model, v.tracker,
                v.gains, v.assist, v.guide, v.rates, v.integral, v.guided, v.rows,
                pipeline.rows_from, pipeline.n_rows, pipeline.approach_ticks,
                pipeline.sensor_offset_rad, v.last, supervisor.constants, supervisor.state, out,
                base, False, False)
            if status == NEED_ROWS:  # load them and go on with the same stretch
                lo, hi = pipeline.rows_needed(done)
                pipeline.load_rows(lo - ROWS_BEHIND, hi + rows_at_once)
                status = physics.OK
                continue
            if feed is not None and done > start:
                feed(records_from_rows(out[start - base:done - base], pipeline, start))
            if done == base + block or done == total or status != physics.OK:
                hand_over(done - base)
                base = done
        if done:
            pipeline.ticked()
        if status == FAULT_LATCHED:
            supervisor.after_tick(0.0)
            return outcome("faulted", done - 1)
        if status != physics.OK:
            # the simulator failed to read tick `done`: the supervisor turns it into its
            # fault (no record: there was no reading)
            error = simulator.failure(status, done * period)
            supervisor.step(done * period, error, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, False, False)
            return outcome("faulted", done)
    finally:
        simulator.safe_state()
        simulator.close()
    return outcome("complete")
