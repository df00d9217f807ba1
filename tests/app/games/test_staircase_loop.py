"""The staircase in the closed loop: virtual patients of three known abilities play a reaching
game on the headless simulator, the staircase setting each round from the last; after it has
converged, each succeeds within ±7 points of 70 % (issue 30)."""

import pytest

from app.games.virtual import convergence, play_rounds
from core.games.staircase import TARGET_SUCCESS
from core.trial import TrialParameters

GAME = TrialParameters(game="reach", shape="targets", n_targets=8, duration_s=12.0,
                       repetitions=1, assist="as-needed", timing="minimum_jerk",
                       centre_m=(-0.3, 0.35), radius_m=0.08)
ROUNDS = 42
ABILITIES = {"healthy": None, "weak": None, "passive": None}
"""Effort 1, 0.4 (device.sim.patient_parameters.DEFAULT_EFFORT) and 0: the robot's help alone."""


@pytest.mark.slow
def test_three_abilities_settle_near_seventy_percent_at_their_own_difficulty():
    settled = {}
    for kind, options in ABILITIES.items():
        played = play_rounds(GAME, kind, ROUNDS, seed=100, patient_options=options)
        c = convergence(played)
        assert c.rounds_to_converge <= ROUNDS // 2, (kind, c)
        assert c.movements_after >= 8 * ROUNDS // 2
        assert abs(c.success_after - TARGET_SUCCESS) <= 0.07, (kind, c)
        settled[kind] = c.settled_rung
    # the staircase found three different difficulties, in the order of the abilities
    assert settled["healthy"] > settled["weak"] > settled["passive"]
