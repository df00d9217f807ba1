"""The patient's screen in the tasks the robot leads (ui.views.patient_screen): position
sense keeps the table blank (no layout, no hand, no target) while the robot moves the hand
and while the patient matches; strength shows only the push's arrow with its line and the
force pushed along it; each phase says its words, on records made to order."""

import math

import pytest

from core.assessment.protocol import protocol
from core.trial import THESIS_SUBJECT
from device.loop.pipeline import PERIOD_S
from tests.ui.views.timetable import on_the_path
from ui.views.patient_screen import TASK_WORDS, PatientOptions, Scene, frame_at
from ui.views.trialview import TrialView

APPROACH, HOLD = 100, 100
STRENGTH = protocol("strength").parameters(THESIS_SUBJECT).replace(n_targets=2)
POSITION = protocol("position").parameters(THESIS_SUBJECT).replace(n_targets=2,
                                                                   repetitions=1)


def records(params, push_N=0.0):
    """A trial's records on the task's timetable: the hand where the reference is, 2 cm
    off in the matches, pushing `push_N` along each push."""
    r = on_the_path(params, APPROACH, HOLD)
    r["force"] = push_N * r["direction_desired"]
    return r


def frame(params, r, t_exercise_s):
    i = APPROACH + round(t_exercise_s / PERIOD_S)
    view = TrialView(params)
    view.append(r[:i + 1])
    return frame_at(view, Scene.of(params), PatientOptions())


def test_position_sense_keeps_the_table_blank_and_says_each_phase():
    r = records(POSITION)
    stretches = POSITION.trajectory().stretches
    for k, stretch in enumerate(stretches):
        f = frame(POSITION, r, 0.5 * (stretch.start_s + stretch.stop_s))
        assert f.cue == TASK_WORDS[stretch.phase]
        assert f.repetition == dict(stretch.values)["index"] + 1  # the target's number
        assert f.repetition_text == f"Target {f.repetition} of 2"
        last_home = k == len(stretches) - 1
        assert f.blank is not last_home
        if f.blank:
            assert f.cursor_m is None
            assert f.target_m is None
            assert f.active_target == -1
    # before the exercise the hand is shown on its way to the start
    view = TrialView(POSITION)
    view.append(r[:APPROACH // 2])
    before = frame_at(view, Scene.of(POSITION), PatientOptions())
    assert not before.blank
    assert before.cursor_m is not None


def test_strength_shows_the_push_with_its_line_and_the_force_along_it():
    r = records(STRENGTH, push_N=3.0)
    for stretch in STRENGTH.trajectory().stretches:
        f = frame(STRENGTH, r, 0.5 * (stretch.start_s + stretch.stop_s))
        values = dict(stretch.values)
        assert f.cue == TASK_WORDS[stretch.phase]
        assert f.blank
        assert f.cursor_m is None
        if stretch.phase == "rest":
            assert f.push is None
            continue
        angle, line, force = f.push
        assert angle == values["direction_rad"]
        assert line == values["line_N"]
        assert force == pytest.approx(3.0 if stretch.phase == "push" else 0.0)


def test_a_task_s_time_left_is_its_timetable_s():
    r = records(STRENGTH)
    total = STRENGTH.trajectory().total_duration_s
    f = frame(STRENGTH, r, 10.0)
    assert f.time_left_s == pytest.approx(total - 10.0, abs=PERIOD_S)
    assert math.isfinite(f.exercise_started_s)


def test_a_task_counts_its_pushes_not_laps_nor_rounds():
    """The patient's screen said "Round 1 of 2" in a task, the word a session plan uses
    for one of a block's trials (and "Round" for a lap elsewhere). A task counts what the
    patient does: each push of every round, "Push 3 of 4" (2 directions, 2 rounds)."""
    params = STRENGTH.replace(repetitions=2)
    r = records(params, push_N=3.0)
    pushes = [s for s in params.trajectory().stretches if s.phase == "push"]
    assert len(pushes) == 4
    said = [frame(params, r, 0.5 * (s.start_s + s.stop_s)).repetition_text for s in pushes]
    assert said == ["Push 1 of 4", "Push 2 of 4", "Push 3 of 4", "Push 4 of 4"]
    end = frame(params, r, params.trajectory().total_duration_s + 0.1)
    assert end.repetition_text == "Push 4 of 4"
