"""A robot figure against a clinical scale over a patient's sessions and across a study,
with Pearson's and Spearman's correlations by hand, invalid trials left out unless asked,
and real changes marked only beyond the norms' MDC95 (issue 31, item 3)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from app.norms import load_norms
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.scales_progress import correlation, scale_series, study_series
from core.trial import THESIS_SUBJECT
from tests.app.norms.handmade import handmade

RT = "vgr_reaction_time_s"


def pearson_by_hand(x, y):
    x, y = np.asarray(x, float), np.asarray(y, float)
    dx, dy = x - x.mean(), y - y.mean()
    return float((dx * dy).sum() / math.sqrt((dx * dx).sum() * (dy * dy).sum()))


def ranks(values):
    """Average ranks (ties share the mean of their places), 1-based."""
    order = sorted(range(len(values)), key=lambda i: values[i])
    out = [0.0] * len(values)
    i = 0
    while i < len(order):
        j = i
        while j + 1 < len(order) and values[order[j + 1]] == values[order[i]]:
            j += 1
        for k in range(i, j + 1):
            out[order[k]] = (i + j) / 2 + 1
        i = j + 1
    return out


def test_correlations_equal_the_hand_computation():
    x, y = [0.30, 0.42, 0.38, 0.55, 0.61], [20, 31, 29, 40, 38]
    c = correlation(x, y)
    assert c.n == 5
    assert c.pearson_r == pytest.approx(pearson_by_hand(x, y), abs=1e-12)
    assert c.spearman_rho == pytest.approx(pearson_by_hand(ranks(x), ranks(y)), abs=1e-12)
    # ranks: x 1 3 2 4 5, y 1 3 2 5 4 -> d² = 0,0,0,1,1 -> rho = 1 - 6·2/(5·24) = 0.9
    assert c.spearman_rho == pytest.approx(0.9, abs=1e-12)
    assert "n = 5" in c.text()
    # exact: of the 120 orders of y, those with |rho| >= 0.9 (rho = ±1: 2, ±0.9: 8)
    assert c.spearman_p == pytest.approx(10 / 120)
    assert correlation([1, 2, 3, 4], [10, 20, 30, 40]).spearman_p == pytest.approx(2 / 24)
    assert math.isnan(correlation([1, 2], [3, 4]).pearson_r)
    assert math.isnan(correlation([1, 1, 1], [3, 4, 5]).spearman_rho)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(-1e3, 1e3), st.integers(0, 66)), min_size=3,
                max_size=12))
def test_the_correlations_are_within_minus_one_and_one_and_monotonic_invariant(pairs):
    x, y = [p[0] for p in pairs], [p[1] for p in pairs]
    c = correlation(x, y)
    if math.isnan(c.pearson_r):
        assert np.ptp(x) < 1e-9 or np.ptp(y) == 0  # (nearly) constant
        return
    assert -1 - 1e-9 <= c.pearson_r <= 1 + 1e-9
    # Spearman's rho depends on the order only: a monotonic map of x leaves it
    bent = np.asarray(x) ** 3 + np.asarray(x)
    assert correlation(bent, y).spearman_rho == pytest.approx(
        c.spearman_rho, abs=1e-9)


@pytest.fixture
def registry(tmp_path):
    return Registry(DataDir(tmp_path / "data"))


def session_with(registry, code, times, fugl_meyer=None):
    """A session of trials with these reaction times (s), and its Fugl-Meyer total."""
    number = registry.open_session(code).number
    ids = []
    for rt in times:
        begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                                     session_number=number)
        registry.finish_trial(begun.trial_id, "complete", {RT: rt})
        ids.append(begun.trial_id)
    if fugl_meyer is not None:
        registry.record_scale(code, number, "fugl_meyer", total=fugl_meyer, rater="K. Lee")
    return ids


def test_a_patients_sessions_figure_against_the_scale(registry):
    code = registry.create_patient("Ada", "Example").code
    session_with(registry, code, [0.50, 0.60], fugl_meyer=20)
    bad = session_with(registry, code, [0.40, 0.90], fugl_meyer=30)
    session_with(registry, code, [0.45], fugl_meyer=None)  # no scale: not a point
    session_with(registry, code, [0.30, 0.34], fugl_meyer=44)
    registry.mark_trial(bad[1], valid=False, reason="slept", by="K. Lee")

    series = scale_series(registry, code, RT, "fugl_meyer")
    assert [(p.session_number, p.figure, p.n_trials, p.scale) for p in series.points] == [
        (1, pytest.approx(0.55), 2, 20.0), (2, 0.40, 1, 30.0), (4, pytest.approx(0.32), 2, 44.0)]
    x, y = [0.55, 0.40, 0.32], [20, 30, 44]
    assert series.correlation.pearson_r == pytest.approx(pearson_by_hand(x, y))
    assert series.correlation.spearman_rho == pytest.approx(-1.0)
    assert series.mdc_note == "No norms in use: no change is marked real."
    every = scale_series(registry, code, RT, "fugl_meyer", include_invalid=True)
    assert every.points[1].figure == pytest.approx(0.65)


def test_changes_are_marked_real_only_beyond_the_norms_mdc(registry, tmp_path):
    path = tmp_path / "norms.json"
    path.write_text(json.dumps(handmade()))  # MDC95 of the reaction time: 0.08 s
    norms = load_norms(path)
    code = registry.create_patient("Ada", "Example").code
    for rt, fm in ((0.50, 20), (0.45, 25), (0.30, 33)):
        session_with(registry, code, [rt], fugl_meyer=fm)
    series = scale_series(registry, code, RT, "fugl_meyer", norms=norms)
    assert [p.real_change for p in series.points] == [None, False, True]
    assert series.mdc_note == ""
    no_mdc = scale_series(registry, code, "rmse_x_m", "fugl_meyer", norms=norms)
    assert no_mdc.points == ()
    held = scale_series(registry, code, RT, "fugl_meyer", norms=None)
    assert [p.real_change for p in held.points] == [None, None, None]


def test_marks_against_an_mdc95_on_no_reliability_say_so(registry, tmp_path):
    """An MDC95 whose test-retest ICC is ≤ 0 (the shipped norms' position sense: no
    lasting trait in the virtual subjects) is the retest's whole spread: the marks line
    says so, and says nothing of the kind for an ICC above 0."""
    from app.norms.model import NO_RELIABILITY_SAID

    document = handmade()
    code = registry.create_patient("Ada", "Example").code
    for rt, fm in ((0.50, 20), (0.30, 33)):
        session_with(registry, code, [rt], fugl_meyer=fm)
    lines = {}
    for icc in (-0.03, 0.7):
        document["figures"][RT]["icc"] = icc
        path = tmp_path / f"norms{icc}.json"
        path.write_text(json.dumps(document))
        lines[icc] = scale_series(registry, code, RT, "fugl_meyer",
                                  norms=load_norms(path)).marks
    assert lines[-0.03].startswith(f"a real change (beyond MDC95 0.08) at session 2 "
                                   f"({NO_RELIABILITY_SAID}); Norms: hand-made")
    assert lines[0.7].startswith("a real change (beyond MDC95 0.08) at session 2; Norms: ")


def test_a_figure_the_norms_do_not_hold_is_said_in_a_short_line(registry, tmp_path):
    """The RMSE against a scale, with norms of the battery's figures in use: the window's
    caption listed every figure the norms hold (39 keys over six lines, the plot pushed
    into a scroll area) to say no change is marked."""
    path = tmp_path / "norms.json"
    path.write_text(json.dumps(handmade()))
    norms = load_norms(path)
    code = registry.create_patient("Ada", "Example").code
    for rmse, fm in ((0.03, 20), (0.02, 30)):
        number = registry.open_session(code).number
        begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                                     session_number=number)
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": rmse})
        registry.record_scale(code, number, "fugl_meyer", total=fm, rater="K. Lee")
    series = scale_series(registry, code, "rmse_x_m", "fugl_meyer", norms=norms)
    assert series.mdc_note == ("the norms (hand-made for the tests, 3 Dec 2026) hold no "
                               "MDC95 for RMSE x (mm), not one of their figures: no change "
                               "is marked real")
    assert [p.real_change for p in series.points] == [None, None]


def test_a_study_has_one_point_per_patient_their_latest_session(registry):
    expected = []
    for i, (rt, fm) in enumerate(((0.6, 15), (0.5, 30), (0.35, 50), (0.3, 60))):
        code = registry.create_patient(f"P{i}", "Example").code
        session_with(registry, code, [rt + 0.1], fugl_meyer=fm - 5)
        session_with(registry, code, [rt], fugl_meyer=fm)
        expected.append((rt, fm))
    registry.create_patient("No", "Scales")  # no scales: not in the study
    series = study_series(registry, RT, "fugl_meyer")
    assert sorted((p.figure, p.scale) for p in series.points) == sorted(
        (rt, float(fm)) for rt, fm in expected)
    assert series.correlation.n == 4
    assert series.correlation.spearman_rho == pytest.approx(-1.0)


def test_a_session_s_figure_leaves_out_the_battery_s_trials_that_do_not_measure_it(registry):
    """Seen in the window: a session of the assessment battery, then a plan, and "Fugl-Meyer
    against RMSE x" drew 17.5 mm, the mean of all eight trials: the strength task's 0.3 mm
    (the robot held the hand still) and the active range's 58 mm among them, figures the
    Trajectory tab says are "not for this task". An assessment trial counts only for its
    task's own figures (core.assessment.task_figures), as the Progress tab shows it."""
    from core.assessment.figures import task_figures

    code = registry.create_patient("Ada", "Example").code
    number = registry.open_session(code).number
    rmse = "rmse_x_m"
    own = task_figures("reaching")[0].key
    for parameters, metrics in (
            (THESIS_SUBJECT, {rmse: 0.004}),
            (THESIS_SUBJECT.replace(assessment="reaching", shape="targets", assist="transparent"),
             {rmse: 0.033, own: 0.4}),
            (THESIS_SUBJECT.replace(assessment="strength", shape="targets", assist="transparent"),
             {rmse: 0.0003})):
        begun = registry.begin_trial(code, parameters, backend="simulator",
                                     session_number=number)
        registry.finish_trial(begun.trial_id, "complete", metrics)
    registry.record_scale(code, number, "fugl_meyer", total=30, rater="K. Lee")
    (point,) = scale_series(registry, code, rmse, "fugl_meyer").points
    assert (point.figure, point.n_trials) == (pytest.approx(0.004), 1)
    (task_point,) = scale_series(registry, code, own, "fugl_meyer").points
    assert (task_point.figure, task_point.n_trials) == (pytest.approx(0.4), 1)


def test_a_task_s_figure_is_drawn_in_the_unit_the_assessments_tab_shows():
    """Seen in the window: "against Posture speed (m/s)", its axis 0.00032, where the
    Assessments tab says 0.3217 mm/s (app.units.shown, the page's units)."""
    from app.reports.progress_figure import shown_row
    from app.units import shown
    from core.assessment import FIGURES

    for key, spec in FIGURES.items():
        factor, unit = shown(1.0, spec.unit)
        unit = "" if unit in ("1", "count") else unit
        row = shown_row(key)
        assert (row.scale, row.unit) == (factor, unit), key
        assert row.heading_in_unit == (f"{spec.label} ({unit})" if unit else spec.label)


def test_a_progress_report_sets_no_assessment_mode_s_figure_against_the_scales(registry):
    """The battery's tasks run transparent; the report set 'RMSE x/y' (the transparent
    mode's success figure) against Fugl-Meyer for a patient whose exercises were all as
    needed, made of nothing but the tasks' trials' distance from their clock."""
    from app.reports.progress import progress
    from app.reports.scales_progress import report_series
    from core.assessment.protocol import protocol

    code = registry.create_patient("Ada", "Example").code
    for fm in (20, 30, 40):
        number = registry.open_session(code).number
        for parameters in (THESIS_SUBJECT, protocol("circle").parameters(THESIS_SUBJECT)):
            begun = registry.begin_trial(code, parameters, backend="simulator",
                                         session_number=number)
            registry.finish_trial(begun.trial_id, "complete",
                                  {"rmse_x_m": 0.01, "rmse_y_m": 0.01,
                                   "directional_performance_pct": 50.0 + fm})
        registry.record_scale(code, number, "fugl_meyer", total=fm, rater="K. Lee")
    keys = {s.figure_key for s in report_series(registry, progress(registry, code))}
    assert keys == {"directional_performance_pct"}
