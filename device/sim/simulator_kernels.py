"""device.sim.physics's kernels bound to one simulator: its constants vector (the sensors'
and the integrator's, physics' S_* names) and its read, write and reset in the flavour it
runs, compiled by numba on float arrays or interpreted on Python tuples and lists.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from core.kernels import interpreted
from device.sim import physics
from device.sim.patients import VirtualPatient

if TYPE_CHECKING:
    from device.sim.simulator import SimulatorBackend


class Kernels:
    """device.sim.physics's read, write and reset bound to one simulator's constants, in
    the flavour the simulator runs: compiled on float arrays, or interpreted on Python
    tuples and lists (several times faster there than numpy scalars), with the patient's
    own torque when it is not a VirtualPatient's (`replacements`)."""

    def __init__(self, simulator: SimulatorBackend) -> None:
        patient = simulator.patient
        self.replacements: dict = {}
        if isinstance(patient, VirtualPatient):
            model = (patient.constants, patient.table, patient.episodes)
        else:
            model = ((), np.zeros((1, 18)), np.zeros(1))

            def own_torque(p, table, episodes, t_s, ts, te, tsd, ted):
                return patient.torque(t_s, ts, te, tsd, ted)

            self.replacements = {"patient_torque": own_torque}
        constants = (simulator.robot.constants, simulator.arm.constants, simulator.constants)
        self._compiled = simulator.compiled
        if self._compiled:
            from device.compiled.jit import compiled  # numba only where it is used

            vectors = tuple(np.asarray(v, dtype=float) for v in (*constants, model[0]))
            self.arrays = (*vectors, np.ascontiguousarray(model[1], dtype=float),
                           np.asarray(model[2], dtype=float))
            self.flavour = compiled
        else:
            self.arrays = (*constants, model[0], [tuple(row) for row in model[1].tolist()],
                           model[2].tolist())
            self.flavour = lambda f: interpreted(f, self.replacements)
        read, write, reset = (self.flavour(f) for f in (physics.read, physics.write,
                                                          physics.reset))
        r, a, c, p, table, episodes = self.arrays
        self.read = lambda x, now, noise, scratch: read(r, a, c, p, table, episodes, x, now,
                                                        noise, scratch)
        self.write = lambda x, tau1, tau2: write(c, x, tau1, tau2)
        self.reset = lambda q1, q2, t0, x, noise, scratch: reset(r, a, c, p, table, episodes,
                                                                 q1, q2, t0, x, noise, scratch)

    def vector(self, size: int):
        return np.zeros(size) if self._compiled else [0.0] * size

    def rows(self, block: np.ndarray):
        return np.ascontiguousarray(block) if self._compiled else block.tolist()


def constants_of(simulator: SimulatorBackend) -> tuple[float, ...]:
    sn, robot = simulator.sensor, simulator.robot
    values = {
        physics.S_OFFSET: sn.offset_rad, physics.S_NOISE_XY: sn.noise_xy_N,
        physics.S_NOISE_Z: sn.noise_z_N, physics.S_LOAD: sn.normal_load_N,
        physics.S_RXY: sn.resolution_xy_N, physics.S_RZ: sn.resolution_z_N,
        physics.S_LIMIT_XY: sn.limit_xy_N, physics.S_LIMIT_Z: sn.limit_z_N,
        physics.S_CPR1: robot.motors[0].counts_per_joint_rev,
        physics.S_CPR2: robot.motors[1].counts_per_joint_rev,
        physics.S_STEP: simulator.step_s, physics.S_RATE: 1.0 / simulator.step_s,
        physics.S_MAX1: robot.max_joint_torque_Nm[0], physics.S_MAX2: robot.max_joint_torque_Nm[1],
        physics.S_RK4: float(simulator.integrator == "rk4"),
        physics.S_DELAY: float(simulator.plant.actuator_delay),
        physics.S_GAIN1: simulator.plant.torque_gain[0],
        physics.S_GAIN2: simulator.plant.torque_gain[1],
    }
    return tuple(float(values[i]) for i in range(physics.S_SIZE))

