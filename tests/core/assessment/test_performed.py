"""A task the patient did not perform at all (core.assessment.performed): named from the
task's own counts, never from a figure merely missing."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, strategies as st

from core.assessment.performed import not_performed
from core.assessment.protocol import protocol
from core.reaches import DEFAULT_MIN_PEAK_SPEED_M_S

REACHES = protocol("reaching").n_targets * protocol("reaching").repetitions
MATCHES = protocol("position").n_targets * protocol("position").repetitions


def test_no_reaction_in_every_reach_is_not_performed():
    assert REACHES == 16
    assert "16 reaches" in not_performed("reaching", {"vgr_no_reaction_count": 16.0})
    assert not_performed("reaching", {"vgr_no_reaction_count": 15.0}) == ""


def test_no_position_reproduced_is_not_performed():
    assert MATCHES == 12
    assert "12 matches" in not_performed("position", {"position_not_reproduced_count": 12})
    assert not_performed("position", {"position_not_reproduced_count": 11}) == ""


def test_a_circle_not_moved_either_way_is_not_performed():
    still = {"circle_mean_speed_cw_m_s": 0.0, "circle_mean_speed_ccw_m_s": 0.001}
    assert "both ways" in not_performed("circle", still)
    one_way = {**still, "circle_mean_speed_ccw_m_s": DEFAULT_MIN_PEAK_SPEED_M_S}
    assert not_performed("circle", one_way) == ""
    # A trial of one way holds that way's speed only; without either, the task's mean.
    assert not_performed("circle", {"circle_mean_speed_cw_m_s": 0.0}) != ""
    assert not_performed("circle", {"circle_mean_speed_m_s": 0.0}) != ""
    assert not_performed("circle", {"circle_mean_speed_m_s": 0.05}) == ""


@pytest.mark.parametrize("task", ["range", "strength"])
def test_tasks_whose_figures_stay_defined_score_instead(task):
    assert not_performed(task, {"range_area_m2": 0.0, "strength_peak_force_n": 0.0}) == ""


@given(task=st.sampled_from(["reaching", "circle", "range", "strength", "position"]),
       value=st.one_of(st.none(), st.just(math.nan), st.just(math.inf), st.text(max_size=3),
                       st.booleans()))
def test_a_figure_missing_or_not_a_number_never_reads_as_not_performed(task, value):
    keys = ("vgr_no_reaction_count", "position_not_reproduced_count",
            "circle_mean_speed_cw_m_s", "circle_mean_speed_ccw_m_s", "circle_mean_speed_m_s")
    assert not_performed(task, {}) == ""
    assert not_performed(task, dict.fromkeys(keys, value)) == ""
