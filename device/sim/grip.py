"""The simulated force sensor's zero at Connect, and a virtual patient's hand taking hold of
the handle meanwhile (device.sim.simulator's `open`).

`open()` takes the sensor's zero as the hardware does, averaging 0.25 s of samples at 2 kHz
(docs/hardware.md, Tare), and refuses one taken under load (device.backend.Tare: the force
moved beyond the sensor's noise). Nobody touches the handle unless told to:
`push_at_connect_N` is a virtual patient's hand taking hold of the handle as the zero
starts, its push (global frame, N) rising with a 50 ms time constant and trembling at 10 Hz
by 5 % (physiological tremor, 8–12 Hz), with the sensor's noise and resolution on top,
drawn from a seed of its own. A zero that passes is taken as exact: what a push within the
noise leaves is within the noise.
"""

from __future__ import annotations

import math

import numpy as np

from device.backend import TARE_SPREAD_LIMIT_N, Tare, tare_of
from device.sim.sensors import ForceSensorModel

TARE_S = 0.25
TARE_RATE_HZ = 2000.0
"""The zero at Connect: 0.25 s of samples at 2 kHz, as the hardware's default settings."""
GRIP_RISE_S = 0.05
GRIP_TREMOR_HZ = 10.0
GRIP_TREMOR_FRACTION = 0.05
"""A hand taking hold of the handle (`push_at_connect_N`): its push rises with this time
constant and trembles at this frequency by this fraction of itself."""


def zero_at_connect(push_N: tuple[float, float], sensor: ForceSensorModel, seed: int) -> Tare:
    """The zero's samples as `sensor` reads them while a hand's push rises to `push_N`
    (fx, fy in N; (0, 0): nobody touches the handle), drawn from `seed`."""
    rng = np.random.default_rng(seed)
    t = np.arange(round(TARE_S * TARE_RATE_HZ)) / TARE_RATE_HZ
    grip = (1.0 - np.exp(-t / GRIP_RISE_S)) * (1.0 + GRIP_TREMOR_FRACTION * np.sin(
        2.0 * math.pi * GRIP_TREMOR_HZ * t + rng.uniform(0.0, 2.0 * math.pi)))
    step = sensor.resolution_xy_N
    forces = [np.round((push * grip + sensor.noise_xy_N * rng.standard_normal(t.size))
                       / step) * step for push in push_N]
    return tare_of(*forces, TARE_S, TARE_SPREAD_LIMIT_N)
