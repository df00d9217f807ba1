"""The transparent mode (core.control.transparent): its law is the model's eq. 3.6 in the
shares asked, its gains come through the trial's gains line and are refused by name out
of range, and a transparent trial has no level: it runs, and records, 0."""

import math

import numpy as np
import pytest

from core.control.gains import built, gain_rows
from core.control.guidance import OFF
from core.control.transparent import (
    TC_FRICTION,
    TC_INERTIA,
    TC_ON,
    TC_SIZE,
    TC_STIFFNESS,
    TransparentGains,
    transparent_torques,
)
from core.errors import ParameterError
from core.robot import Friction, RobotModel, Stiffness
from core.robot_terms import friction_terms, inverse_dynamics_terms, stiffness_terms
from core.trial import ASSIST_MODES, THESIS_SUBJECT, TrialParameters
from device.loop.pipeline import TickPipeline, TrialPlan, assistance_group

ROBOT = RobotModel(
    friction=Friction((0.05, 0.04), (0.02, 0.03), ee_coulomb_N=0.3, ee_viscous_Ns_m=0.5),
    stiffness=Stiffness(0.5, 0.1, 0.4, 1.0, 2.0),
)


def vector(inertia, friction, stiffness):
    out = [*OFF, 0.0, 0.0, 0.0, 0.0]
    assert len(out) == TC_SIZE
    out[TC_ON], out[TC_INERTIA], out[TC_FRICTION], out[TC_STIFFNESS] = (
        1.0, inertia, friction, stiffness)
    return out


def states(n=100, seed=3):
    rng = np.random.default_rng(seed)
    q = ROBOT.ik(rng.uniform([-0.40, 0.20], [-0.15, 0.45], (n, 2)))
    for (q1, q2), noise in zip(q, rng.normal(0.0, [1.0, 1.0, 5.0, 5.0], (n, 4)), strict=True):
        yield (float(q1), float(q2), *map(float, noise))


def test_with_every_share_one_the_law_is_the_robots_own_dynamics():
    """Shares of 1 give the left of eq. 3.6 (M θ̈ + C θ̇ + K(θ − θ0) + friction): the torque
    that would leave the hand no force, the robot's inverse dynamics with F = 0."""
    r = ROBOT.constants
    for q1, q2, v1, v2, a1, a2 in states():
        got = transparent_torques(r, vector(1.0, 1.0, 1.0), q1, q2, v1, v2, a1, a2)
        want = inverse_dynamics_terms(r, q1, q2, v1, v2, a1, a2, 0.0, 0.0)
        assert got == pytest.approx(want, rel=1e-12, abs=1e-12)


def test_each_share_scales_its_own_term_and_none_gives_no_torque():
    r = ROBOT.constants
    for q1, q2, v1, v2, a1, a2 in states(20):
        assert transparent_torques(r, vector(0.0, 0.0, 0.0), q1, q2, v1, v2, a1, a2) == (
            0.0, 0.0)
        friction = friction_terms(r, q1, q2, v1, v2)
        got = transparent_torques(r, vector(0.0, 0.4, 0.0), q1, q2, v1, v2, a1, a2)
        assert got == pytest.approx((0.4 * friction[0], 0.4 * friction[1]), rel=1e-12)
        spring = stiffness_terms(r, q1, q2)
        got = transparent_torques(r, vector(0.0, 0.0, 0.7), q1, q2, v1, v2, a1, a2)
        assert got == pytest.approx((0.7 * spring[0], 0.7 * spring[1]), rel=1e-12)
        inertial = [a - b for a, b in zip(
            inverse_dynamics_terms(r, q1, q2, v1, v2, a1, a2, 0.0, 0.0),
            transparent_torques(r, vector(0.0, 1.0, 1.0), q1, q2, v1, v2, a1, a2),
            strict=True)]
        got = transparent_torques(r, vector(0.3, 0.0, 0.0), q1, q2, v1, v2, a1, a2)
        assert got == pytest.approx((0.3 * inertial[0], 0.3 * inertial[1]), rel=1e-9,
                                    abs=1e-12)


def test_the_gains_come_through_the_trials_line():
    params = THESIS_SUBJECT.replace(assist="transparent",
                                    gains="transparent.inertia=0.3; transparent.friction=0.5")
    assert params.gains == "transparent.friction=0.5; transparent.inertia=0.3"
    assert built("transparent", params.gains) == TransparentGains(0.3, 0.5, 1.0)
    pipeline = TickPipeline(TrialPlan.build(params))
    guide = list(pipeline.vectors.guide)
    assert (guide[TC_ON], guide[TC_INERTIA], guide[TC_FRICTION]) == (1.0, 0.3, 0.5)
    assert pipeline.transparent == TransparentGains(0.3, 0.5, 1.0)
    group = assistance_group(params, None, np.empty((0, 0)))
    assert group == {"mode": "transparent", "level": 0.0, "inertia": 0.3, "friction": 0.5,
                     "stiffness": 1.0}
    rows = {row[0]: row for row in gain_rows()}
    assert rows["transparent.inertia"][1] == "0.7"
    assert "0–0.9" in rows["transparent.inertia"][2]


@pytest.mark.parametrize(("line", "needle"), [
    ("transparent.inertia=1", "transparent.inertia"),
    ("transparent.friction=1", "transparent.friction"),
    ("transparent.stiffness=-0.1", "transparent.stiffness"),
    ("transparent.mass=0.2", "a gain of transparent"),
])
def test_a_share_out_of_its_range_is_refused_by_name(line, needle):
    with pytest.raises(ParameterError, match="gains") as caught:
        TrialParameters(gains=line)
    assert needle in str(caught.value)


def test_other_modes_leave_the_transparent_part_off():
    for mode in ASSIST_MODES:
        pipeline = TickPipeline(TrialPlan.build(THESIS_SUBJECT.replace(assist=mode)))
        assert (list(pipeline.vectors.guide)[TC_ON] == 1.0) == (mode == "transparent")


def test_a_transparent_trial_has_level_zero_whatever_it_was_given():
    """Nothing in the mode acts on a level: the parameters, the pipeline and every tick's
    record say 0 (docs/data-format.md)."""
    params = THESIS_SUBJECT.replace(assist="transparent", assistance_level=0.7)
    assert params.assistance_level == 0.0
    assert TrialParameters.from_dict(params.to_dict()) == params
    pipeline = TickPipeline(TrialPlan.build(params))
    assert pipeline.assistance.level == 0.0
    with pytest.raises(ParameterError, match="assistance_level"):
        THESIS_SUBJECT.replace(assist="transparent", assistance_level=1.5)
    assert math.isclose(THESIS_SUBJECT.replace(assist="as-needed", assistance_level=0.7)
                        .assistance_level, 0.7)
