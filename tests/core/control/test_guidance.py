"""The as-needed guidance's law, tick by tick, on a straight path (core.control.guidance):
where its reference goes, what help it gives and never gives, what it learns and forgets.
Its closed-loop outcomes are in tests/app/trials/test_assistance_outcomes.py."""

import math

import numpy as np
import pytest

from core.control.assistance import PerformanceAssistance
from core.control.guidance import (
    GS_KEPT,
    GS_RHO,
    GS_U,
    GuidanceGains,
    guidance_command,
    state_size,
)
from core.errors import ParameterError
from core.robot import FRICTIONLESS, RobotModel
from core.robot_terms import jacobian_terms

PERIOD = 0.002
ROBOT = RobotModel(friction=FRICTIONLESS)
SPEED = 0.1  # m/s along +x


def straight_rows(n=2000, start=(-0.35, 0.30)):
    """A straight path along +x at SPEED, one row per tick: (x, y, vx, vy, dx, dy, …)."""
    rows = []
    for k in range(n):
        x = start[0] + SPEED * k * PERIOD
        rows.append((x, start[1], SPEED, 0.0, 1.0, 0.0) + (0.0,) * 6)
    return tuple(rows)


ROWS = straight_rows()


def at(x, y):
    return ROBOT.ik_terms(x, y)


def tick(gains, state, k, x, y, *, vx=0.0, vy=0.0, force=(0.0, 0.0), level=1.0):
    q1, q2 = at(x, y)
    j11, j12, j21, j22 = jacobian_terms(ROBOT.constants, q1, q2)
    det = j11 * j22 - j12 * j21
    qd1 = (j22 * vx - j12 * vy) / det
    qd2 = (-j21 * vx + j11 * vy) / det
    assist = PerformanceAssistance(ROBOT, level=level).constants
    c = gains.constants(period_s=PERIOD, repetition_s=len(ROWS) * PERIOD)
    return guidance_command(ROBOT.constants, c, assist, state, ROWS, 0, len(ROWS), 0, k, q1, q2,
                            qd1, qd2, *force)


def handle_force(q, tau_minus_base):
    """The force at the handle that the joint torques J_Rᵀ F stand for."""
    j11, j12, j21, j22 = jacobian_terms(ROBOT.constants, *q)
    t1, t2 = tau_minus_base
    det = j11 * j22 - j21 * j12
    return ((j22 * t1 - j21 * t2) / det, (-j12 * t1 + j11 * t2) / det)


def new_state(gains=None, reps=1):
    return [0.0] * state_size((gains or GuidanceGains()).bins, reps)


def test_a_patient_ahead_of_the_clock_is_neither_pulled_back_nor_along():
    g = GuidanceGains(friction_compensation=0.0)
    s = new_state(g)
    for k in range(41):  # a hand ten times faster than the clock: row 400 at tick 40
        x = ROWS[10 * k][0]
        sigma, _, b1, b2, o1, o2, *_ = tick(g, s, k, x, ROWS[0][1])
    assert sigma == 400
    assert (o1, o2) == (b1, b2)  # no help
    fx, fy = handle_force(at(x, ROWS[0][1]), (o1, o2))
    assert abs(fx) < 1e-9
    assert abs(fy) < 1e-9


def test_a_patient_less_than_the_delay_behind_is_left_alone():
    g = GuidanceGains(delay_s=0.3)
    s = new_state(g)
    sigma, _, b1, b2, o1, o2, *_ = tick(g, s, 100, ROWS[0][0], ROWS[0][1])  # 0.2 s behind
    assert sigma == 0
    assert (o1, o2) == (b1, b2)


def test_beyond_the_delay_the_robot_leads_along_the_path_within_its_limit():
    g = GuidanceGains(delay_s=0.3, friction_compensation=0.0, help_limit_N=5.0)
    s = new_state(g)
    k = 400  # the clock at row 400; the reference at 400 − 150 = 250
    q = at(ROWS[100][0], ROWS[0][1])
    sigma, _, b1, b2, o1, o2, *_ = tick(g, s, k, ROWS[100][0], ROWS[0][1])
    assert sigma == k - round(0.3 / PERIOD)
    fx, fy = handle_force(q, (o1 - b1, o2 - b2))
    lag = ROWS[sigma][0] - ROWS[100][0]
    expected = min(5.0, g.lead_stiffness_N_m * lag + g.lead_damping_Ns_m * SPEED)
    assert fx == pytest.approx(expected, rel=1e-9)
    assert abs(fy) < 1e-9  # along the path only
    assert fx <= 5.0 + 1e-9


def test_the_help_is_never_against_the_patient_and_level_zero_gives_none():
    g = GuidanceGains(delay_s=0.0, friction_compensation=0.0)
    for vx in (-0.5, 0.0, 0.05, 0.5, 2.0):  # even a hand rushing ahead of its reference
        s = new_state(g)
        q = at(ROWS[100][0], ROWS[0][1])
        _sigma, _, b1, b2, o1, o2, *_ = tick(g, s, 300, ROWS[100][0], ROWS[0][1], vx=vx)
        fx, _ = handle_force(q, (o1 - b1, o2 - b2))
        assert fx >= -1e-9
    s = new_state(g)
    _, _, b1, b2, o1, o2, *_ = tick(g, s, 300, ROWS[100][0], ROWS[0][1], level=0.0)
    assert (o1, o2) == (b1, b2)


def test_the_channel_pushes_back_across_the_path_and_damps_across_it():
    g = GuidanceGains(friction_compensation=0.0)
    y0 = ROWS[0][1]
    s = new_state(g)
    q = at(ROWS[50][0], y0 + 0.004)
    _, _, b1, b2, *_ = tick(g, s, 50, ROWS[50][0], y0 + 0.004)
    _, fy = handle_force(q, (b1, b2))
    assert fy == pytest.approx(-g.channel_stiffness_N_m * 0.004, rel=1e-6)
    s = new_state(g)
    _, _, b1, b2, *_ = tick(g, s, 50, ROWS[50][0], y0, vy=0.1)
    _fx, fy = handle_force(at(ROWS[50][0], y0), (b1, b2))
    assert fy == pytest.approx(-g.channel_damping_Ns_m * 0.1, rel=1e-6)


def test_relief_is_earned_inside_the_cone_and_lost_outside_it():
    g = GuidanceGains()
    s = new_state(g)
    x, y = ROWS[0][0], ROWS[0][1]
    for k in range(500):  # pushing along the path, on it: 1 s at 1/s
        tick(g, s, k, x, y, force=(2.0, 0.1))
    assert s[GS_RHO] == pytest.approx(g.relief_floor)
    for k in range(500, 520):  # pushing across it
        tick(g, s, k, x, y, force=(0.0, 2.0))
    assert s[GS_RHO] > g.relief_floor + 0.05


def test_the_feedforward_learns_from_lag_and_forgets_when_the_patient_keeps_up():
    g = GuidanceGains(delay_s=0.0, bins=4, forgetting=0.5, learning_N_m=100.0,
                      deadband_m=0.0)
    reps = 3
    rows_per_rep = len(ROWS) // reps
    s = new_state(g, reps)
    c = g.constants(period_s=PERIOD, repetition_s=rows_per_rep * PERIOD)
    assist = PerformanceAssistance(ROBOT).constants

    def visit(k, behind_rows):
        x = ROWS[max(k - behind_rows, 0)][0]
        q = at(x, ROWS[0][1])
        guidance_command(ROBOT.constants, c, assist, s, ROWS, 0, len(ROWS), 0, k, *q, 0.0, 0.0,
                         0.0, 0.0)

    for k in range(rows_per_rep):  # one repetition 10 rows (2 mm) behind
        visit(k, 10)
    visit(rows_per_rep, 0)
    learned = np.array(s[GS_U:GS_U + 4])
    assert (learned > 0.0).all()
    assert s[GS_KEPT] == 1
    for k in range(rows_per_rep + 1, 2 * rows_per_rep + 1):  # one keeping up
        visit(k, 0)
    assert np.allclose(s[GS_U:GS_U + 4], 0.5 * learned, rtol=0.05)


@pytest.mark.parametrize(("field", "value"), [
    ("channel_stiffness_N_m", -1.0), ("help_limit_N", 50.0), ("delay_s", math.nan),
    ("forgetting", 1.5), ("friction_compensation", 1.0), ("bins", 2.5), ("bins", True),
])
def test_gains_out_of_range_are_refused_by_name(field, value):
    with pytest.raises(ParameterError, match=field):
        GuidanceGains(**{field: value})


def test_gains_round_trip_through_plain_values():
    g = GuidanceGains(delay_s=0.5, bins=10)
    assert GuidanceGains.from_dict(g.to_dict()) == g
    with pytest.raises(ParameterError, match="unknown guidance gain"):
        GuidanceGains.from_dict({"stiffness": 1.0})
