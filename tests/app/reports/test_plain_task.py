"""The patient's lines of an assessment trial (app.reports.plain_task): each task's
figures in words built from their numbers, in the display units, missing figures giving
no line; and on the report of a task trial they come first, with nothing said twice."""

from __future__ import annotations

import math

import pytest

from app.reports.plain_language import force_text
from app.reports.plain_task import task_lines

REACHING = {"vgr_movement_time_s": 1.0744, "vgr_path_length_ratio": 1.0439,
            "vgr_speed_maxima_count": 2.9167, "vgr_reaction_time_s": 0.5128,
            "vgr_no_movement_end_count": 4.0, "vgr_sparc": -1.72}


def texts(task, figures):
    return [line.text for line in task_lines(task, figures)]


def test_reaching_in_words():
    assert texts("reaching", REACHING) == [
        "A reach took you 1.1 seconds on average.",
        "Your hand's path was 4 % longer than the straight line.",
        "Your hand sped up 2.9 times in a reach on average.",
        "You started to move 0.5 seconds after a target appeared.",
        "Your hand did not come to rest on 4 targets.",
    ]
    one = texts("reaching", {"vgr_no_movement_end_count": 1.0})
    assert one == ["Your hand did not come to rest on 1 target."]
    # every reach came to rest: nothing said of it
    assert texts("reaching", {"vgr_no_movement_end_count": 0.0}) == []


def test_a_circle_trial_speaks_of_its_own_way_round():
    one_way = {"circle_ratio_ccw": 0.7831, "circle_joint_independence_ccw": 0.6243,
               "circle_mean_speed_ccw_m_s": 0.0671, "circle_sparc_ccw": -3.8}
    assert texts("circle", one_way) == [
        "Your circle was 78 % as wide one way as the other.",
        "Your shoulder and elbow moved independently: 62 %.",
        "You drew at 67 mm per second on average.",
    ]
    # the pair's mean where no way round is given
    assert texts("circle", {"circle_ratio": 0.8555})[0].startswith("Your circle was 86 %")
    # the trial's own way first
    both = {"circle_ratio": 0.8555, "circle_ratio_cw": 0.928}
    assert texts("circle", both)[0].startswith("Your circle was 93 %")


def test_range_strength_and_position_in_words():
    lines = task_lines("range", {"range_area_m2": 0.0267, "range_area_ratio": 0.4027})
    assert [line.text for line in lines] == [
        "You reached 40 % of the table the robot and your arm allow."]
    assert lines[0].detail == "Your hand covered 267 cm² on its own."
    strength = task_lines("strength", {"strength_peak_force_n": 4.0615,
                                       "strength_at_limit_count": 4.0})
    assert [line.text for line in strength] == [
        "Your firmest pushes were 4.1 N on average over 8 directions.",
        "In 4 directions of 8 you pushed as hard as the robot can hold.",
    ]
    assert strength[0].detail == "About the effort of holding up 400 g."
    every = texts("strength", {"strength_peak_force_n": 5.3, "strength_at_limit_count": 8.0})
    assert every[1] == "In every direction you pushed as hard as the robot can hold."
    assert texts("position", {"position_absolute_error_m": 0.0428,
                              "position_variable_error_m": 0.0352,
                              "position_not_reproduced_count": 2.0}) == [
        "You found the remembered spot within 43 mm on average.",
        "Your tries at one spot were 35 mm apart on average.",
        "Your hand did not leave the centre in 2 tries.",
    ]


@pytest.mark.parametrize("bad", [math.nan, math.inf, None, "x"])
def test_a_figure_missing_or_not_a_number_gives_no_line(bad):
    figures = dict(REACHING, vgr_movement_time_s=bad)
    keys = [line.key for line in task_lines("reaching", figures)]
    assert "vgr_movement_time_s" not in keys
    assert len(keys) == 4
    assert task_lines("reaching", {}) == ()
    assert task_lines("no such task", REACHING) == ()


def test_a_task_trials_report_leads_with_the_tasks_lines(tmp_path):
    """On the post-trial report of a strength trial the patient reads the task's lines
    first; the firmest push is said once (the task's, not the exercise's force line)."""
    from app.assessments.runner import run_task
    from app.records.datadir import DataDir
    from app.records.registry import Registry
    from app.reports.build import content_for_registry_trial

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Strong", birth_year=1960, side="right",
                                   sex="female", handedness="right").code
    (trial,) = run_task("strength", "healthy", seed=3, registry=registry, code=code)
    content = content_for_registry_trial(registry, trial.trial_id)
    keys = [line.key for line in content.plain]
    assert keys[0] == "strength_peak_force_n"
    assert "peak_force_N" not in keys
    assert "rmse" not in keys
    first = content.plain[0].text
    peak = force_text(trial.figures["strength_peak_force_n"])
    assert first == f"Your firmest pushes were {peak} N on average over 8 directions."
