"""The Parameters tab as a therapist uses it: typing values, reading the refusal under the
field at fault, seeing the unreachable part of the path, fixing it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt

from app.records.datadir import DataDir
from app.records.registry import Registry
from core.errors import UnreachableError
from core.games.staircase import start
from core.trial import POSITION_RANGE_M, RADIUS_RANGE_M, THESIS_SUBJECT, TrialParameters
from core.trial_check import check_trial
from tests.ui.shown import shown
from ui import theme
from ui.tabs.parameters import HARDWARE, SIMULATOR, ParametersTab


@pytest.fixture
def tab(qtbot, qapp):
    theme.apply_theme(qapp)
    return shown(qtbot, ParametersTab())


def type_into(qtbot, field, text: str) -> None:
    """Type as a therapist does, then commit with Enter (a number counts only then)."""
    field.setFocus()
    field.selectAll()
    qtbot.keyClicks(field, text)
    qtbot.keyClick(field, Qt.Key.Key_Return)


def test_shoulder_as_printed_is_refused_with_distances_and_marked_on_the_preview(qtbot, tab):
    assert tab.problem() == ""
    with qtbot.waitSignal(tab.parameters_changed, timeout=2000) as signal:
        type_into(qtbot, tab.shoulder_x, "12")
    parameters, problem = signal.args
    assert parameters is None
    # in the form's unit, cm (issue 13 #6: the refusal was in metres)
    assert "67.6 cm from the shoulder" in problem
    assert "reaches 61.0 cm" in problem

    for key in ("centre", "shoulder"):
        label = tab.errors[key]
        assert label.isVisible()
        assert "point (-30.0, 20.0) cm is 67.6 cm from the shoulder" in label.text()
        assert "61.0 cm" in label.text()
        assert " m " not in label.text()
    assert not tab.errors["radius"].isVisible()
    assert "Not ready" in tab.status.text()
    with pytest.raises(UnreachableError, match=r"67\.6 cm"):
        tab.parameters()

    # The preview marks the unreachable points: the ones check_trial finds, in cm.
    check = check_trial(THESIS_SUBJECT.replace(shoulder_m=(0.12, 0.73)))
    bad = check.points_m[~check.reachable] * 100
    xs, ys = tab.path_bad.getData()
    assert len(xs) > 0
    for x, y in zip(xs, ys, strict=True):
        assert np.min(np.hypot(bad[:, 0] - x, bad[:, 1] - y)) < 1e-9
    shoulder = tab.shoulder_mark.getData()
    assert (shoulder[0][0], shoulder[1][0]) == pytest.approx((12.0, 73.0))

    with qtbot.waitSignal(tab.parameters_changed, timeout=2000) as signal:
        type_into(qtbot, tab.shoulder_x, "-12")
    parameters, problem = signal.args
    assert problem == ""
    assert parameters.shoulder_m == (-0.12, 0.73)
    assert not tab.errors["centre"].isVisible()
    assert not tab.errors["shoulder"].isVisible()
    assert len(tab.path_bad.getData()[0]) == 0
    assert "Ready" in tab.status.text()
    assert tab.parameters() == parameters


def test_too_fast_path_is_refused_under_the_time_field(qtbot, tab):
    with qtbot.waitSignal(tab.parameters_changed, timeout=2000) as signal:
        type_into(qtbot, tab.radius, "25")
        type_into(qtbot, tab.duration, "1")
        type_into(qtbot, tab.shoulder_y, "90")
    assert signal.args[0] is None
    assert "peak speed" in tab.errors["duration"].text()
    assert tab.errors["duration"].isVisible()


def test_spin_boxes_hold_the_allowed_ranges(qtbot, tab):
    assert tab.radius.minimum() == pytest.approx(RADIUS_RANGE_M[0] * 100)
    assert tab.radius.maximum() == pytest.approx(RADIUS_RANGE_M[1] * 100)
    assert tab.centre_x.maximum() == pytest.approx(POSITION_RANGE_M[1] * 100)
    type_into(qtbot, tab.radius, "99")
    tab.radius.interpretText()
    assert tab.radius.value() <= RADIUS_RANGE_M[1] * 100
    assert tab.radius.suffix() == " cm"
    assert tab.tolerance.suffix() == "°"


def test_set_parameters_round_trips_in_si(qtbot, tab):
    chosen = TrialParameters(
        shape="circle", centre_m=(-0.25, 0.35), radius_m=0.08, duration_s=6.5, repetitions=3,
        timing="minimum_jerk", clockwise=False, shoulder_m=(-0.15, 0.75), body_mass_kg=70.5,
        upper_arm_m=0.29, forearm_m=0.27, side="right", tolerance_rad=math.radians(30.0),
        controller="ctpid", assistance_level=0.6)
    with qtbot.waitSignal(tab.parameters_changed, timeout=2000) as signal:
        tab.set_parameters(chosen)
    assert signal.args == [chosen, ""]
    assert tab.parameters() == chosen
    assert tab.radius.text() == "8.00 cm"
    assert tab.tolerance.text() == "30.0°"
    assert tab.assistance.text() == "60 %"


def test_choices_by_combo_and_checkbox(qtbot, tab):
    with qtbot.waitSignal(tab.parameters_changed, timeout=2000) as signal:
        tab.controller.setCurrentIndex(tab.controller.findData("ctpid"))
        box = tab.clockwise
        qtbot.mouseClick(box, Qt.MouseButton.LeftButton, pos=QPoint(12, box.height() // 2))
    parameters = signal.args[0]
    assert parameters.controller == "ctpid"
    assert parameters.clockwise is False


def test_camera_and_backend_choices(qtbot, tab):
    assert tab.camera_source() is None
    with qtbot.waitSignal(tab.camera_changed) as signal:
        tab.with_camera.click()
    assert signal.args == [0]
    tab.camera_source_edit.clear()
    qtbot.keyClicks(tab.camera_source_edit, "/videos/session.mp4")
    assert tab.camera_source() == "/videos/session.mp4"

    assert tab.backend().name == SIMULATOR
    assert tab.backend().patient_kind == "healthy"
    tab.patient_kind.setCurrentIndex(tab.patient_kind.findData("spastic"))
    assert tab.backend().patient_kind == "spastic"
    with qtbot.waitSignal(tab.backend_changed):
        tab.hardware.click()
    assert tab.backend().name == HARDWARE
    assert "settings file" in tab.backend_problem()
    assert tab.errors["settings_path"].isVisible()
    qtbot.keyClicks(tab.settings_path, "/etc/rehab/robot.toml")
    assert tab.backend_problem() == ""
    assert str(tab.backend().settings_path) == "/etc/rehab/robot.toml"


def test_every_virtual_patient_says_what_it_is(qtbot, tab):
    """The simulator's patient list: each kind's tooltip says what the virtual patient is
    (the weak one a stroke survivor's arm, device.sim.patients' defaults)."""
    from PySide6.QtCore import Qt

    from device.sim.patient_parameters import PATIENT_KINDS

    tips = {tab.patient_kind.itemData(i): tab.patient_kind.itemData(
        i, Qt.ItemDataRole.ToolTipRole) for i in range(tab.patient_kind.count())}
    assert set(tips) == set(PATIENT_KINDS)
    assert all(tip for tip in tips.values())
    assert "40 %" in tips["weak"]
    assert "selective" in tips["weak"]


def test_a_patients_measurements_fill_the_arm(qtbot, tab, tmp_path):
    registry = Registry(DataDir(tmp_path / "data"))
    patient = registry.create_patient("Sam", "Lefty", body_mass_kg=64.0, upper_arm_m=0.28,
                                      forearm_m=0.26, side="left", shoulder_m=(0.12, 0.73))
    tab.apply_patient(patient)
    assert tab.body_mass.value() == 64.0
    assert tab.side.currentData() == "left"
    assert tab.upper_arm.text() == "28.00 cm"


def test_a_patient_without_stored_measurements_never_runs_with_the_previous_ones(
        qtbot, tab, tmp_path):
    """Choosing a patient with no stored body and shoulder values kept the previous
    patient's in the form, and Build took them: the new patient's trial ran with another's
    arm. They are now refused under their rows until given (typed, or checked) and kept in
    the patient's record."""
    registry = Registry(DataDir(tmp_path / "data"))
    sam = registry.create_patient("Sam", "Lefty", body_mass_kg=64.0, upper_arm_m=0.32,
                                  forearm_m=0.29, side="right", shoulder_m=(-0.12, 0.70))
    ada = registry.create_patient("Ada", "Plain", body_mass_kg=58.0)  # no arm stored
    tab.apply_patient(sam)
    assert tab.parameters().upper_arm_m == pytest.approx(0.32)
    tab.apply_patient(ada)
    with pytest.raises(Exception, match="upper arm, forearm, shoulder position are not"):
        tab.parameters()
    assert tab.shown() is None  # a trial built for Sam is stale, so Start cannot run it
    for key in ("upper_arm", "forearm", "shoulder"):
        assert not tab.errors[key].isHidden()
    assert tab.errors["body_mass"].isHidden()  # hers, stored
    assert tab.keep_measurements.isVisible()
    # typed for her: that row is hers; the others are still not
    type_into(qtbot, tab.upper_arm, "31")
    with pytest.raises(Exception, match="forearm, shoulder position are not"):
        tab.parameters()
    assert "typed for this patient" in tab.errors["upper_arm"].text()
    _keep_in_record(qtbot, tab, registry)  # the rest checked against her and kept
    assert tab.parameters().upper_arm_m == pytest.approx(0.31)
    assert tab.parameters().body_mass_kg == pytest.approx(58.0)
    assert not tab.keep_measurements.isVisible()
    tab.apply_patient(sam)  # all stored: nothing to give
    assert tab.parameters().forearm_m == pytest.approx(0.29)
    tab.apply_patient(registry.patient(ada.code))  # and back: hers now, from her record
    assert tab.parameters().forearm_m == pytest.approx(0.29)
    assert tab.parameters().upper_arm_m == pytest.approx(0.31)
    tab.apply_patient(ada)  # as she was registered, nothing stored: refused again
    with pytest.raises(Exception, match="not stored"):
        tab.parameters()


def _keep_in_record(qtbot, tab, registry) -> None:
    """Press Keep with a name, and do what the window does with what the tab asks
    (ui.window.kept_measurements): each field kept by the registry's correction, the
    patient's record as it is then given back to the tab."""
    tab.checked_by.setText("K. Lee")
    with qtbot.waitSignal(tab.keep_asked, timeout=2000) as asked:
        tab.keep_measurements.click()
    code, values, by = asked.args
    for field, (value, reason) in values.items():
        patient = registry.correct_patient(code, field, value, reason=reason, by=by)
    tab.keep_answered()
    tab.apply_patient(patient)


def test_the_values_used_for_a_patient_are_kept_in_their_record_with_who_and_why(
        qtbot, tab, tmp_path):
    """'Use these values for this patient' let the trial run with them, and the patient's
    record still had none: the next time the same refusal came back, and the registry, the
    report and the exports could not say what the patient measures. The values the
    therapist confirms (typed, or the ones shown, checked) are asked to be kept in the
    record, with who checked them and how each was given; until then Build is refused."""
    registry = Registry(DataDir(tmp_path / "data"))
    ada = registry.create_patient("Ada", "Plain", body_mass_kg=58.0)
    tab.apply_patient(ada)
    type_into(qtbot, tab.forearm, "27")
    with qtbot.assertNotEmitted(tab.keep_asked):
        tab.keep_measurements.click()  # nobody named: the record keeps who
    assert "Checked by" in tab.status.text()
    tab.checked_by.setText("K. Lee")
    tab.upper_arm.setFocus()
    tab.upper_arm.selectAll()
    qtbot.keyClicks(tab.upper_arm, "33")  # on the screen, not yet committed
    with qtbot.waitSignal(tab.keep_asked, timeout=2000) as asked:
        tab.keep_measurements.click()
    code, values, by = asked.args
    assert (code, by) == (ada.code, "K. Lee")
    assert set(values) == {"upper_arm_m", "forearm_m", "shoulder_m"}  # not her body mass
    assert values["forearm_m"] == (pytest.approx(0.27), pytest.approx(
        "confirmed on the Parameters tab: typed for this patient"))
    assert values["upper_arm_m"] == (pytest.approx(0.33), pytest.approx(
        "confirmed on the Parameters tab: typed for this patient"))  # what it showed
    assert values["shoulder_m"][0] == pytest.approx(
        (tab.shoulder_x.value() / 100, tab.shoulder_y.value() / 100))  # shown in cm
    assert "checked against this patient" in values["shoulder_m"][1]
    assert tab.keep_measurements.text() == "Saving…"  # until the registry answers
    with pytest.raises(Exception, match="not stored"):
        tab.parameters()  # not in her record yet
    tab.keep_answered("upper_arm_m = 9 is not allowed")
    assert "Not kept: upper_arm_m = 9" in tab.status.text()
    assert tab.keep_measurements.isEnabled()


def test_the_first_patient_without_stored_measurements_is_refused_too(qtbot, tab, tmp_path):
    """The form's values at the start are the defaults or the settings' last trial (maybe
    another patient's): not this patient's either."""
    registry = Registry(DataDir(tmp_path / "data"))
    tab.apply_patient(registry.create_patient("Ada", "Plain", shoulder_m=(-0.12, 0.73)))
    with pytest.raises(Exception, match="body mass, upper arm, forearm are not stored"):
        tab.parameters()
    assert tab.errors["shoulder"].isHidden()


def test_the_assistance_mode_is_chosen_shown_and_the_level_announced_at_once(qtbot, tab):
    assert tab.parameters().assist == "as-needed"  # the window's default
    names = [tab.assist.itemText(i) for i in range(tab.assist.count())]
    assert any("As needed" in n for n in names)
    assert any("Thesis" in n for n in names)
    tab.assist.setCurrentIndex(tab.assist.findData("thesis"))
    tab.refresh()
    assert tab.parameters().assist == "thesis"
    tab.set_parameters(THESIS_SUBJECT.replace(assist="as-needed", assistance_level=0.5))
    assert tab.assist.currentData() == "as-needed"
    assert tab.assistance.value() == 50
    with qtbot.waitSignal(tab.assistance_changed, timeout=500) as signal:
        tab.assistance.setValue(30)
    assert signal.args == [pytest.approx(0.3)]


def test_the_transparent_mode_greys_the_level_and_says_it_has_none(qtbot, tab):
    """The transparent mode has no level (core.control.transparent): the field is greyed,
    its label says so, it shows 0 %, the level the trial the form builds runs at (it
    showed a greyed "60 %" beside "No help in this mode"), a level set there (a proposal,
    a plan's block) is kept, not shown nor sent to a running trial; another mode gives the
    field back with the level it held."""
    tab.set_parameters(THESIS_SUBJECT.replace(assist="as-needed", assistance_level=0.6))
    assert tab.assistance.isEnabled()
    tab.assist.setCurrentIndex(tab.assist.findData("transparent"))
    tab.refresh()
    assert not tab.assistance.isEnabled()
    assert (tab.assistance.value(), tab.assistance.text()) == (0, "0 %")
    assert tab._values()["assistance_level"] == 0.0
    sent: list[float] = []
    tab.assistance_changed.connect(sent.append)
    tab.assistance.setValue(40)  # as a plan's block or a proposal would, greyed
    tab.refresh()
    assert (tab.assistance.value(), sent) == (0, [])
    tab.assist.setCurrentIndex(tab.assist.findData("as-needed"))
    tab.refresh()
    assert tab.parameters().assistance_level == pytest.approx(0.4)
    tab.assistance.setValue(60)
    assert sent == [pytest.approx(0.6)]  # the mode's level is sent again
    tab.assist.setCurrentIndex(tab.assist.findData("transparent"))
    tab.refresh()
    assert tab.labels["assistance"].text() == "No help in this mode"
    assert "no help" in tab.assistance.toolTip().lower()
    built = tab.parameters()
    assert (built.assist, built.assistance_level) == ("transparent", 0.0)
    tab.assist.setCurrentIndex(tab.assist.findData("as-needed"))
    tab.refresh()
    assert tab.assistance.isEnabled()
    assert tab.parameters().assistance_level == pytest.approx(0.6)


def test_a_researcher_sets_a_gain_and_a_bad_one_is_refused_under_the_field(qtbot, tab):
    with qtbot.waitSignal(tab.parameters_changed, timeout=2000) as signal:
        type_into(qtbot, tab.gains, "smc.lambda_1_s=500")
    parameters, problem = signal.args
    assert parameters is None
    assert "smc.lambda_1_s" in problem
    assert tab.errors["gains"].isVisible()
    assert "100" in tab.errors["gains"].text()
    with qtbot.waitSignal(tab.parameters_changed, timeout=2000) as signal:
        type_into(qtbot, tab.gains, "guidance.delay_s = 0.5 ; smc.lambda_1_s=25")
    parameters, problem = signal.args
    assert problem == ""
    assert parameters.gains == "guidance.delay_s=0.5; smc.lambda_1_s=25,25"
    assert not tab.errors["gains"].isVisible()


def test_the_proposal_for_the_next_trial_is_shown_and_taken_with_one_click(qtbot, tab):
    from app.trials.progression import propose

    current = tab.parameters()
    proposal = propose(current, {"led_pct": 88.0}, "complete")  # the as-needed default
    tab.show_proposal(proposal)
    assert tab._proposal_group.isVisible()
    assert "88 %" in tab.proposal_text.text()
    qtbot.mouseClick(tab.use_proposal, Qt.MouseButton.LeftButton)
    assert tab.parameters().assistance_level == pytest.approx(0.9)
    assert tab.assistance.value() == 90
    assert not tab.use_proposal.isVisible()
    tab.show_proposal(None)
    assert not tab._proposal_group.isVisible()


@pytest.mark.parametrize("duration_s", [4.5, 1.56, 7.3, 2.2])
def test_a_pace_proposal_taken_runs_as_proposed(qtbot, tab, duration_s):
    """A proposal of 4.05 s per traversal, taken, put 4.0 s in the form (it kept tenths):
    the trial ran 4.0 s and the registry recorded the proposal as changed, not taken."""
    from app.records.registry.proposals import _decision
    from app.trials.progression import propose

    tab.set_parameters(tab.parameters().replace(duration_s=duration_s, assistance_level=0.0))
    before = tab.parameters()
    proposal = propose(before, {"led_pct": 95.0}, "complete")
    assert proposal.change == "speed"
    tab.show_proposal(proposal)
    qtbot.mouseClick(tab.use_proposal, Qt.MouseButton.LeftButton)
    assert tab.parameters().duration_s == proposal.duration_s
    assert _decision(proposal.to_dict(), before, tab.parameters()) == "accepted"


def test_the_proposal_waits_while_the_form_holds_an_assessment_task(qtbot, tab):
    """Taken while the form held the battery's circle, the proposal changed the pace its
    protocol fixes: the trial became an exercise, said nowhere but in the form (brief hI)."""
    from app.trials.progression import propose
    from core.assessment.protocol import protocol

    proposal = propose(tab.parameters(), {"led_pct": 88.0}, "complete")
    tab.show_proposal(proposal)
    tab.set_parameters(protocol("circle").parameters(tab.parameters()))
    tab.refresh()
    assert tab.parameters().assessment == "circle"
    assert not tab.use_proposal.isEnabled()
    assert "assessment task" in tab.use_proposal.toolTip()
    tab.set_parameters(tab.parameters().replace(assessment=""))  # an exercise again
    tab.refresh()
    assert tab.use_proposal.isEnabled()
    assert tab.use_proposal.toolTip() == ""


def _wheel(widget, steps: int) -> None:
    from PySide6.QtCore import QPoint, QPointF
    from PySide6.QtGui import QWheelEvent
    from PySide6.QtWidgets import QApplication

    centre = QPointF(widget.width() / 2, widget.height() / 2)
    event = QWheelEvent(centre, widget.mapToGlobal(centre), QPoint(0, 0),
                        QPoint(0, 120 * steps), Qt.MouseButton.NoButton,
                        Qt.KeyboardModifier.NoModifier, Qt.ScrollPhase.NoScrollPhase, False)
    QApplication.sendEvent(widget, event)


def test_scrolling_the_form_never_changes_a_field_under_the_pointer(qtbot, tab):
    """Repetitions 5 → 1 unnoticed while a therapist scrolled the form."""
    tab.repetitions.setValue(5)
    tab.radius.setValue(10.0)
    tab.shape.setFocus()  # the focus is elsewhere
    for field in (tab.repetitions, tab.radius, tab.timing):
        before = field.value() if hasattr(field, "value") else field.currentIndex()
        _wheel(field, -3)
        after = field.value() if hasattr(field, "value") else field.currentIndex()
        assert after == before, field
    tab.repetitions.setFocus()  # clicked into: now the wheel is meant for it
    qtbot.waitUntil(tab.repetitions.hasFocus, timeout=1000)
    _wheel(tab.repetitions, -1)
    assert tab.repetitions.value() == 4


def test_the_centre_field_says_what_it_places_for_each_shape(qtbot, tab):
    """As the thesis's form does: for the D, the centre of its straight line."""
    for shape, words in (("d", "D's straight line"), ("circle", "of the circle"),
                         ("reach", "Start of the reach"), ("targets", "Home")):
        tab.shape.setCurrentIndex(tab.shape.findData(shape))
        tab.refresh()
        assert words in tab.labels["centre"].text(), shape


def test_a_plan_s_game_round_set_in_the_form_is_built_as_that_game(qtbot, tab):
    """A session plan's game block goes through the form (ui.window.plan: the runner's
    round set here, then Build): the game and its difficulty, for which the form has no
    field, were lost and the round ran as a plain exercise. They are kept while the form
    shows what was set (a tolerance of 0.3 rad shows as 17.2°: kept all the same); a field
    changed by hand makes it a plain exercise again (nothing is played that the form does
    not show)."""
    fields = ("game", "time_allowed_s", "n_distractors", "target_radius_m", "staircase")
    game = THESIS_SUBJECT.replace(
        shape="targets", centre_m=(-0.2, 0.35), radius_m=0.08, n_targets=6, duration_s=9.0,
        repetitions=1, game="reach", time_allowed_s=1.2, n_distractors=2,
        target_radius_m=0.025, tolerance_rad=0.3, assist="as-needed")
    game = game.replace(staircase=start(game, rung=2).to_json())
    tab.set_parameters(game)
    for got in (tab.parameters(), tab.shown()):
        assert [getattr(got, f) for f in fields] == [getattr(game, f) for f in fields]
    assert "reaching game" in tab.status.text()
    type_into(qtbot, tab.repetitions, "2")
    plain = THESIS_SUBJECT
    got = tab.parameters()
    assert got.repetitions == 2
    assert [getattr(got, f) for f in fields] == [getattr(plain, f) for f in fields]
    assert "game" not in tab.status.text()


def test_the_patient_rows_not_stored_are_brought_into_view(qtbot, qapp, tmp_path):
    """On a laptop the Patient rows are below the fold: a therapist read "not stored" and
    saw only the exercise's fields. Once per patient chosen, the form scrolls to them."""
    theme.apply_theme(qapp)
    tab = ParametersTab()
    qtbot.addWidget(tab)
    tab.resize(1366, 500)
    registry = Registry(DataDir(tmp_path / "data"))
    tab.apply_patient(registry.create_patient("Ada", "Plain", body_mass_kg=58.0))
    tab.show()  # chosen on the Registration tab, then the Parameters tab shown
    qtbot.waitExposed(tab)

    def in_view(label) -> bool:
        return not label.visibleRegion().isEmpty()

    qtbot.waitUntil(lambda: in_view(tab.errors["upper_arm"]), timeout=5000)
    bar = tab._form_scroll.verticalScrollBar()
    bar.setValue(0)  # the therapist scrolls back up: left there
    tab.hide()
    tab.show()
    qtbot.waitExposed(tab)
    qapp.processEvents()
    assert bar.value() == 0
