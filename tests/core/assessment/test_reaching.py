"""Visually guided reaching's figures against hand computations on minimum-jerk reaches
built sample by sample (exact velocities passed in), and their invariance under moving
the whole table."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from core.assessment import FIGURES, task_figures
from core.assessment.reaching import VgrReach, vgr_figures, vgr_reaches
from core.errors import ParameterError
from core.reaches import Reach
from core.smoothness import ldlj, sparc

DT = 0.002
T_END = 3.0


def s_of(tau):
    """Minimum-jerk position share s(τ) = 10τ³ − 15τ⁴ + 6τ⁵."""
    return 10 * tau**3 - 15 * tau**4 + 6 * tau**5


def crossing(level):
    """τ < 0.5 where a minimum-jerk speed 30τ²(1−τ)² (peak 1.875) equals `level`."""
    return (1 - math.sqrt(1 - 4 * math.sqrt(level / 30))) / 2


def movement(t, parts, rest=(0.0, 0.0)):
    """Hand position and velocity of minimum-jerk sub-movements (t0 s, T s, displacement m)
    added onto a rest position."""
    position = np.tile(np.asarray(rest, float), (t.size, 1))
    velocity = np.zeros_like(position)
    for t0, duration, displacement in parts:
        tau = np.clip((t - t0) / duration, 0.0, 1.0)
        position += s_of(tau)[:, None] * np.asarray(displacement)
        rate = np.where((t > t0) & (t < t0 + duration),
                        (30 * tau**2 - 60 * tau**3 + 30 * tau**4) / duration, 0.0)
        velocity += rate[:, None] * np.asarray(displacement)
    return position, velocity


T = np.arange(round(T_END / DT)) * DT


def test_one_smooth_reach_with_a_known_reaction_and_posture_drift():
    # drifting 2 mm/s along y for the 500 ms before the target, still, then a 0.8 s reach
    position, velocity = movement(T, [(1.3, 0.8, (0.1, -0.001))])
    drift = (T >= 0.5) & (T < 1.0)
    velocity[drift, 1] += 0.002
    position[:, 1] += 0.002 * np.clip(T - 0.5, 0.0, 0.5)
    (reach,) = vgr_reaches(T, position, [Reach(1.0, (0.0, 0.0), (0.1, 0.0))],
                           velocity_m_s=velocity)
    tau = crossing(0.1875)
    assert reach.posture_speed_m_s == pytest.approx(0.002, rel=1e-12)
    assert reach.reaction_time_s == pytest.approx(0.3 + tau * 0.8, abs=1e-4)
    assert reach.movement_time_s == pytest.approx((1 - 2 * tau) * 0.8, abs=2e-4)
    assert reach.max_speed_m_s == pytest.approx(1.875 * math.hypot(0.1, 0.001) / 0.8)
    distance = math.hypot(0.1, 0.001)
    assert reach.path_length_ratio == pytest.approx(distance * (1 - 2 * s_of(tau)) / 0.1,
                                                    abs=1e-4)
    assert reach.initial_direction_error_rad == pytest.approx(0.0, abs=1e-9)
    assert reach.initial_distance_ratio == 1.0
    assert reach.initial_speed_ratio == 1.0
    assert reach.speed_maxima_count == 1
    assert reach.min_max_speed_difference_m_s == 0.0
    assert reach.initial_end_s == reach.offset_s
    window = (reach.onset_s <= T) & (reach.offset_s >= T)
    speed = np.hypot(*velocity.T)
    assert reach.sparc == pytest.approx(sparc(speed[window], DT), rel=1e-12)
    assert reach.ldlj == pytest.approx(ldlj(velocity[window], DT), rel=1e-12)


def two_part_reach(alpha, first=0.08, t1=0.6, t2=0.5):
    """A primary sub-movement `first` m long at `alpha` rad off the target line (1.3 s to
    1.3 + t1), then a correction onto the target (0.1, 0) lasting t2."""
    aim = first * np.array([math.cos(alpha), math.sin(alpha)])
    rest = np.array([0.1, 0.0]) - aim
    parts = [(1.3, t1, aim), (1.3 + t1, t2, rest)]
    return parts, aim, rest


def test_a_reach_with_a_wrong_first_aim_and_a_correction():
    alpha = 0.3
    parts, aim, rest = two_part_reach(alpha)
    position, velocity = movement(T, parts)
    (reach,) = vgr_reaches(T, position, [Reach(1.0, (0.0, 0.0), (0.1, 0.0))],
                           velocity_m_s=velocity)
    # by hand: threshold 10 % of the primary's peak 1.875·0.08/0.6 = 0.25 m/s
    peak1, d2 = 1.875 * 0.08 / 0.6, float(np.hypot(*rest))
    peak2 = 1.875 * d2 / 0.5
    tau_on = crossing(0.1875)
    tau_off2 = 1 - crossing(0.1 * peak1 / (d2 / 0.5))
    onset, offset = 1.3 + tau_on * 0.6, 1.9 + tau_off2 * 0.5
    assert reach.onset_s == pytest.approx(onset, abs=1e-4)
    assert reach.offset_s == pytest.approx(offset, abs=1e-4)
    assert reach.initial_end_s == pytest.approx(1.9, abs=1e-9)  # the speed's zero between
    at_onset = s_of(tau_on) * aim
    to_target = np.array([0.1, 0.0]) - at_onset
    expected_angle = math.atan2(to_target[0] * (aim - at_onset)[1]
                                - to_target[1] * (aim - at_onset)[0],
                                float(to_target @ (aim - at_onset)))
    assert expected_angle > 0.3  # seen from the onset, the aim is further off the line
    assert reach.initial_direction_error_rad == pytest.approx(expected_angle, abs=1e-6)
    initial = 0.08 * (1 - s_of(tau_on))
    whole = initial + d2 * s_of(tau_off2)
    assert reach.initial_distance_ratio == pytest.approx(initial / whole, abs=1e-4)
    assert reach.path_length_ratio == pytest.approx(whole / 0.1, abs=1e-4)
    assert reach.initial_speed_ratio == 1.0
    assert reach.max_speed_m_s == pytest.approx(peak1)
    assert reach.speed_maxima_count == 2
    assert reach.min_max_speed_difference_m_s == pytest.approx(peak2, abs=1e-12)
    assert reach.reaction_time_s == pytest.approx(onset - 1.0, abs=1e-4)
    assert reach.movement_time_s == pytest.approx(offset - onset, abs=2e-4)


def test_a_correction_faster_than_the_first_aim_sets_the_initial_speed_ratio():
    parts, _, rest = two_part_reach(0.5, first=0.03, t1=0.6, t2=0.3)
    position, velocity = movement(T, parts)
    (reach,) = vgr_reaches(T, position, [Reach(1.0, (0.0, 0.0), (0.1, 0.0))],
                           velocity_m_s=velocity)
    peak1, peak2 = 1.875 * 0.03 / 0.6, 1.875 * float(np.hypot(*rest)) / 0.3
    assert reach.max_speed_m_s == pytest.approx(peak2)
    assert reach.initial_speed_ratio == pytest.approx(peak1 / peak2)
    assert reach.min_max_speed_difference_m_s == pytest.approx(peak2)


def test_no_reaction_no_end_and_their_counts():
    reaches = [Reach(0.2, (0.0, 0.0), (0.1, 0.0)),    # the hand never moves
               Reach(1.0, (0.0, 0.0), (0.0, 0.05)),   # moving when the target appears
               Reach(2.0, (0.0, 0.05), (0.1, 0.05))]  # stops 3 cm short
    position, velocity = movement(T, [(0.9, 0.6, (0.0, 0.05)), (2.2, 0.5, (0.07, 0.0))])
    result = vgr_reaches(T, position, reaches, ends_s=[0.8, 1.9, math.inf],
                         velocity_m_s=velocity)
    assert [r.reacted for r in result] == [False, False, True]
    assert [r.ended for r in result] == [False, True, False]
    assert result[0].max_speed_m_s == 0.0
    assert math.isnan(result[1].reaction_time_s)
    assert math.isnan(result[1].movement_time_s)
    short = result[2]
    assert short.reaction_time_s == pytest.approx(0.2 + crossing(0.1875) * 0.5, abs=1e-4)
    assert math.isnan(short.movement_time_s)
    assert math.isnan(short.path_length_ratio)
    assert short.initial_distance_ratio == 1.0  # one peak: the initial phase is the whole
    assert short.initial_speed_ratio == 1.0
    assert short.initial_direction_error_rad == 0.0
    figures = vgr_figures(result)
    assert figures["vgr_no_reaction_count"] == 2
    assert figures["vgr_no_movement_end_count"] == 2
    assert figures["vgr_reaction_time_s"] == short.reaction_time_s
    assert math.isnan(figures["vgr_movement_time_s"])


def test_the_task_figures_are_means_over_defined_reaches_keyed_as_the_catalogue():
    nan = math.nan
    one = VgrReach(0.0, 0.3, 1.0, 0.8, 0.001, 0.3, -0.2, 0.9, 1.0, 1.0, 0.0, 0.7, 1.1, 0.4,
                   -1.6, -4.0)
    two = VgrReach(2.0, 2.5, nan, 3.0, 0.003, 0.5, 0.1, nan, 0.8, nan, nan, nan, nan, 0.2,
                   -2.0, -6.0)
    three = VgrReach(4.0, nan, nan, nan, nan, nan, nan, nan, nan, nan, nan, nan, nan, 0.0,
                     nan, nan)
    figures = vgr_figures([one, two, three])
    assert list(figures) == [spec.key for spec in task_figures("reaching")]
    assert figures["vgr_posture_speed_m_s"] == pytest.approx(0.002)
    assert figures["vgr_reaction_time_s"] == pytest.approx(0.4)
    assert figures["vgr_initial_direction_error_rad"] == pytest.approx(0.15)  # |−0.2|, |0.1|
    assert figures["vgr_initial_distance_ratio"] == 0.9
    assert figures["vgr_initial_speed_ratio"] == pytest.approx(0.9)
    assert figures["vgr_movement_time_s"] == 0.7
    assert figures["vgr_max_speed_m_s"] == pytest.approx(0.2)
    assert figures["vgr_sparc"] == pytest.approx(-1.8)
    assert figures["vgr_ldlj"] == -5.0
    assert figures["vgr_no_reaction_count"] == 1
    assert figures["vgr_no_movement_end_count"] == 2
    assert all(key in FIGURES for key in figures)


def test_the_speed_from_positions_alone_finds_the_same_reach():
    position, velocity = movement(T, [(1.3, 0.8, (0.1, 0.0))])
    (exact,) = vgr_reaches(T, position, [Reach(1.0, (0.0, 0.0), (0.1, 0.0))],
                           velocity_m_s=velocity)
    (derived,) = vgr_reaches(T, position, [Reach(1.0, (0.0, 0.0), (0.1, 0.0))])
    assert derived.reaction_time_s == pytest.approx(exact.reaction_time_s, abs=5e-3)
    assert derived.speed_maxima_count == 1
    assert derived.path_length_ratio == pytest.approx(exact.path_length_ratio, abs=1e-2)


def test_bad_inputs_are_refused_by_name():
    position, _velocity = movement(T, [(1.3, 0.8, (0.1, 0.0))])
    reach = Reach(1.0, (0.0, 0.0), (0.1, 0.0))
    with pytest.raises(ParameterError, match="position_m"):
        vgr_reaches(T, position[:-1], [reach])
    with pytest.raises(ParameterError, match="ends_s"):
        vgr_reaches(T, position, [reach], ends_s=[0.5])
    with pytest.raises(ParameterError, match="reaches"):
        vgr_reaches(T, position, [reach, Reach(0.5, (0.0, 0.0), (0.1, 0.0))])
    with pytest.raises(ParameterError, match="target_radius_m"):
        vgr_reaches(T, position, [reach], target_radius_m=0.0)


def test_a_window_end_cuts_off_the_return_movement():
    # out to the target and back to the centre; the return's cue at 2.5 s ends the reach
    position, velocity = movement(T, [(1.3, 0.8, (0.1, 0.0)), (2.6, 0.3, (-0.1, 0.0))])
    reach = Reach(1.0, (0.0, 0.0), (0.1, 0.0))
    (cut,) = vgr_reaches(T, position, [reach], ends_s=[2.5], velocity_m_s=velocity)
    (whole,) = vgr_reaches(T, position, [reach], velocity_m_s=velocity)
    assert cut.max_speed_m_s == pytest.approx(1.875 * 0.1 / 0.8)
    assert whole.max_speed_m_s == pytest.approx(1.875 * 0.1 / 0.3)  # the return's


@settings(max_examples=25, deadline=None)
@given(alpha=st.floats(-0.6, 0.6), turn=st.floats(-math.pi, math.pi),
       shift=st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3)),
       scale=st.floats(0.5, 2.0))
def test_times_ratios_and_counts_do_not_depend_on_where_the_table_is(alpha, turn, shift,
                                                                    scale):
    parts, _, _ = two_part_reach(alpha)
    position, velocity = movement(T, parts)
    reach = Reach(1.0, (0.0, 0.0), (0.1, 0.0))
    (plain,) = vgr_reaches(T, position, [reach], velocity_m_s=velocity)
    rotation = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    moved = scale * position @ rotation.T + np.asarray(shift)
    target = scale * rotation @ np.array([0.1, 0.0]) + np.asarray(shift)
    (other,) = vgr_reaches(T, moved, [Reach(1.0, shift, tuple(target))],
                           velocity_m_s=scale * velocity @ rotation.T,
                           target_radius_m=0.01 * scale)
    for name in ("onset_s", "offset_s", "initial_end_s", "reaction_time_s",
                 "initial_direction_error_rad", "initial_distance_ratio",
                 "initial_speed_ratio", "speed_maxima_count", "movement_time_s",
                 "path_length_ratio", "sparc", "ldlj"):
        assert getattr(other, name) == pytest.approx(getattr(plain, name), rel=1e-6,
                                                      abs=1e-9), name
    assert other.max_speed_m_s == pytest.approx(scale * plain.max_speed_m_s)


@settings(max_examples=20, deadline=None)
@given(distance=st.floats(0.03, 0.25), duration=st.floats(0.4, 1.5))
def test_a_reachs_smoothness_does_not_depend_on_its_size_or_pace(distance, duration):
    # SPARC and LDLJ are dimensionless (Balasubramanian et al. 2015): a minimum-jerk reach
    # scores the same whatever its length, and its pace changes them only by where the
    # samples fall about the 10 % crossings
    def scores(d, t):
        position, velocity = movement(T, [(1.3, t, (d, 0.0))])
        (reach,) = vgr_reaches(T, position, [Reach(1.0, (0.0, 0.0), (d, 0.0))],
                               velocity_m_s=velocity)
        return reach.sparc, reach.ldlj

    reference = scores(0.1, 0.8)
    assert scores(distance, 0.8) == pytest.approx(reference, rel=1e-9)
    paced = scores(distance, duration)
    assert paced[0] == pytest.approx(reference[0], abs=0.02)
    assert paced[1] == pytest.approx(reference[1], abs=0.06)


def test_encoder_noise_adds_no_speed_maxima_when_the_speed_comes_from_positions():
    # 20 µm of noise quantised to 10 µm counts: the 10 Hz smoothing keeps one peak
    rng = np.random.default_rng(0)
    position, _ = movement(T, [(1.3, 0.8, (0.1, 0.0))])
    for _ in range(5):
        noisy = np.round((position + rng.normal(0.0, 2e-5, position.shape)) / 1e-5) * 1e-5
        (reach,) = vgr_reaches(T, noisy, [Reach(1.0, (0.0, 0.0), (0.1, 0.0))])
        assert reach.speed_maxima_count == 1
        assert reach.initial_distance_ratio == pytest.approx(1.0)
        assert reach.reaction_time_s == pytest.approx(0.3 + crossing(0.1875) * 0.8, abs=2e-3)


def test_a_target_shown_after_the_recording_stopped_is_a_reach_with_nothing_found():
    # a trial stopped early: the last targets came after its last sample
    position, velocity = movement(T, [(1.3, 0.8, (0.1, 0.0))])
    late = [Reach(1.0, (0.0, 0.0), (0.1, 0.0)), Reach(T_END + 2.0, (0.1, 0.0), (0.0, 0.0))]
    first, after = vgr_reaches(T, position, late, velocity_m_s=velocity)
    assert first.ended
    assert not after.reacted
    assert not after.ended
    assert math.isnan(after.posture_speed_m_s)
    assert math.isnan(after.max_speed_m_s)
    assert vgr_figures([first, after])["vgr_no_reaction_count"] == 1


sub_movement = st.tuples(st.floats(0.0, 2.8), st.floats(0.1, 1.0),
                         st.tuples(st.floats(-0.1, 0.1), st.floats(-0.1, 0.1)))


@settings(max_examples=60, deadline=None)
@given(parts=st.lists(sub_movement, min_size=0, max_size=5),
       ons=st.lists(st.floats(0.0, 2.9), min_size=1, max_size=4, unique=True),
       radius=st.floats(0.002, 0.05), derived=st.booleans())
def test_any_movement_gives_figures_in_their_ranges_and_no_warning(parts, ons, radius,
                                                                   derived):
    position, velocity = movement(T, parts)
    ons = sorted(ons)
    reaches = [Reach(on, (0.0, 0.0), (0.07, 0.02)) for on in ons]
    result = vgr_reaches(T, position, reaches, velocity_m_s=None if derived else velocity,
                         target_radius_m=radius)
    for reach in result:
        if reach.reacted:
            assert reach.on_s <= reach.onset_s <= reach.initial_end_s
            assert 0.0 < reach.initial_speed_ratio <= 1.0
            assert reach.reaction_time_s >= 0.0
        if reach.reacted and reach.ended:
            assert reach.initial_end_s <= reach.offset_s
            assert reach.movement_time_s > 0.0
            assert reach.speed_maxima_count >= 1
            assert reach.min_max_speed_difference_m_s >= 0.0
            assert reach.path_length_ratio >= 0.0
        if math.isfinite(reach.initial_distance_ratio):
            assert 0.0 <= reach.initial_distance_ratio <= 1.0 + 1e-12
    figures = vgr_figures(result)
    assert figures["vgr_no_reaction_count"] == sum(not r.reacted for r in result) <= len(ons)
