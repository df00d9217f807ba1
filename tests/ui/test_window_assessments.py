"""The Assessments tab in the window (issue 31): a task read and its trial put in the
Parameters form, which then builds it as that task until a field its protocol fixes is
changed; a task run through the window's own Build, Connect and Start with the real loop
and recorder, its figures in the registry and on the tab, and its page saved as a PDF."""

import pytest

from app.trials.reader import read_trial
from core.assessment.protocol import protocol
from device.loop.states import State
from tests.ui.session import build_connect_start, click, open_window, register_patient

WAIT_MS = 30_000
"""A bound for a hang, never a measure of speed."""


def read(qtbot, win) -> None:
    """Wait for the tab's figures (read on the job thread) to be shown."""
    qtbot.waitUntil(lambda: not win.assessment_reading(), timeout=WAIT_MS)


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    yield win
    win.close()


def test_a_task_is_read_and_set_up_and_a_changed_field_makes_it_an_exercise(qtbot, window):
    win = window
    tab = win.assessments_tab
    assert win.tabs.tabText(win.tabs.indexOf(tab)) == "Assessments"
    register_patient(qtbot, win)
    win.tabs.setCurrentWidget(tab)
    read(qtbot, win)
    assert "has no visually guided reaching yet" in tab.results.toPlainText()
    tab.choose("circle")
    words = tab.protocol_text.toPlainText()
    assert protocol("circle").therapist in words
    assert protocol("circle").patient in words
    assert tab.trial.count() == 2
    tab.trial.setCurrentIndex(1)
    click(qtbot, tab.use_button)
    held = win.parameters_tab.parameters()
    assert held.assessment == "circle"
    assert not held.clockwise
    assert (held.shape, held.radius_m, held.repetitions) == ("circle", 0.07, 5)
    assert held.body_mass_kg == 70.0  # the patient's, not the default's
    assert "holds the circle drawing (counter-clockwise)" in tab.setup.text()
    # a field the protocol fixes, changed: an exercise again, and the tab says so
    win.parameters_tab.repetitions.setValue(3)
    win.parameters_tab.refresh()
    assert win.parameters_tab.parameters().assessment == ""
    assert "holds an exercise, not a task" in tab.setup.text()
    # a field it does not fix (the tolerance) keeps the task
    click(qtbot, tab.use_button)
    win.parameters_tab.tolerance.setValue(25.0)
    win.parameters_tab.refresh()
    assert win.parameters_tab.parameters().assessment == "circle"


@pytest.mark.slow
def test_a_task_runs_through_the_windows_buttons(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        register_patient(qtbot, win)
        tab = win.assessments_tab
        win.tabs.setCurrentWidget(tab)
        tab.choose("circle")
        click(qtbot, tab.use_button)
        build_connect_start(qtbot, win)
        qtbot.waitUntil(lambda: win.state != State.RUNNING, timeout=120000)
        code = win.patient.code
        qtbot.waitUntil(lambda: any(t.finished and t.metrics for t in
                                    win.registry.trials_for_patient(code)), timeout=60000)
        (trial,) = win.registry.trials_for_patient(code)
        assert trial.status == "complete"
        assert trial.parameters["assessment"] == "circle"
        assert trial.metrics["circle_mean_speed_cw_m_s"] > 0.05
        data = read_trial(win.registry.trial_path(trial), ())
        assert data.parameters.assessment == "circle"
        assert data.metrics["circle_ratio_cw"] == pytest.approx(trial.metrics["circle_ratio_cw"])
        win.tabs.setCurrentWidget(win.parameters_tab)
        win.tabs.setCurrentWidget(tab)
        read(qtbot, win)
        shown = tab.results.toPlainText()
        assert f"Patient {code}, session 1" in shown
        assert "No normative model in use" in shown or "Norms: " in shown
        saved = win.save_assessment_pdf("circle", tmp_path / "circle.pdf")
        assert saved is not None
        assert saved.read_bytes().startswith(b"%PDF")
    finally:
        win.close()


def test_an_assessment_leaves_the_exercises_proposal_offered(qtbot, window):
    """An assessment proposes nothing (app.trials.finalize): the window keeps offering the
    exercise's proposal that still waits for the next exercise, as it does after a
    restart; it had hidden it until the console was started again."""
    from app.trials.finalize import finalize_trial
    from core.trial import THESIS_SUBJECT
    from tests.app.assessments.registered import register

    register_patient(qtbot, window)
    code = window.patient.code
    exercise = register(window.registry, code, {}, task="",
                        parameters=THESIS_SUBJECT.replace(repetitions=1), finish=False)
    done = finalize_trial(window.registry, exercise.trial_id, "complete")
    window._finalized(exercise.trial_id, done)  # its reads after it on the job thread
    qtbot.waitUntil(lambda: window.unsaved_trial == exercise.trial_id, timeout=60000)
    box = window.parameters_tab.proposal
    assert not box.isHidden()
    offered = box.proposal
    assessment = register(window.registry, code, {"vgr_reaction_time_s": 0.4},
                          parameters=THESIS_SUBJECT.replace(assist="transparent",
                                                            shape="targets"), finish=False)
    done = finalize_trial(window.registry, assessment.trial_id, "complete")
    assert done.proposal is None
    window._finalized(assessment.trial_id, done)
    qtbot.waitUntil(lambda: window.unsaved_trial == assessment.trial_id, timeout=60000)
    assert not box.isHidden(), "the exercise's proposal was hidden after an assessment"
    assert box.proposal == offered


def test_the_strength_tasks_polar_plot_shows_its_figures_and_hides_for_other_tasks(
        qtbot, window):
    """The tab draws the strength page's polar plot beside its text (ui.tabs.strength_polar):
    the peak and mean polygons at (F cos θ, F sin θ) N of the trial's metrics, with a gap
    where a direction was not measured, the line shown dashed, the directions named; it is
    hidden for a task without one."""
    import math

    import numpy as np

    from app.assessments.strength import lines_N
    from core.trial import THESIS_SUBJECT
    from tests.app.assessments.registered import register
    from tests.core.assessment.test_strength_polar import METRICS

    register_patient(qtbot, window)
    code = window.patient.code
    parameters = protocol("strength").parameters(THESIS_SUBJECT)
    register(window.registry, code, METRICS, task="strength", parameters=parameters)
    tab = window.assessments_tab
    window.tabs.setCurrentWidget(tab)
    read(qtbot, window)
    assert tab.polar.isHidden()  # reaching: no polar plot
    tab.choose("strength")
    read(qtbot, window)
    assert tab.polar.isVisible()
    # the text stays, each number held to its unit (a no-break space: the panel wrapped
    # '… (mean of directions): 10.6' above a lone 'N')
    # (in the report's places for N: two)
    assert "Peak force 0°: 10.00\u00a0N" in tab.results.document().toRawText()
    theta = np.radians([0, 45, 90, 135, 180, 225, 270, 315, 360])
    nan = math.nan
    for curve, radius in ((tab.polar.peak_curve, [10, 12, 20, 14, nan, 9, 0, nan, 10]),
                          (tab.polar.mean_curve, [6, 7, 11, 8, nan, 4, 0, nan, 6])):
        x, y = curve.getData()
        np.testing.assert_allclose(x, np.multiply(radius, np.cos(theta)), atol=1e-12)
        np.testing.assert_allclose(y, np.multiply(radius, np.sin(theta)), atol=1e-12)
    shown = lines_N(parameters.replace(side=window.patient.side or "right"))
    x, y = tab.polar.line_curve.getData()
    line = np.hypot(x, y)
    np.testing.assert_allclose(line[:-1], [shown[d] for d in sorted(shown)])
    texts = [label.toPlainText() for label in tab.polar.labels]
    assert "left\n0°" in texts
    assert "away\n270°" in texts
    assert "right\n180°\nnot measured" in texts
    assert "20 N" in texts  # the outer circle's force: the largest peak
    item = tab.polar.getPlotItem()
    assert item.getViewBox().state["aspectLocked"]
    assert item.getViewBox().xInverted()
    assert item.getViewBox().yInverted()
    tab.choose("position")
    assert tab.polar.isHidden()  # at once: hidden while the figures are read
    read(qtbot, window)
    assert tab.polar.isHidden()
    assert "has no position sense yet" in tab.results.toPlainText()


def test_a_robot_led_tasks_protocol_says_how_long_it_runs_and_what_the_robot_does():
    """Found trying the window: the strength protocol's first line read "1 trial, 1 × 3 s
    each; 8 targets 5 cm from the centre; the robot transparent", under words saying the
    robot holds the handle still; the trial ran 48 s (8 pushes with their rests)."""
    from core.trial import THESIS_SUBJECT
    from ui.tabs.assessments import protocol_words

    for task, robot in (("strength", "the robot holds the handle still"),
                        ("position", "the robot takes the relaxed hand to each target")):
        total_s = protocol(task).parameters(THESIS_SUBJECT).trajectory().total_duration_s
        first = protocol_words(task).splitlines()[0]
        assert f", {total_s:.0f} s; " in first
        assert robot in first
        assert "transparent" not in first
    # in the words of the Parameters tab's summary and `rehab assess tasks`
    assert protocol_words("strength").startswith(
        "Isometric strength: 1 trial: 8 directions, a push of 3 s each; 1 round, 48 s; the "
        "robot holds the handle still.")
    # a task the patient leads reads as before
    assert protocol_words("reaching").splitlines()[0].endswith("the robot transparent.")
    # its rounds and laps said as such: "1 trial, 2 × 48 s each" read as two trials
    assert protocol_words("reaching").startswith(
        "Visually guided reaching: 1 trial, 2 rounds of 48 s (96 s); 8 targets")
    assert protocol_words("circle").startswith(
        "Circle drawing: 2 trials: clockwise, counter-clockwise, each 5 laps of 4 s (20 s);")


@pytest.mark.slow
def test_a_task_set_up_then_a_level_set_runs_at_the_level_the_form_shows(
        qtbot, tmp_path, monkeypatch):
    """The state machine's steps (brief hQ): circle drawing set up (transparent), Build,
    then the level set to 60 % (as a second Build's form would have it) and Build again,
    Connect and Start. The form showed a greyed "60 %" at Start while the robot, its file
    and the registry ran at 0 %; it shows 0 %, what runs, and the file says what it
    showed."""
    import dataclasses

    import numpy as np

    from core.assessment.protocol import PROTOCOLS
    from tests.ui.session import build_and_connect

    monkeypatch.setitem(PROTOCOLS, "circle", dataclasses.replace(
        PROTOCOLS["circle"], repetitions=1, duration_s=2.0))  # one short lap
    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        register_patient(qtbot, win)
        tab, p = win.assessments_tab, win.parameters_tab
        win.tabs.setCurrentWidget(tab)
        tab.choose("circle")
        click(qtbot, tab.use_button)
        click(qtbot, win.robot.buttons["build"])
        qtbot.waitUntil(lambda: win.state == State.BUILT and win.built is not None,
                        timeout=60000)
        p.assistance.setValue(60)
        p.refresh()
        win.tabs.setCurrentWidget(p)
        build_and_connect(qtbot, win)
        shown = (p.assistance.text(), p._values()["assistance_level"])
        click(qtbot, win.robot.buttons["start"])
        qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=10000)
        qtbot.waitUntil(lambda: win.state != State.RUNNING, timeout=120000)
        code = win.patient.code
        qtbot.waitUntil(lambda: any(t.finished for t in
                                    win.registry.trials_for_patient(code)), timeout=60000)
        (trial,) = win.registry.trials_for_patient(code)
        data = read_trial(win.registry.trial_path(trial))
        running = np.asarray(data.channels["phase"]).reshape(-1) > 0
        ran = set(np.asarray(data.channels["assistance_level"]).reshape(-1)[running])
        assert (data.parameters.assist, trial.parameters["assistance_level"]) == (
            "transparent", 0.0)
        assert shown == ("0 %", 0.0), f"the form showed {shown[0]} at Start"
        assert ran == {shown[1]}
    finally:
        win.close()
