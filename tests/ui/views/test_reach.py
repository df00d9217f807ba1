"""A trial's check as the Parameters tab shows it, without Qt: the picture of what can be
reached, the summary, and each problem under its field."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.robot import RobotModel
from core.trial import THESIS_SUBJECT
from core.trial_check import ELBOW_FLEXION_RANGE_RAD, check_trial
from ui.views.reach import (
    UNREACHABLE_MARK_EVERY,
    check_summary,
    field_key,
    problem_fields,
    reach_picture,
    robot_workspace,
)

AS_PRINTED = THESIS_SUBJECT.replace(shoulder_m=(0.12, 0.73))  # section 3.6: out of reach


def test_the_unreachable_part_is_crossed_out_in_cm():
    check = check_trial(AS_PRINTED)
    assert not check.ok
    picture = reach_picture(check, AS_PRINTED.shoulder_m)
    points = check.points_m * 100
    bad = points[~check.reachable]
    np.testing.assert_allclose(picture.crosses_cm, bad[::UNREACHABLE_MARK_EVERY])
    # The two lines together draw every point; each holds NaN where only the other draws.
    drawn = np.isfinite(picture.reachable_cm[:, 0]) | np.isfinite(picture.unreachable_cm[:, 0])
    assert drawn.all()
    assert np.isfinite(picture.unreachable_cm[~check.reachable]).all()
    np.testing.assert_allclose(picture.start_cm, points[0])


def test_the_reach_circles_are_centred_on_the_shoulder():
    check = check_trial(THESIS_SUBJECT)
    picture = reach_picture(check, THESIS_SUBJECT.shoulder_m)
    centre = np.array(THESIS_SUBJECT.shoulder_m) * 100
    for circle, flexion in ((picture.reach_far_cm, ELBOW_FLEXION_RANGE_RAD[0]),
                            (picture.reach_near_cm, ELBOW_FLEXION_RANGE_RAD[1])):
        radius = check.arm.reach_at_elbow_flexion(flexion) * 100
        np.testing.assert_allclose(np.hypot(*(circle - centre).T), radius)
    assert picture.crosses_cm.size == 0


def test_the_frame_holds_the_path_the_shoulder_and_the_robots_base():
    check = check_trial(THESIS_SUBJECT)
    picture = reach_picture(check, THESIS_SUBJECT.shoulder_m)
    points = np.vstack((check.points_m * 100, [np.array(THESIS_SUBJECT.shoulder_m) * 100],
                        [[0.0, 0.0]]))
    (x0, x1), (y0, y1) = picture.x_range_cm, picture.y_range_cm
    assert x0 < points[:, 0].min()
    assert points[:, 0].max() < x1
    assert y0 < points[:, 1].min()
    assert points[:, 1].max() < y1


def test_the_summary_gives_length_speed_and_joint_ranges():
    check = check_trial(THESIS_SUBJECT)
    text = check_summary(check)
    assert text.startswith(f"Path {check.path_length_m * 100:.0f} cm per traversal, fastest "
                           f"{check.peak_speed_m_s * 1000:.0f} mm/s.")
    low, high = (math.degrees(v) for v in check.range_of(check.isb_angles_rad[:, 1]))
    assert f"the elbow {low:.0f}° to {high:.0f}° (ISB)" in text


def test_a_task_the_robot_leads_is_summed_up_as_it_runs_not_as_a_path():
    """Clinic exploration 2 #4: the strength task set up read "Path 80 cm per traversal,
    fastest 0 mm/s" for a hand held still; the summary says the task's timetable and what
    the robot does, in the words of the Assessments tab and `rehab assess tasks`
    (app.assessments.words, one function for all)."""
    from app.assessments.words import robot_task_words
    from core.assessment.protocol import protocol

    strength = protocol("strength").parameters(THESIS_SUBJECT)
    text = check_summary(check_trial(strength))
    assert text == ("8 directions, a push of 3 s each; 1 round, 48 s; the robot holds the "
                    "handle still.")
    assert "Path" not in text
    assert "mm/s" not in text
    position = protocol("position").parameters(THESIS_SUBJECT)
    text = check_summary(check_trial(position))
    words = robot_task_words(position)
    assert text.startswith(f"{words[0].upper()}{words[1:]}. The shoulder will move ")


def test_an_arm_problem_goes_under_centre_and_shoulder():
    check = check_trial(AS_PRINTED)
    placed = problem_fields(check)
    assert [key for key, _ in placed] == ["centre", "shoulder"]
    assert placed[0][1] == placed[1][1] == check.problems[0]
    assert "0.68 m from the shoulder" in placed[0][1]
    assert problem_fields(check_trial(THESIS_SUBJECT)) == []


def test_too_fast_goes_under_the_time_per_traversal():
    fast = THESIS_SUBJECT.replace(radius_m=0.25, duration_s=1.0, shoulder_m=(-0.12, 0.90))
    placed = problem_fields(check_trial(fast))
    assert "duration" in {key for key, _ in placed}
    assert any("peak speed" in message for key, message in placed if key == "duration")


@pytest.mark.parametrize(("field", "key"), [
    ("centre_m[x]", "centre"), ("shoulder_m", "shoulder"), ("duration_s", "duration"),
    ("assistance_level", "assistance"), ("shape", "shape"),
])
def test_a_refused_field_is_shown_on_its_row(field, key):
    assert field_key(field) == key


def test_the_robots_workspace_is_computed_once_and_covers_its_reach():
    robot = RobotModel()
    mask, (x, y, width, height) = robot_workspace(robot)
    assert robot_workspace(robot)[0] is mask
    assert mask.shape[0] == mask.shape[1]
    assert mask.any()
    assert not mask.all()
    assert width == pytest.approx(height) == pytest.approx(mask.shape[0] * 0.005)
    assert x == y < -robot.reach_max_m
