"""The live loop's running tick in one compiled call: read the simulator, control,
supervise, write.

Why: the loop sleeps between ticks, and on a small VM the tick then starts on cold
caches. The Python tick (about 25 µs warm) took 150–200 µs at its 99th percentile
there; the compiled tick touches a fraction of the memory, and `warm` runs it once on
a copy of its state just before the deadline, so the real tick finds its code and
data in cache (bench/loop_jitter.py gives the figures).

The Python objects (SimulatorBackend, TickPipeline, SafetySupervisor) stay the
owners of the trial. `take_over` copies their per-tick state into arrays; `tick`
runs one tick on them; `hand_back` copies the state back. Any tick that is not
ordinary (a safety check trips, the simulator fails, the noise block is used up)
is undone inside the kernel and handed back before anything was written, so the
loop runs exactly that tick again in Python, which latches and reports the fault
as it always does. The loop hands back before handling a command and takes over
again after it.
"""

from __future__ import annotations

import numpy as np

from device.compiled import control as ctl
from device.compiled import dynamics as dyn
from device.compiled import guard
from device.compiled.jit import kernel
from device.compiled.trial import TRIPPED, unsupported
from device.safety.faults import Fault
from device.sim.simulator import SimulatorSnapshot, restore, snapshot

_X, _Z, _W = dyn.X_SIZE, ctl.Z_SIZE, guard.W_SIZE
_SHADOW = _X + _Z + _W + ctl.C_SIZE + 15  # warm_tick's copies of x, z, w, c and scratch
NOISE_RESERVE = 1000
"""Sensor-noise rows (2 s of ticks) kept ahead of the compiled tick."""


def unsupported_live(backend, pipeline, supervisor) -> str:
    """Why the loop cannot run this trial's ticks compiled, or ''."""
    return unsupported(backend, pipeline, supervisor, patient_may_wait=True)


class CompiledTick:
    """One trial's compiled running tick; see the module notes."""

    def __init__(self, backend, pipeline, supervisor) -> None:
        reason = unsupported_live(backend, pipeline, supervisor)
        if reason:
            raise ValueError(reason)
        self.backend, self.pipeline, self.supervisor = backend, pipeline, supervisor
        self._sc = dyn.simulator_constants(backend)
        self._p, self._table, self._episodes = dyn.patient_arrays(backend.patient)
        self._kc = ctl.controller_constants(pipeline)
        self._gc = guard.supervisor_constants(supervisor)
        self._x = np.zeros(_X)
        self._z = np.zeros(_Z)
        self._w = np.zeros(_W)
        self._c = np.zeros(ctl.C_SIZE)
        self._scratch = np.zeros(15)
        self._saved = np.zeros(_X + _Z + _W)
        self._shadow = np.zeros(_SHADOW)
        self._rows = pipeline.reference_rows
        self._approach_ticks = 0
        self._noise = np.zeros((1, 3))
        self._ticked = False  # whether c holds a tick since take_over
        self.active = False

    # ------------------------------------------------------------ hand-over
    def take_over(self) -> str:
        """Copy the objects' state into the arrays; '' when the compiled tick may run,
        else why not (the loop then runs the tick in Python)."""
        backend, pipeline, supervisor = self.backend, self.pipeline, self.supervisor
        if supervisor.fault is not Fault.NONE:
            return "a fault is latched"
        if not all(est.primed for est in pipeline.rate_estimators):
            return "the rate trackers have no angle yet"
        snap = snapshot(backend)
        if snap.anchor is None:
            return "the simulator's clock is not anchored yet"
        x = self._x
        x[dyn.X_STEPS] = snap.steps
        x[dyn.X_Q1:dyn.X_QD2 + 1] = snap.state
        x[[dyn.X_TAU1, dyn.X_TAU2]] = snap.torque
        x[[dyn.X_LAST_TAU1, dyn.X_LAST_TAU2]] = snap.last_torque
        x[[dyn.X_T0, dyn.X_ANCHOR, dyn.X_CACHED]] = (
            snap.patient_t0, snap.anchor, float(snap.cached_k1))
        x[dyn.X_LAST:dyn.X_LAST + 15] = snap.last
        x[dyn.X_READING:dyn.X_READING + 6] = snap.reading
        x[dyn.X_NOISE] = snap.noise_pos
        self._noise = snap.noise_block
        self._z[:] = ctl.pipeline_state(pipeline)
        self._w[:] = supervisor.history()
        self._kc[ctl.K_LEVEL] = pipeline.assistance.level
        self._kc[ctl.K_TOLERANCE] = pipeline.assistance.tolerance_rad
        self._rows = pipeline.reference_rows
        self._approach_ticks = pipeline.approach_ticks
        self._ticked = False
        self.active = True
        return ""

    def hand_back(self) -> None:
        """Copy the arrays' state back into the objects; the loop's Python tick goes on."""
        if not self.active:
            return
        x = self._x
        restore(self.backend, SimulatorSnapshot(
            int(x[dyn.X_STEPS]), tuple(x[dyn.X_Q1:dyn.X_QD2 + 1].tolist()),
            (x[dyn.X_TAU1], x[dyn.X_TAU2]), (x[dyn.X_LAST_TAU1], x[dyn.X_LAST_TAU2]),
            tuple(x[dyn.X_LAST:dyn.X_LAST + 15].tolist()),
            tuple(x[dyn.X_READING:dyn.X_READING + 6].tolist()),
            bool(x[dyn.X_CACHED]), x[dyn.X_T0], x[dyn.X_ANCHOR], self._noise,
            int(x[dyn.X_NOISE]),
        ))
        ctl.restore_pipeline(self.pipeline, self._z, self._c if self._ticked else None)
        self.supervisor.restore_history(self._w.tolist())
        self.active = False

    def keep_noise(self, reserve: int = NOISE_RESERVE) -> None:
        """Between ticks: when fewer than `reserve` sensor-noise rows are left, let the
        simulator draw the next block now, so that no tick is handed back for it."""
        if self.active and len(self._noise) - int(self._x[dyn.X_NOISE]) < reserve:
            self.hand_back()
            self.backend.top_up_noise(reserve)
            self.take_over()

    # ----------------------------------------------------------------- tick
    def tick(self, tick: int, loop_t: float, lateness_s: float, heartbeat_age_s: float,
             estop: bool, recording_lost: bool) -> tuple[float, float] | None:
        """Run trial tick `tick` at loop time `loop_t`: the torques written, or None when
        the tick was undone and handed back for the Python loop to run."""
        status, out1, out2 = loop_tick(
            tick, loop_t, lateness_s, heartbeat_age_s, estop, recording_lost, self._rows,
            self._approach_ticks, self._sc, self._p, self._table, self._episodes, self._x,
            self._noise, self._kc, self._z, self._gc, self._w, self._c, self._scratch,
            self._saved,
        )
        if status != dyn.OK:
            self.hand_back()
            return None
        self._ticked = True
        return out1, out2

    def warm(self, tick: int, loop_t: float) -> None:
        """Run the coming tick on a copy of the state and throw the result away, so the
        real tick finds its code and data in cache."""
        warm_tick(tick, loop_t, self._rows, self._approach_ticks, self._sc, self._p,
                  self._table, self._episodes, self._x, self._noise, self._kc, self._z,
                  self._gc, self._w, self._shadow)

    def reading(self) -> tuple:
        """The sensor reading of the last tick: (time, q1, q2, fx, fy, fz)."""
        return tuple(self._x[dyn.X_READING:dyn.X_READING + 6].tolist())

    def last_tick(self) -> tuple:
        """TickPipeline.last_tick of the last tick, for its record."""
        return ctl.last_tick(self._c)


@kernel
def loop_tick(tick, loop_t, lateness, beat_age, estop, lost, rows, approach_ticks, sc, p,
              table, episodes, x, noise, kc, z, gc, w, c, scratch, saved):
    """DeviceLoop's running tick: (status, torque1, torque2). Not OK: nothing changed."""
    saved[:_X] = x
    saved[_X:_X + _Z] = z
    saved[_X + _Z:] = w
    status = dyn.read(sc, p, table, episodes, x, loop_t, noise, scratch)
    if status == dyn.OK:
        r = dyn.X_READING
        q1 = x[r + 1]
        q2 = x[r + 2]
        ctl.control(kc, z, tick, rows, approach_ticks, q1, q2, x[r + 3], x[r + 4], c)
        out1, out2, tripped = guard.check(
            gc, w, loop_t, x[r], q1, q2, x[r + 3], x[r + 4], x[r + 5], c[ctl.C_QD1],
            c[ctl.C_QD2], c[ctl.C_OUT1], c[ctl.C_OUT2], lateness, beat_age, estop, lost)
        if tripped == guard.CLEAR:
            dyn.write(sc, x, out1, out2)
            return dyn.OK, out1, out2
        status = TRIPPED
    x[:] = saved[:_X]
    z[:] = saved[_X:_X + _Z]
    w[:] = saved[_X + _Z:]
    return status, 0.0, 0.0


@kernel
def warm_tick(tick, loop_t, rows, approach_ticks, sc, p, table, episodes, x, noise, kc, z,
              gc, w, shadow):
    """loop_tick on copies of x, z, w kept in `shadow`."""
    xs = shadow[:_X]
    zs = shadow[_X:_X + _Z]
    ws = shadow[_X + _Z:_X + _Z + _W]
    cs = shadow[_X + _Z + _W:_X + _Z + _W + ctl.C_SIZE]
    scratch = shadow[_X + _Z + _W + ctl.C_SIZE:]
    xs[:] = x
    zs[:] = z
    ws[:] = w
    status = dyn.read(sc, p, table, episodes, xs, loop_t, noise, scratch)
    if status == dyn.OK:
        r = dyn.X_READING
        ctl.control(kc, zs, tick, rows, approach_ticks, xs[r + 1], xs[r + 2], xs[r + 3],
                    xs[r + 4], cs)
        guard.check(gc, ws, loop_t, xs[r], xs[r + 1], xs[r + 2], xs[r + 3], xs[r + 4],
                    xs[r + 5], cs[ctl.C_QD1], cs[ctl.C_QD2], cs[ctl.C_OUT1], cs[ctl.C_OUT2],
                    0.0, 0.0, False, False)
