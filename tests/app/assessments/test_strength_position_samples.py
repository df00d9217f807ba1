"""The strength and position-sense figures of this console's protocol on samples made by
hand (app.assessments.strength, .position): which samples are a push or a match, when a
push is at the robot's limit, when a match was not made."""

import math

import numpy as np
import pytest

from app.assessments.position import HELD_S, matches, position_figures
from app.assessments.strength import AT_LINE, GAVE_WAY_M, lines_N, push_windows
from core.assessment.protocol import protocol
from core.trial import THESIS_SUBJECT

PERIOD = 0.002
STRENGTH = protocol("strength").parameters(THESIS_SUBJECT).replace(n_targets=2)
POSITION = protocol("position").parameters(THESIS_SUBJECT).replace(n_targets=2,
                                                                   repetitions=2)


def still_samples(params, start_s=0.7):
    """The hand still at the centre over the task's whole exercise, from `start_s` (the
    exercise's first sample on the trial's clock), no force."""
    n = round(params.trajectory().total_duration_s / PERIOD)
    t = start_s + np.arange(n) * PERIOD
    return {"time": t, "position": np.tile(params.centre_m, (n, 1)),
            "force": np.zeros((n, 2))}


def test_each_push_is_its_timetable_s_window_flagged_at_the_line_or_when_the_hand_gave():
    samples = still_samples(STRENGTH)
    pushes = [s for s in STRENGTH.trajectory().stretches if s.phase == "push"]
    lines = lines_N(STRENGTH)
    t = samples["time"]
    first, second = pushes
    # the first push reaches AT_LINE of its line exactly; the second stays under it, but
    # the handle gives 1.1 cm
    inside = (t >= t[0] + first.start_s) & (t <= t[0] + first.stop_s)
    line = dict(first.values)["line_N"]
    samples["force"][inside] = AT_LINE * line * np.asarray(first.push)
    inside2 = (t >= t[0] + second.start_s) & (t <= t[0] + second.stop_s)
    samples["force"][inside2] = 0.5 * np.asarray(second.push)
    samples["position"][inside2] += (GAVE_WAY_M + 0.001) * np.asarray(second.push)
    windows = push_windows(samples, STRENGTH)
    assert [w.at_limit for w in windows] == [True, True]
    for w, s in zip(windows, pushes, strict=True):
        assert w.start_s == pytest.approx(t[0] + s.start_s)
        assert w.end_s == pytest.approx(t[0] + s.stop_s)
        assert w.direction_rad == dict(s.values)["direction_rad"]
    assert sorted(lines) == sorted(dict(s.values)["direction_deg"] for s in pushes)
    # just under the line and the handle still: not at the limit
    samples = still_samples(STRENGTH)
    samples["force"][inside] = 0.99 * AT_LINE * line * np.asarray(first.push)
    assert [w.at_limit for w in push_windows(samples, STRENGTH)] == [False, False]


def test_a_match_is_the_hand_s_mean_over_its_end_and_one_never_tried_is_counted():
    samples = still_samples(POSITION)
    t = samples["time"]
    found = [s for s in POSITION.trajectory().stretches if s.phase == "match"]
    assert len(found) == 4
    by_hand = []
    for k, s in enumerate(found[:3]):
        target = np.asarray(dict(s.values)["target_m"])
        during = (t >= t[0] + s.start_s) & (t < t[0] + s.stop_s)
        held = (t >= t[0] + s.stop_s - HELD_S) & (t < t[0] + s.stop_s)
        # on the way, then 1, 2, 3 cm off along +x while held (and 5 cm off before that)
        samples["position"][during] = target + np.array([0.05, 0.0])
        samples["position"][held] = target + np.array([0.01 * (k + 1), 0.0])
        by_hand.append(0.01 * (k + 1))
    # the fourth: the hand wanders 2 cm, a fifth of the 10 cm: not tried
    s = found[3]
    during = (t >= t[0] + s.start_s) & (t < t[0] + s.stop_s)
    samples["position"][during] = np.asarray(POSITION.centre_m) + np.array([0.0, 0.02])
    targets, reproduced = matches(samples, POSITION)
    np.testing.assert_allclose(np.hypot(*(reproduced[:3] - targets[:3]).T), by_hand)
    assert np.isnan(reproduced[3]).all()
    figures = position_figures(samples, POSITION)
    assert figures["position_not_reproduced_count"] == 1
    assert figures["position_absolute_error_m"] == pytest.approx(np.mean(by_hand))
    assert math.isfinite(figures["position_variable_error_m"])
