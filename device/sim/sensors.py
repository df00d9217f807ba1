"""Models of the robot's sensors for the simulator: the handle's force sensor (Table 3.1)
and a block-drawn Gaussian noise source.

The encoders need no model here: `core.motor.MotorParameters.quantise_joint_angle`
is the encoder.

Force sensor
------------
An ATI Nano25 sits on the handle and turns with link 4 (eq. 3.35–3.36). It reports
the force the hand applies to the handle in its own frame: x', y' in the table
plane, z' normal to it, tared at connect. Table 3.1 gives its resolution, 1/24 N
horizontal and 1/48 N normal, and its range, 250 N horizontal and 1000 N normal.

The noise is added to the analogue signal *before* the data-acquisition card
quantises it, as on the real chain (strain gauges → amplifier → ADC), so every
reading is a whole multiple of the resolution whatever the noise. ATI quotes
resolution as the smallest change the system resolves, i.e. about the noise
floor, so the default noise standard deviation is one resolution step per axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.errors import check_finite, check_non_negative, check_positive

NANO25_RESOLUTION_XY_N = 1.0 / 24.0
NANO25_RESOLUTION_Z_N = 1.0 / 48.0
NANO25_LIMIT_XY_N = 250.0
NANO25_LIMIT_Z_N = 1000.0


@dataclass(frozen=True, slots=True)
class ForceSensorModel:
    """The handle's force sensor as the simulator sees it; defaults are Table 3.1.

    `noise_xy_N` and `noise_z_N` are standard deviations of zero-mean Gaussian
    noise (0 turns the noise off). `offset_rad` is the sensor's mounting angle
    on link 4 (eq. 3.35 with θ_R1 + offset; 0 in the thesis). `normal_load_N` is
    a steady normal force left after the tare, e.g. the forearm resting on the
    handle (0: tared with the hand in place).
    """

    resolution_xy_N: float = NANO25_RESOLUTION_XY_N
    resolution_z_N: float = NANO25_RESOLUTION_Z_N
    noise_xy_N: float = NANO25_RESOLUTION_XY_N
    noise_z_N: float = NANO25_RESOLUTION_Z_N
    limit_xy_N: float = NANO25_LIMIT_XY_N
    limit_z_N: float = NANO25_LIMIT_Z_N
    offset_rad: float = 0.0
    normal_load_N: float = 0.0

    def __post_init__(self) -> None:
        check_positive("resolution_xy_N", self.resolution_xy_N, "N")
        check_positive("resolution_z_N", self.resolution_z_N, "N")
        check_non_negative("noise_xy_N", self.noise_xy_N, "N", "a standard deviation")
        check_non_negative("noise_z_N", self.noise_z_N, "N", "a standard deviation")
        check_positive("limit_xy_N", self.limit_xy_N, "N")
        check_positive("limit_z_N", self.limit_z_N, "N")
        check_finite("offset_rad", self.offset_rad, "rad")
        check_finite("normal_load_N", self.normal_load_N, "N")


def gaussian_triples(rng: np.random.Generator, block: int = 4096):
    """An endless iterator of triples of standard normal numbers from `rng`.

    Drawn `block` triples at a time, so numpy stays off the 2 ms path (one `next`
    per tick); the sequence depends only on the generator's seed.
    """
    while True:
        yield from rng.standard_normal((block, 3)).tolist()
