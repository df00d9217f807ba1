"""Circle drawing's figures against hand computations on ellipses of known axes and joint
angles of known phase, and their invariances."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from core.assessment import circle_key, task_figures
from core.assessment.circle import circle_figures, circle_task_figures
from core.errors import ParameterError

N = 2000  # samples per lap, a multiple of 4: the ends of both axes are samples
DURATION = 4.0


def ellipse(a, b, turn=0.0, centre=(0.0, 0.4), laps=1, way=1):
    """Positions and exact velocities of an ellipse of semi-axes a, b drawn at an even
    angular rate, its a-axis `turn` rad from x; `way` −1 draws it clockwise."""
    t = np.arange(N * laps) * (DURATION / N)
    phase = way * 2 * math.pi * t / DURATION
    rate = way * 2 * math.pi / DURATION
    local = np.column_stack([a * np.cos(phase), b * np.sin(phase)])
    local_v = np.column_stack([-a * rate * np.sin(phase), b * rate * np.cos(phase)])
    rotation = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    return t, local @ rotation.T + np.asarray(centre), local_v @ rotation.T


def angles(t, lag, shoulder=(0.6, 0.2), elbow=(1.4, 0.3)):
    """Shoulder and elbow angles oscillating once a lap, the elbow `lag` rad behind."""
    phase = 2 * math.pi * t / DURATION
    return np.column_stack([shoulder[0] + shoulder[1] * np.sin(phase),
                            elbow[0] + elbow[1] * np.sin(phase - lag)])


def test_an_ellipse_of_known_axes():
    t, position, velocity = ellipse(0.10, 0.06, turn=0.4)
    figures = circle_figures(t, position, angles(t, math.pi / 3), velocity_m_s=velocity)
    assert figures["circle_ratio"] == pytest.approx(0.6, abs=1e-9)
    # r = cos(lag) over whole laps sampled evenly
    assert figures["circle_joint_independence"] == pytest.approx(1 - 0.5, abs=1e-9)
    chords = np.hypot(*np.diff(position, axis=0).T).sum()
    assert figures["circle_mean_speed_m_s"] == pytest.approx(chords / (t[-1] - t[0]))
    # Ramanujan's perimeter of the ellipse, less the one chord that closes the lap
    perimeter = math.pi * (3 * 0.16 - math.sqrt((0.3 + 0.06) * (0.1 + 0.18)))
    assert chords == pytest.approx(perimeter * (N - 1) / N, abs=2e-4)


def test_a_circle_at_constant_speed_has_the_ldlj_of_a_lap():
    # |d²v/dt²|² = R²ω⁶, peak speed Rω, one lap ωT = 2π: LDLJ = −ln((ωT)⁴) = −4 ln 2π
    t, position, velocity = ellipse(0.08, 0.08)
    figures = circle_figures(t, position, angles(t, math.pi / 2), velocity_m_s=velocity)
    assert figures["circle_ratio"] == pytest.approx(1.0, abs=1e-9)
    assert figures["circle_joint_independence"] == pytest.approx(1.0, abs=1e-9)
    assert figures["circle_ldlj"] == pytest.approx(-4 * math.log(2 * math.pi), rel=2e-3)
    assert figures["circle_mean_speed_m_s"] == pytest.approx(
        N * 2 * 0.08 * math.sin(math.pi / N) * (N - 1) / N / (t[-1] - t[0]))


def test_joints_locked_in_one_synergy_draw_a_line_and_score_zero():
    t, position, velocity = ellipse(0.10, 0.0)
    figures = circle_figures(t, position, angles(t, 0.0), velocity_m_s=velocity)
    assert figures["circle_ratio"] == pytest.approx(0.0, abs=1e-12)
    assert figures["circle_joint_independence"] == pytest.approx(0.0, abs=1e-12)
    opposite = circle_figures(t, position, angles(t, math.pi), velocity_m_s=velocity)
    assert opposite["circle_joint_independence"] == pytest.approx(0.0, abs=1e-12)


def test_a_hand_that_never_moved():
    t = np.arange(500) * 0.002
    still = np.tile([0.0, 0.4], (500, 1))
    figures = circle_figures(t, still, np.tile([0.5, 1.2], (500, 1)))
    assert math.isnan(figures["circle_ratio"])
    assert math.isnan(figures["circle_joint_independence"])
    assert math.isnan(figures["circle_sparc"])
    assert math.isnan(figures["circle_ldlj"])
    assert figures["circle_mean_speed_m_s"] == 0.0


def test_the_task_keeps_each_way_and_their_mean():
    t, position, velocity = ellipse(0.10, 0.08, way=-1)
    cw = circle_figures(t, position, angles(t, math.pi / 2), velocity_m_s=velocity)
    t, position, velocity = ellipse(0.10, 0.05)
    ccw = circle_figures(t, position, angles(t, math.pi / 3), velocity_m_s=velocity)
    figures = circle_task_figures(cw, ccw)
    assert list(figures) == [spec.key for spec in task_figures("circle")]
    assert figures["circle_ratio_cw"] == pytest.approx(0.8)
    assert figures["circle_ratio_ccw"] == pytest.approx(0.5)
    assert figures["circle_ratio"] == pytest.approx(0.65)
    assert figures["circle_joint_independence"] == pytest.approx((1.0 + 0.5) / 2)
    assert figures[circle_key("circle_mean_speed_m_s", "cw")] == cw["circle_mean_speed_m_s"]
    ccw["circle_ratio"] = math.nan
    assert circle_task_figures(cw, ccw)["circle_ratio"] == pytest.approx(0.8)


def test_bad_inputs_are_refused_by_name():
    t, position, _velocity = ellipse(0.1, 0.1)
    with pytest.raises(ParameterError, match="joint_angles_rad"):
        circle_figures(t, position, angles(t, 0.0)[:-1])
    bad = position.copy()
    bad[7, 0] = math.nan
    with pytest.raises(ParameterError, match="position_m"):
        circle_figures(t, bad, angles(t, 0.0))
    with pytest.raises(ParameterError, match="way"):
        circle_key("circle_ratio", "left")


def test_speed_from_positions_alone_agrees_with_the_exact_one():
    t, position, velocity = ellipse(0.10, 0.06, laps=2)
    exact = circle_figures(t, position, angles(t, 1.0), velocity_m_s=velocity)
    derived = circle_figures(t, position, angles(t, 1.0))
    assert derived["circle_ratio"] == exact["circle_ratio"]
    assert derived["circle_mean_speed_m_s"] == exact["circle_mean_speed_m_s"]
    # the smoothing's ends bend a path cut at full speed: only the middle agrees
    assert math.isfinite(derived["circle_ldlj"])
    assert math.isfinite(derived["circle_sparc"])


@settings(max_examples=30, deadline=None)
@given(b=st.floats(0.01, 0.1), turn=st.floats(-math.pi, math.pi),
       shift=st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5)), scale=st.floats(0.2, 5.0),
       lag=st.floats(0.0, math.pi), offset=st.floats(-2.0, 2.0), sign=st.sampled_from([-1, 1]))
def test_invariant_under_moving_turning_and_scaling(b, turn, shift, scale, lag, offset, sign):
    t, position, velocity = ellipse(0.1, b)
    joints = angles(t, lag)
    plain = circle_figures(t, position, joints, velocity_m_s=velocity)
    rotation = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    moved = circle_figures(t, scale * position @ rotation.T + np.asarray(shift),
                           np.column_stack([sign * joints[:, 0] + offset, joints[:, 1]]),
                           velocity_m_s=scale * velocity @ rotation.T)
    assert moved["circle_ratio"] == pytest.approx(plain["circle_ratio"], rel=1e-9, abs=1e-12)
    assert moved["circle_ratio"] == pytest.approx(b / 0.1, rel=1e-9)
    assert moved["circle_joint_independence"] == pytest.approx(
        plain["circle_joint_independence"], abs=1e-9)
    assert moved["circle_joint_independence"] == pytest.approx(1 - abs(math.cos(lag)),
                                                                abs=1e-9)
    assert moved["circle_sparc"] == pytest.approx(plain["circle_sparc"], rel=1e-9)
    assert moved["circle_ldlj"] == pytest.approx(plain["circle_ldlj"], rel=1e-9)
    assert moved["circle_mean_speed_m_s"] == pytest.approx(
        scale * plain["circle_mean_speed_m_s"], rel=1e-9)


@settings(max_examples=40, deadline=None)
@given(coefficients=st.lists(st.floats(-0.05, 0.05), min_size=8, max_size=8),
       joints=st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4))
def test_any_drawing_gives_figures_in_their_ranges(coefficients, joints):
    t = np.arange(1000) * 0.004
    w = 2 * math.pi * t / 4.0
    a = coefficients
    position = np.column_stack([a[0] * np.cos(w) + a[1] * np.sin(w) + a[2] * np.cos(2 * w)
                                + a[3] * np.sin(3 * w),
                                0.4 + a[4] * np.cos(w) + a[5] * np.sin(w)
                                + a[6] * np.sin(2 * w) + a[7] * np.cos(3 * w)])
    angles = np.column_stack([joints[0] * np.sin(w) + joints[1] * np.cos(2 * w),
                              joints[2] * np.cos(w) + joints[3] * np.sin(w)])
    figures = circle_figures(t, position, angles)
    for key in ("circle_ratio", "circle_joint_independence"):
        assert math.isnan(figures[key]) or 0.0 <= figures[key] <= 1.0
    assert figures["circle_mean_speed_m_s"] >= 0.0
    assert math.isnan(figures["circle_sparc"]) or figures["circle_sparc"] < 0.0


def drawn_by_speed(speed_m_s, dt_s, radius=0.07, centre=(0.0, 0.4)):
    """Positions round a circle walked at the speeds given (arc length by the trapezoid
    rule) and the shoulder and elbow angles a lap's phase apart."""
    arc = np.concatenate(([0.0], np.cumsum((speed_m_s[1:] + speed_m_s[:-1]) / 2 * dt_s)))
    phase = arc / radius
    position = np.column_stack((centre[0] + radius * np.cos(phase),
                                centre[1] + radius * np.sin(phase)))
    joints = np.column_stack((0.6 + 0.2 * np.sin(phase), 1.4 + 0.3 * np.sin(phase - 1.0)))
    return position, joints


def test_the_smoothness_runs_to_rest_and_the_rest_over_the_drawing():
    """`drawing` marks the circle's samples: ratio, independence and mean speed are the
    drawing's alone (the rest after it changes none of them), SPARC and LDLJ run over the
    rest too."""
    t, position, velocity = ellipse(0.10, 0.06, laps=2)
    alone = circle_figures(t, position, angles(t, 1.0), velocity_m_s=velocity)
    rest = 500
    t2 = np.arange(t.size + rest) * (DURATION / N)
    position2 = np.vstack((position, np.tile(position[-1], (rest, 1))))
    velocity2 = np.vstack((velocity, np.zeros((rest, 2))))
    angles2 = np.vstack((angles(t, 1.0), np.tile(angles(t, 1.0)[-1], (rest, 1))))
    drawing = np.arange(t2.size) < t.size
    both = circle_figures(t2, position2, angles2, velocity_m_s=velocity2, drawing=drawing)
    for key in ("circle_ratio", "circle_joint_independence", "circle_mean_speed_m_s"):
        assert both[key] == alone[key], key
    everything = circle_figures(t2, position2, angles2, velocity_m_s=velocity2)
    for key in ("circle_sparc", "circle_ldlj"):
        assert both[key] == everything[key], key
    assert both["circle_ldlj"] != alone["circle_ldlj"]
    with pytest.raises(ParameterError, match="drawing"):
        circle_figures(t2, position2, angles2, drawing=np.zeros(t2.size))


def test_a_circle_drawn_in_pieces_is_less_smooth_and_a_small_ripple_is_not_seen():
    """Five laps at 0.11 m/s from rest to rest, evenly or with the speed rippling at 2.3 Hz
    (submovements): a ripple of a quarter of the speed makes the circle less smooth; one
    of 6 % leaves SPARC where it was, its line in the spectrum (3 % of the mean's) under
    SPARC's 5 % threshold, so the adaptive cut-off stays below it (docs/assessments.md,
    Submovements)."""
    dt = 0.002
    t = np.arange(0.0, 21.0, dt)
    ramp = np.clip(t / 0.3, 0.0, 1.0) * np.clip((20.3 - t) / 0.3, 0.0, 1.0)
    sparc = {}
    for ripple in (0.0, 0.06, 0.25):
        position, joints = drawn_by_speed(0.11 * ramp * (1.0 + ripple * np.sin(
            2 * math.pi * 2.3 * t)), dt)
        sparc[ripple] = circle_figures(t, position, joints, drawing=t < 20.0)["circle_sparc"]
    assert sparc[0.25] < sparc[0.0] - 0.5
    assert sparc[0.06] == pytest.approx(sparc[0.0], abs=0.01)
