"""The seeds of a simulated trial: the station's robot's, a new trial's (drawn from the
operating system's randomness, six digits), and the independent streams one seed gives
the patient, the sensor's noise and the zero at Connect (device.sim.simulator).
"""

from __future__ import annotations

import secrets

import numpy as np

from core.errors import ParameterError

ROBOT_SEED = 0
"""The seed that draws the simulated robot of a realistic plant (device.sim.plant) unless
another is asked for: a station's robot is one robot, so its masses, friction and drives
stay the same from trial to trial while each trial's seed draws the patient's variations
and the sensor's noise. (Before 2026-12-03 the trial's seed drew the robot too, and with a
new seed per trial every trial ran on another robot.)"""

SEEDS = 1_000_000
"""How many seeds `draw_seed` draws from: six digits, easy to read back and to type into
`rehab run --seed`."""


def draw_seed() -> int:
    """A new seed for a simulated trial (the operating system's randomness): a course of
    simulated trials at one setting varies as a person's would, each trial's seed kept in
    its file to run it again."""
    return secrets.randbelow(SEEDS)


def check_seed(seed) -> None:
    """Refuse a seed numpy's SeedSequence would take but a trial file could not keep."""
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ParameterError("seed", seed, "a whole number >= 0")


def child_seed(seed: int, index: int) -> np.random.SeedSequence:
    """The `index`-th independent stream of `seed` (what SeedSequence.spawn gives)."""
    return np.random.SeedSequence(int(seed), spawn_key=(index,))
