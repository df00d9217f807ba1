"""What the patient's screen says at each moment (ui.views.patient_screen), on records
made to order: the approach, the exercise's first sample, the repetitions on the clock,
the end, a fault; clinical figures only when the therapist chose them."""

import numpy as np
import pytest

from core.trial import THESIS_SUBJECT
from device.loop.pipeline import PERIOD_S
from tests.ui.views.timetable import on_the_path
from ui.views.patient_screen import (
    CUE_DONE,
    CUE_GO,
    CUE_OVER,
    CUE_READY,
    CUE_STOPPED,
    GO_SHOWN_S,
    PatientOptions,
    Scene,
    clock,
    frame_at,
)
from ui.views.trialview import TrialView

PARAMS = THESIS_SUBJECT.replace(repetitions=3, duration_s=2.0)
APPROACH, EXERCISE, HOLD = 300, 3000, 100


def _records(params=PARAMS, fault_at: int | None = None) -> np.ndarray:
    r = on_the_path(params, APPROACH, HOLD, exercise=EXERCISE)
    r["position"] += 0.003  # the hand 3 mm off, both ways
    r["force_angle"] = 0.1
    if fault_at is not None:
        r["fault"][fault_at:] = 7
    return r


def _frame_at_sample(records, i, options=None, params=PARAMS):
    view = TrialView(params)
    view.append(records[:i + 1])
    return frame_at(view, Scene.of(params), options or PatientOptions())


def test_get_ready_then_go_at_the_exercise_s_first_sample_then_the_clock():
    r = _records()
    assert _frame_at_sample(r, APPROACH - 1).cue == CUE_READY
    before = _frame_at_sample(r, APPROACH - 1)
    assert not before.go
    assert before.time_left_s == pytest.approx(6.0)
    go = _frame_at_sample(r, APPROACH)
    assert go.go
    assert go.cue == CUE_GO
    assert go.repetition_text == "Lap 1 of 3"
    assert go.time_left_text == "0:06 left"
    shown = round(GO_SHOWN_S / PERIOD_S)
    assert _frame_at_sample(r, APPROACH + shown - 1).go
    assert not _frame_at_sample(r, APPROACH + shown).go
    second = _frame_at_sample(r, APPROACH + 1000 + 10)  # 2.02 s in
    assert second.repetition == 2
    assert second.time_left_s == pytest.approx(6.0 - 2.02)
    end = _frame_at_sample(r, APPROACH + EXERCISE + 5)
    assert end.cue == CUE_DONE
    assert end.time_left_text == "0:00 left"
    assert end.repetition == 3


def test_a_fault_says_stopped_and_nothing_more():
    r = _records(fault_at=APPROACH + 500)
    frame = _frame_at_sample(r, APPROACH + 600)
    assert frame.cue == CUE_STOPPED
    assert not frame.go


def test_clinical_figures_only_when_the_therapist_chose_them():
    r = _records()
    hidden = _frame_at_sample(r, APPROACH + 2000)
    assert hidden.numbers == ()
    shown = _frame_at_sample(r, APPROACH + 2000, PatientOptions(show_numbers=True))
    assert shown.numbers[0] == "Right direction 100 %"
    assert shown.numbers[1] == "Off the path 4 mm"  # 3 mm on each axis: 4.2 mm


def test_the_last_repetition_s_path_is_shown_during_the_next_only_when_asked():
    r = _records()
    i = APPROACH + 1000 + 200  # in the second repetition
    frame = _frame_at_sample(r, i)
    assert frame.previous_path_m is not None
    first_rep = r["position"][APPROACH:APPROACH + 1000]
    np.testing.assert_array_equal(frame.previous_path_m[0], first_rep[0])
    assert len(frame.previous_path_m) >= 300
    assert _frame_at_sample(r, APPROACH + 500).previous_path_m is None  # nothing before
    off = _frame_at_sample(r, i, PatientOptions(previous_path=False))
    assert off.previous_path_m is None


def test_the_reach_target_lit_is_the_one_the_reference_moves_to():
    params = THESIS_SUBJECT.replace(shape="targets", n_targets=4, radius_m=0.08,
                                    centre_m=(-0.2, 0.35), duration_s=6.0, repetitions=1)
    r = _records(params)
    scene = Scene.of(params)
    assert len(scene.targets_m) == 4
    # 4 targets, 8 lines of 0.75 s: out to target k from 1.5 k s, home from 1.5 k + 0.75 s
    for k in range(4):
        out = _frame_at_sample(r, APPROACH + int((1.5 * k + 0.375) / PERIOD_S), params=params)
        assert out.active_target == k
        home = _frame_at_sample(r, APPROACH + int((1.5 * k + 1.125) / PERIOD_S),
                                params=params)
        assert home.active_target == -1


@pytest.mark.parametrize(("seconds", "text"), [(0.0, "0:00"), (0.2, "0:01"), (59.01, "1:00"),
                                               (61.0, "1:01"), (600.0, "10:00")])
def test_the_clock_rounds_up(seconds, text):
    assert clock(seconds) == text


def test_each_round_s_end_is_said_for_a_while_after_it():
    from ui.views.patient_game import RESULT_SHOWN_S

    r = _records()
    just_after = _frame_at_sample(r, APPROACH + 1000 + 10)
    # the result, then the round's quality: the hand 3 mm off both ways is within 5 mm
    assert just_after.result == "Done! Right on the path"  # the top band says "Lap 2 of 3"
    assert just_after.success
    assert just_after.message == "Done! Right on the path"  # no cue then
    shown = min(RESULT_SHOWN_S, 0.5 * PARAMS.duration_s)  # at most half a round
    assert _frame_at_sample(r, APPROACH + 1000 + round(shown / PERIOD_S) - 1).result
    later = _frame_at_sample(r, APPROACH + 1000 + round(shown / PERIOD_S) + 1)
    assert later.result == ""
    assert _frame_at_sample(r, APPROACH + 500).result == ""  # nothing before the first end


def test_a_live_view_that_missed_the_first_records_counts_from_the_loop_s_start():
    """The window's live view can miss a trial's first records (taken before it saw the
    trial running); the loop says where the exercise starts (its approach's length), and
    the screen counts from there, not from the first sample it holds."""
    r = _records()
    view = TrialView(PARAMS)
    view.append(r[APPROACH + 17:APPROACH + 200])  # the approach and 17 ticks missed
    t_start = APPROACH * PERIOD_S
    told = frame_at(view, Scene.of(PARAMS), PatientOptions(), exercise_start_s=t_start)
    t = float(r["time"][APPROACH + 199])
    assert told.exercise_started_s == t_start
    assert told.time_left_s == pytest.approx(6.0 - (t - t_start))
    guessed = frame_at(view, Scene.of(PARAMS), PatientOptions())
    assert guessed.exercise_started_s == pytest.approx(t_start + 17 * PERIOD_S)  # 34 ms late
    early = TrialView(PARAMS)
    early.append(r[:APPROACH - 5])
    assert frame_at(early, Scene.of(PARAMS), PatientOptions(),
                    exercise_start_s=t_start).cue == CUE_READY


@pytest.mark.parametrize(("off_m", "words"), [(0.0, "Right on the path"),
                                              (0.004, "Right on the path"),
                                              (0.010, "Close to the path"),
                                              (0.030, "Stay closer to the path")])
def test_after_each_round_its_quality_follows_its_result(off_m, words):
    """Knowledge of results, then of performance: the hand's distance from the path over
    the round just done, in words (a circle, so that 'off' is the same everywhere)."""
    params = PARAMS.replace(shape="circle", radius_m=0.08)
    r = _records(params)
    r["position"] = r["position_desired"] * 1.0
    # out from the circle's centre by off_m, whatever the angle
    centre = np.asarray(params.centre_m)
    radial = r["position_desired"] - centre
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    r["position"] = r["position_desired"] + off_m * radial
    frame = _frame_at_sample(r, APPROACH + 1000 + 10, params=params)
    assert frame.result == f"Done! {words}"


def test_a_hand_that_stayed_still_at_the_start_is_not_told_it_kept_to_the_path():
    """The passive virtual patient in the transparent mode: nothing moves the relaxed
    hand, which stays at the path's start, on the path. It was told "Round 1 done! Right
    on the path" in green. A round whose hand moved less than the path game's share of
    the path's length (core.games.scoring.COVERAGE) is said to need the whole path, not
    in green."""
    params = PARAMS.replace(assist="transparent")
    r = _records(params)
    r["position"] = r["position_desired"][APPROACH]  # still at the start all along
    frame = _frame_at_sample(r, APPROACH + 1000 + 10, params=params)
    assert frame.result == "Now follow the whole path"
    assert not frame.success
    half = _records(params)  # half of the round, then still: not enough either
    half["position"][APPROACH + 500:] = half["position_desired"][APPROACH + 500]
    assert not _frame_at_sample(half, APPROACH + 1000 + 10, params=params).success


def test_the_end_gives_the_last_round_s_result_and_praises_only_a_hand_that_followed():
    """The last round's result was never shown (no next round shows it), and "Well done!"
    was said to every hand, a still one too. The end now gives the last round's result;
    a hand that did not follow the last round ends with "Finished.", not praise."""
    r = _records()
    end = _frame_at_sample(r, APPROACH + EXERCISE + 5)
    assert end.cue == CUE_DONE
    assert end.result == "Lap 3 done! Right on the path"  # 3 mm off both ways
    assert end.success
    params = PARAMS.replace(assist="transparent")
    still = _records(params)
    still["position"] = still["position_desired"][APPROACH]  # at the start all along
    end = _frame_at_sample(still, APPROACH + EXERCISE + 5, params=params)
    assert end.cue == CUE_OVER
    assert end.result == "Lap 3 over: next time, follow the whole path"
    assert not end.success
