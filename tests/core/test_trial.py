"""Trial parameters: ranges, round trips, and reachability with the numbers."""

import math

import numpy as np
import pytest

from core.errors import ParameterError, UnreachableError
from core.trial import THESIS_AS_PRINTED, THESIS_SUBJECT, TrialParameters
from core.trial_check import check_trial


def test_thesis_subject_is_reachable_with_its_ranges():
    check = check_trial(THESIS_SUBJECT)
    assert check.ok
    lo, hi = np.degrees(check.range_of(check.isb_angles_rad[:, 0]))
    # the ISB shoulder range over the D is close to the thesis's measured 42.17°
    assert 35.0 < hi - lo < 45.0
    lo_e, hi_e = np.degrees(check.range_of(check.isb_angles_rad[:, 1]))
    assert 0.0 < lo_e < hi_e < 140.0


def test_thesis_as_printed_is_refused_with_the_numbers():
    check = check_trial(THESIS_AS_PRINTED)
    assert not check.ok
    assert check.problems[0].startswith(
        "point (-0.30, 0.20) m is 0.68 m from the shoulder; this arm reaches 0.61 m"
    )
    assert 0.2 < (~check.arm_ok).mean() < 0.6, "only part of the D is out of reach"
    with pytest.raises(UnreachableError, match=r"0\.68 m from the shoulder"):
        check.require_ok()


def test_unreachable_points_are_marked_for_the_preview():
    check = check_trial(THESIS_AS_PRINTED)
    far = check.shoulder_distance_m > check.arm.reach_max_m
    assert np.all(~check.arm_ok[far])
    assert np.isnan(check.isb_angles_rad[~check.arm_ok]).all()


def test_nearly_straight_arm_is_refused():
    # Push the D until its far end is within reach but with the elbow nearly straight.
    params = THESIS_SUBJECT.replace(centre_m=(-0.33, 0.25))
    check = check_trial(params)
    assert not check.ok
    assert "almost straight" in check.problems[0] or "reaches" in check.problems[0]


def test_robot_limits_are_checked():
    params = THESIS_SUBJECT.replace(centre_m=(0.0, 0.66), shoulder_m=(0.0, 1.0))
    check = check_trial(params)
    assert not check.robot_ok.all()
    assert any("robot" in p or "fold" in p for p in check.problems)


def test_too_fast_is_refused():
    check = check_trial(THESIS_SUBJECT.replace(duration_s=1.0, timing="minimum_jerk"))
    assert any("peak speed" in p for p in check.problems)


def test_to_dict_round_trip():
    params = THESIS_SUBJECT.replace(shape="circle", repetitions=3, side="left",
                                    shoulder_m=(-0.4, 0.7))
    assert TrialParameters.from_dict(params.to_dict()) == params


def test_unknown_keys_are_refused_by_name():
    with pytest.raises(ParameterError, match="speed_m_s"):
        TrialParameters.from_dict({"speed_m_s": 1.0})


@pytest.mark.parametrize(
    ("field", "value", "allowed"),
    [
        ("radius_m", 0.0, r"\[0.02, 0.25\] m"),
        ("radius_m", float("nan"), "finite"),
        ("duration_s", -4.0, r"\[1, 120\] s"),
        ("duration_s", float("inf"), "finite"),
        ("body_mass_kg", 15.0, r"\[20, 250\] kg"),
        ("body_mass_kg", 260.0, r"\[20, 250\] kg"),
        ("upper_arm_m", 0.0, r"\[0.15, 0.5\] m"),
        ("forearm_m", -0.3, r"\[0.15, 0.5\] m"),
        ("tolerance_rad", math.radians(120), "90°"),
        ("assistance_level", 1.5, r"\[0, 1\]"),
        ("repetitions", 0, r"\[1, 100\]"),
        ("repetitions", 2.5, "whole number"),
        ("shape", "square", "one of d, circle"),
        ("controller", "pid", "one of smc, ctpid"),
        ("centre_m", (0.1,), "pair"),
        ("shoulder_m", (0.0, float("nan")), "finite"),
    ],
)
def test_bad_parameters_name_field_value_and_range(field, value, allowed):
    with pytest.raises(ParameterError, match=field) as info:
        THESIS_SUBJECT.replace(**{field: value})
    assert info.match(allowed)


@pytest.mark.parametrize("shape", ["d", "circle", "reach", "targets", "figure8"])
def test_every_shape_can_be_checked(shape):
    params = THESIS_SUBJECT.replace(shape=shape, radius_m=0.06, duration_s=6.0)
    check = check_trial(params)
    assert check.points_m.shape[0] > 10
    assert check.path_length_m > 0


@pytest.mark.parametrize(("field", "value"), [
    ("radius_m", "0.1"), ("duration_s", True), ("assistance_level", None),
    ("repetitions", 3.0), ("repetitions", "3"),
])
def test_a_number_given_as_text_or_a_flag_is_refused_by_name(field, value):
    with pytest.raises(ParameterError, match=field):
        TrialParameters(**{field: value})


def test_numpy_numbers_become_plain_ones_that_json_and_hdf5_take():
    import json

    p = TrialParameters(repetitions=np.int64(3), radius_m=np.float32(0.08))
    assert type(p.repetitions) is int
    assert type(p.radius_m) is float
    assert json.loads(json.dumps(p.to_dict()))["repetitions"] == 3


def test_a_learned_model_is_named_for_the_computed_torque_pid_only():
    chosen = TrialParameters(controller="ctpid", learned_model="delan-robot.v2",
                             learned_model_sha256="0123456789abcdef" * 4)
    assert TrialParameters.from_dict(chosen.to_dict()) == chosen
    with pytest.raises(ParameterError, match="computed-torque PID"):
        TrialParameters(controller="smc", learned_model="delan-robot")
    with pytest.raises(ParameterError, match="a model file's name"):
        TrialParameters(controller="ctpid", learned_model="../../etc/passwd")
    with pytest.raises(ParameterError, match="64 lower-case hex digits"):
        TrialParameters(controller="ctpid", learned_model="m", learned_model_sha256="abc")
    with pytest.raises(ParameterError, match="a hash belongs to a model"):
        TrialParameters(controller="ctpid", learned_model_sha256="0" * 64)


def test_a_point_just_out_of_reach_reads_as_out_of_reach():
    """'0.61 m from the shoulder; this arm reaches 0.61 m' said nothing: when the two round
    alike they get one decimal more."""
    far = THESIS_SUBJECT.replace(shape="figure8")
    problem = check_trial(far).problems[0]
    assert "is 0.613 m from the shoulder; this arm reaches 0.610 m" in problem
