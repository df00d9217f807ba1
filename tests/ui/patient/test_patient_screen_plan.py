"""A session plan on the patient's screen (issue 30): the rest's countdown in place of the
table, the block and the session's progress during a block, the end in the patient's words;
fed from the window's plan runner as it repaints."""

import math

import pytest
from PySide6.QtWidgets import QApplication

from app.plans.runner import PlanState
from core.trial import THESIS_SUBJECT
from tests.ui.session import open_window
from ui.patient.window import CURSOR, GO, PatientWindow
from ui.views.patient_plan import laps_passed, overlay
from ui.views.patient_screen import CUE_READY, PatientFrame, waiting_frame


def _state(**changes) -> PlanState:
    values = dict(phase="running", block=2, n_blocks=3, block_name="D shape", round=1,
                  rounds=1, laps_planned=5, laps_done=0, movements_done=30,
                  movements_planned=120, rest_left_s=0.0, time_left_s=300.0, outcome="",
                  reason="", done_share=0.25, lap_share=0.05)
    values.update(changes)
    return PlanState(**values)


@pytest.fixture
def patient(qtbot):
    window = PatientWindow()
    qtbot.addWidget(window)
    window.resize(1000, 700)
    window.show_parameters(THESIS_SUBJECT)
    return window


def test_the_rest_countdown_replaces_the_table(patient):
    patient.show_plan(_state(phase="resting", rest_left_s=44.2,
                             next_trial=THESIS_SUBJECT.replace(shape="circle", repetitions=4),
                             next_rounds=1))
    image = patient.grab().toImage()
    assert patient.painted["plan"] == ("Rest", "0:45")
    assert patient.painted["top"] == ("Block 2 of 3", "", "")
    assert patient.painted["cursor"] is None  # no table during a rest
    area = patient.screen_layout().table
    greens = sum(image.pixelColor(x, y) == GO
                 for x in range(round(area.left), round(area.left + area.width), 4)
                 for y in range(round(area.top + 0.4 * area.height),
                                round(area.top + area.height), 4))
    assert greens > 50  # the countdown, large, in green
    assert patient.plan.message == "Next: Circle, 4 laps"
    patient.show_plan(_state(phase="resting", rest_left_s=3.0, block=3))
    patient.grab()
    assert patient.painted["plan"] == ("Rest", "0:03")
    assert patient.plan.message == ""  # the last block: nothing next


@pytest.mark.parametrize(("next_trial", "rounds", "words"), [
    (dict(shape="targets", game="reach", repetitions=1, n_targets=6), 3,
     "Next: Reaching game, 3 rounds of 6 targets"),
    (dict(shape="targets", game="reach", repetitions=2, n_targets=6), 1,
     "Next: Reaching game, 2 laps"),
    (dict(game="path", repetitions=2, assist="transparent"), 3,
     "Next: Path game, 3 rounds of 2 laps"),
    (dict(repetitions=1), 1, "Next: D shape, 1 lap"),
])
def test_a_rest_says_what_comes_next_in_the_patient_s_words(next_trial, rounds, words):
    """It said "Next: block 2": the patient is told the game or the exercise by the name
    their report gives it, and how much, counted as the screen will count it (a reaching
    game of one lap by its targets)."""
    state = _state(phase="resting", rest_left_s=30.0,
                   next_trial=THESIS_SUBJECT.replace(**next_trial), next_rounds=rounds)
    assert overlay(state).message == words


def test_the_next_block_goes_on_two_lines_rather_than_shrink(qtbot):
    """One line of "Next: Reaching game, 3 rounds of 6 targets" came to 95 % of the
    screen's letter size, edge to edge: two lines keep the size."""
    window = PatientWindow()
    qtbot.addWidget(window)
    window.resize(1920, 1080)
    window.show_parameters(THESIS_SUBJECT)
    reach = THESIS_SUBJECT.replace(shape="targets", game="reach", repetitions=1, n_targets=6)
    window.show_plan(_state(phase="resting", rest_left_s=30.0, next_trial=reach,
                            next_rounds=3))
    window.grab()
    text_px = window.screen_layout().text_px
    assert window.painted["plan_lines"] == ("Next: Reaching game,", "3 rounds of 6 targets")
    assert window.painted["plan_px"] == (text_px, text_px)
    window.show_plan(_state(phase="resting", rest_left_s=30.0,
                            next_trial=THESIS_SUBJECT.replace(repetitions=5), next_rounds=1))
    window.grab()
    assert window.painted["plan_lines"] == ("Next: D shape, 5 laps",)  # one line fits


def test_during_a_block_the_block_and_the_session_s_progress_show(patient):
    patient.show_plan(_state())
    patient.frame = PatientFrame(CUE_READY, False, None, None, -1, 0, 5, 12.0)
    patient.grab()
    assert patient.painted["message"] == "Block 2 of 3. Get ready"  # the block's first round
    patient.frame = PatientFrame("", False, None, None, -1, 2, 5, 8.0)
    image = patient.grab().toImage()
    assert patient.painted["top"] == ("Lap 2 of 5", "", "0:08 left")  # as a trial alone
    assert patient.painted["progress"] == pytest.approx(0.25)
    bands = patient.screen_layout()
    y = round(bands.top.height + 2)
    assert image.pixelColor(round(0.1 * patient.width()), y) == CURSOR  # done: the left
    assert image.pixelColor(round(0.9 * patient.width()), y) != CURSOR


@pytest.mark.parametrize(("outcome", "words"), [("complete", "Session complete. Well done!"),
                                                ("emergency_stop", "Stopped")])
def test_the_end_is_said_in_the_patient_s_words(patient, outcome, words):
    patient.show_plan(_state(phase="ended", outcome=outcome, reason="E-STOP pressed"))
    patient.grab()
    assert patient.painted["plan"][0] == words
    assert "E-STOP" not in patient.plan.message  # the therapist's words stay theirs


def test_no_plan_no_overlay():
    assert overlay(None) is None
    assert overlay(_state(phase="idle", block=0)) is None
    assert math.isnan(overlay(_state(done_share=math.nan)).progress)


def test_the_bar_moves_with_the_running_trial_s_laps_and_never_back():
    """A two-minute block's bar stood still: it counted the movements of finished trials
    only. The running trial's laps passed on the screen's clock now move it, up to the
    laps it runs, while the plan says a trial runs or is being saved; never back."""
    running = _state()  # 0.25 done, a lap 0.05, 5 laps running
    assert overlay(running, 0.0).progress == pytest.approx(0.25)
    assert overlay(running, 2.5).progress == pytest.approx(0.375)
    assert overlay(running, 9.0).progress == pytest.approx(0.5)  # no more than it runs
    assert overlay(_state(phase="saving"), 5.0).progress == pytest.approx(0.5)
    # building the next round: the last trial's laps are in done_share already
    assert overlay(_state(phase="building"), 5.0).progress == pytest.approx(0.25)
    assert overlay(running, 1.0).at_least(0.4).progress == pytest.approx(0.4)
    assert overlay(running, 4.0).at_least(0.4).progress == pytest.approx(0.45)


def test_the_laps_passed_are_the_trial_s_clock():
    frame = PatientFrame("", False, None, None, -1, 2, 3, 7.0)  # lap 2 of 3, 4 s laps
    assert laps_passed(frame, 4.0) == pytest.approx(3 - 7.0 / 4.0)
    assert laps_passed(waiting_frame(None), 4.0) == 0.0
    assert laps_passed(PatientFrame("", False, None, None, -1, 3, 3, 0.0), 4.0) == 3.0


def test_the_console_feeds_its_plan_runner_s_state(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    asked = []

    class Runner:
        phase = "resting"

        def state(self, now):
            asked.append(now)
            return _state(phase="resting", rest_left_s=10.0)

    patient = win.open_patient_screen()
    qtbot.waitExposed(patient, timeout=20000)
    assert patient.plan is None
    win.plan_runner = Runner()
    win._repaint()
    assert patient.plan.centre == "Rest"
    assert asked
    win.plan_runner = None
    win._repaint()
    assert patient.plan is None
    assert QApplication.activeWindow() is not patient
    win.close()


def test_a_block_of_several_rounds_names_its_round_as_the_status_line_does(patient):
    """A game block of three rounds: the patient saw "Block 1 of 2" and, in the middle,
    "Round 1 of 3" meaning the trial's lap; the therapist's line said "round 2 of 3"
    meaning the block's trial. Now a lap is a lap and the screen says the block's round
    in the status line's words with the trial's "Get ready" (the top band keeps its
    size), the block with its first round's."""
    state = _state(block=1, n_blocks=2, round=2, rounds=3)
    plan = overlay(state)
    assert (plan.block_text, plan.ready_text) == ("Block 1 of 2", "Round 2 of 3")
    assert state.line().startswith("Block 1 of 2, round 2 of 3")
    assert overlay(_state(phase="resting", round=3, rounds=3)).ready_text == ""
    assert overlay(_state(round=1, rounds=3)).ready_text == "Block 2 of 3"
    assert overlay(_state()).ready_text == "Block 2 of 3"  # one round: the block said
    patient.show_plan(state)
    patient.frame = PatientFrame(CUE_READY, False, None, None, -1, 0, 3, 12.0)
    patient.grab()
    assert patient.painted["message"] == "Round 2 of 3. Get ready"
    assert patient.painted["top"] == ("", "", "0:12 left")


def test_a_plan_s_next_block_shows_waiting_as_its_build_is_asked_not_the_last_lap(
        qtbot, tmp_path, monkeypatch):
    """For about 0.1 s as a plan's next block was built the patient's top band still
    showed the last trial's end, "Lap 2 of 2" and "0:00 left", until the loop answered
    the Build: the live view stayed the last built trial's. Now, the plan building, the
    screen shows the exercise being built, waiting."""
    from app.trials.headless import simulate_to_file
    from app.trials.reader import read_trial
    from ui.views.trialview import TrialView

    last = THESIS_SUBJECT.replace(repetitions=2, duration_s=1.5)
    path = tmp_path / "last.h5"
    simulate_to_file(last, path, patient="healthy", seed=3)
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        view = TrialView.from_trial(read_trial(path))
        win.live, win.built = view, view.parameters
        patient = win.open_patient_screen()
        qtbot.waitExposed(patient, timeout=20000)
        win._repaint()
        patient.grab()
        assert patient.painted["top"] == ("Lap 2 of 2", "", "0:00 left")  # its end

        class Runner:
            phase = "building"

            def state(self, now):
                return _state(phase="building", block=2, n_blocks=2, laps_planned=1)

        following = last.replace(game="path", repetitions=1, duration_s=4.0,
                                 assist="transparent", assistance_level=0.0)
        win._pending_build = following  # the plan's Build, asked of the loop
        win.plan_runner = Runner()
        win._repaint()
        patient.grab()
        assert patient.painted["top"] == ("", "", "0:04 left")
        assert patient.painted["message"] == "Please wait"
        assert patient.scene.parameters == following
    finally:
        win.plan_runner = None
        win.close()


def test_a_pause_in_a_trial_says_pause_at_once_never_stopped(patient):
    """Brief hT: Pause pressed mid-trial, the patient's screen said "Stopped" for about a
    second, the loop stopping the trial and its file being saved, before "Pause": the
    plan was paused only once the trial's file was finished. The patient, who did
    nothing wrong, read that something had gone wrong. Now "Pause" covers the table from
    the press, whatever the trial's end says meanwhile."""
    from app.plans.runner import PAUSED, PlanRunner
    from core.plan import Block, Plan
    from ui.patient.window import stopped_frame
    from ui.views.patient_plan import PAUSE_WORDS

    class Console:
        """The loop and the registry as the runner sees them: asked, answering later."""

        def __getattr__(self, _name):
            return lambda *args, **kwargs: None

    plan = Plan("One", (Block(shape="d", repetitions=4, duration_s=2.0, rest_s=0.0),))
    runner = PlanRunner(plan, THESIS_SUBJECT, Console())
    runner.start(0.0)
    runner.built(0.0, True)
    runner.started(0.0, 1)
    patient.show_plan(runner.state(0.5))
    patient.grab()
    assert patient.plan.centre == ""  # the trial's screen while it runs

    def said(now: float) -> str:
        # the trial Pause stopped ends early: the console marks its frame "Stopped"
        # (ui.patient.control) until the next Build
        patient.frame = stopped_frame(patient.frame, True)
        patient.show_plan(runner.state(now))
        patient.grab()
        return patient.painted.get("plan", ("",))[0] or patient.painted["message"]

    runner.pause(1.0)  # the loop is asked to stop the trial
    assert said(1.0) == PAUSE_WORDS
    runner.trial_ended(1.3)  # stopped: its file being finished
    assert said(1.3) == PAUSE_WORDS
    runner.finished(2.0, 1, "stopped_early", 1, 0.8)
    assert runner.phase == PAUSED
    assert said(2.0) == PAUSE_WORDS


def test_a_round_resumed_after_a_pause_counts_its_laps_on(patient):
    """Seen in the window (brief hT): a five-minute block paused at "Lap 2 of 60" came back
    as "Lap 1 of 58", the patient's count gone back, the resumed trial counting only the
    laps it had left. The top band counts the round's laps on from the paused trial's."""
    state = _state(block=1, laps_planned=58, laps_done=2)
    patient.show_plan(state)
    patient.frame = PatientFrame("", False, None, None, -1, 1, 58, 290.0)
    patient.grab()
    assert patient.painted["top"][0] == "Lap 3 of 60"
    patient.frame = PatientFrame(CUE_READY, False, None, None, -1, 0, 58, 290.0)
    patient.grab()
    assert patient.painted["top"][0] == ""  # no lap under way yet
    patient.show_plan(_state(block=1, laps_planned=60, laps_done=0))
    patient.frame = PatientFrame("", False, None, None, -1, 1, 60, 300.0)
    patient.grab()
    assert patient.painted["top"][0] == "Lap 1 of 60"


@pytest.mark.parametrize("followed", [True, False])
def test_a_resumed_round_s_end_names_the_lap_the_band_counted(patient, followed):
    """Brief hT: a round resumed after a pause ended saying "Lap 58 done!" under a top band
    "Lap 60 of 60": the band counted the laps on from the paused trial's, the last lap's
    result kept the resumed trial's own number. Both say the round's lap."""
    from tests.ui.views.timetable import on_the_path
    from ui.views.patient_screen import PatientOptions, Scene, frame_at
    from ui.views.trialview import TrialView

    params = THESIS_SUBJECT.replace(repetitions=3, duration_s=2.0)
    records = on_the_path(params, 300, 100)
    if not followed:
        records["position"] = records["position_desired"][300]  # the hand left at the start
    view = TrialView(params)
    view.append(records)
    patient.show_parameters(params)
    patient.show_plan(_state(block=1, laps_planned=3, laps_done=57))
    patient.frame = frame_at(view, Scene.of(params), PatientOptions())
    patient.grab()
    assert patient.painted["top"][0] == "Lap 60 of 60"
    said = "Lap 60 done! Right on the path" if followed else \
        "Lap 60 over: next time, follow the whole path"
    assert patient.painted["message"].endswith(said)
    assert "58" not in patient.painted["message"]
