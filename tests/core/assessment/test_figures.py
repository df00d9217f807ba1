"""The figure catalogue: every key the team fixed (issue 31) is there, once, with a unit that
matches its suffix, a direction, a definition and a reference with a doi."""

from __future__ import annotations

import math

import pytest

from core.assessment import (
    CIRCLE_BASE_KEYS,
    FIGURES,
    STRENGTH_DIRECTIONS_DEG,
    TASK_TITLES,
    TASKS,
    FigureSpec,
    figure,
    strength_key,
    task_figures,
)
from core.errors import ParameterError

# The keys fixed for every helper (helpers/scopes/common31.md), written out by hand.
FIXED = {
    "reaching": [
        "vgr_posture_speed_m_s", "vgr_reaction_time_s", "vgr_initial_direction_error_rad",
        "vgr_initial_distance_ratio", "vgr_initial_speed_ratio", "vgr_speed_maxima_count",
        "vgr_min_max_speed_difference_m_s", "vgr_movement_time_s", "vgr_path_length_ratio",
        "vgr_max_speed_m_s", "vgr_no_reaction_count", "vgr_no_movement_end_count", "vgr_sparc",
        "vgr_ldlj",
    ],
    "circle": [
        "circle_ratio", "circle_joint_independence", "circle_sparc", "circle_ldlj",
        "circle_mean_speed_m_s",
        "circle_ratio_cw", "circle_joint_independence_cw", "circle_sparc_cw", "circle_ldlj_cw",
        "circle_mean_speed_cw_m_s",
        "circle_ratio_ccw", "circle_joint_independence_ccw", "circle_sparc_ccw",
        "circle_ldlj_ccw", "circle_mean_speed_ccw_m_s",
    ],
    "range": ["range_area_m2", "range_area_ratio"],
    "strength": [f"strength_{kind}_force_n_{deg:03d}" for deg in range(0, 360, 45)
                 for kind in ("peak", "mean")] + ["strength_peak_force_n",
                                                  "strength_mean_force_n",
                                                  "strength_at_limit_count"],
    "position": ["position_absolute_error_m", "position_variable_error_m",
                 "position_constant_error_m", "position_not_reproduced_count"],
}

SUFFIX_UNITS = {"_m_s": "m/s", "_rad": "rad", "_m2": "m²", "_s": "s", "_m": "m", "_n": "N"}


def test_the_tasks_are_the_fixed_ids_in_order():
    assert TASKS == ("reaching", "circle", "range", "strength", "position")
    assert set(TASK_TITLES) == set(TASKS)


@pytest.mark.parametrize("task", TASKS)
def test_every_fixed_key_is_in_the_catalogue_under_its_task(task):
    assert [spec.key for spec in task_figures(task)] == FIXED[task]


def test_the_catalogue_holds_nothing_else():
    assert sorted(FIGURES) == sorted(key for keys in FIXED.values() for key in keys)


@pytest.mark.parametrize("key", sorted(FIGURES))
def test_unit_matches_the_key_suffix(key):
    spec = FIGURES[key]
    # the direction of a circle and the degrees of a push are tags, not units
    stem = "_".join(p for p in key.split("_") if p not in ("cw", "ccw") and not p.isdigit())
    expected = next((unit for suffix, unit in SUFFIX_UNITS.items() if stem.endswith(suffix)),
                    "count" if stem.endswith("_count") else "1")
    assert spec.unit == expected


@pytest.mark.parametrize("key", sorted(FIGURES))
def test_each_entry_says_which_way_is_better_and_cites_a_doi(key):
    spec = FIGURES[key]
    # every figure of the battery has a good side but the flag of pushes the robot capped
    # and the count of matches never tried (counts that say what the figures leave out)
    good_side = (("none",) if key in ("strength_at_limit_count", "position_not_reproduced_count")
                 else ("lower", "higher"))
    assert spec.better in good_side
    assert "doi:10." in spec.reference
    assert spec.definition.endswith(".")
    assert spec.label


def test_the_better_direction_of_some_figures_by_hand():
    assert figure("vgr_reaction_time_s").better == "lower"
    assert figure("vgr_sparc").better == "higher"
    assert figure("circle_ratio_cw").better == "higher"
    assert figure("position_absolute_error_m").better == "lower"
    assert figure("strength_peak_force_n_090").better == "higher"


def test_strength_keys():
    assert strength_key("peak", 0) == "strength_peak_force_n_000"
    assert strength_key("mean", 315) == "strength_mean_force_n_315"
    assert STRENGTH_DIRECTIONS_DEG == (0, 45, 90, 135, 180, 225, 270, 315)
    with pytest.raises(ParameterError, match="direction_deg"):
        strength_key("peak", 30)
    with pytest.raises(ParameterError, match="kind"):
        strength_key("max", 0)


def test_unknown_key_or_task_is_refused_by_name():
    with pytest.raises(ParameterError, match=r"vgr_nothing.*core\.assessment\.FIGURES"):
        figure("vgr_nothing")
    with pytest.raises(ParameterError, match="task"):
        task_figures("juggling")


def test_a_spec_refuses_an_unknown_task_or_direction():
    with pytest.raises(ParameterError, match="task"):
        FigureSpec("x_m", "juggling", "m", "X", "lower", "X.", "doi:10.1/x")
    with pytest.raises(ParameterError, match="better"):
        FigureSpec("x_m", "range", "m", "X", "smaller", "X.", "doi:10.1/x")
    with pytest.raises(ParameterError, match="label"):
        FigureSpec("x_m", "range", "m", " ", "lower", "X.", "doi:10.1/x")


def test_every_bounded_figure_is_in_the_catalogue_and_every_domain_holds_its_bounds():
    from core.assessment.figures import _DOMAINS, domain

    assert set(_DOMAINS) <= set(FIGURES) | set(CIRCLE_BASE_KEYS)
    for key in FIGURES:
        low, high = domain(key)
        assert low < high
    assert domain("circle_ratio_cw") == domain("circle_ratio") == (0.0, 1.0)
    assert domain("vgr_sparc") == (-math.inf, math.inf)
    assert domain("strength_mean_force_n_090")[0] == -math.inf  # pulled the wrong way
