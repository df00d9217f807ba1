"""The Registration tab's clinical record (issue 31): a new patient's sex and handedness;
a session's scale, a note, a trial marked invalid and valid again, a correction kept with
its audit, all as a therapist clicks them; a value out of range refused in one line with
nothing stored."""

from __future__ import annotations

import pytest
from PySide6.QtCore import Qt

from app.records.datadir import DataDir
from app.records.registry import Registry
from core.trial import THESIS_SUBJECT
from tests.ui.shown import shown
from tests.ui.test_tabs_registration import (
    ada_chosen_after_a_trial,
    answering_late,
    fill_new_patient,
)
from ui import theme
from ui.tabs.registration import RegistrationTab


@pytest.fixture
def registry(tmp_path):
    return Registry(DataDir(tmp_path / "data"))


@pytest.fixture
def tab(qtbot, qapp, registry):
    theme.apply_theme(qapp)
    return shown(qtbot, RegistrationTab(registry))


def click(qtbot, button):
    qtbot.mouseClick(button, Qt.MouseButton.LeftButton)


def press(qtbot, record, button):
    """`button` clicked, and the registry's answer (on the job thread) shown."""
    click(qtbot, button)
    qtbot.waitUntil(lambda: not record.saving(), timeout=60000)


def type_into(qtbot, field, text):
    field.clear()
    qtbot.keyClicks(field, text)


def test_a_therapist_keeps_the_clinical_record_from_the_window(qtbot, tab, registry):
    fill_new_patient(qtbot, tab, "Ada", "Lovelace")
    tab.sex.setCurrentIndex(tab.sex.findData("female"))
    tab.handedness.setCurrentIndex(tab.handedness.findData("left"))
    with qtbot.waitSignal(tab.patient_selected) as chosen:
        click(qtbot, tab.create_button)
    patient = chosen.args[0]
    assert (patient.sex, patient.handedness) == ("female", "left")
    for _ in range(2):
        begun = registry.begin_trial(patient.code, THESIS_SUBJECT, backend="simulator",
                                     session_number=1)
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.01})
    tab.clinical.set_patient(registry.patient(patient.code), 1)
    record = tab.clinical
    qtbot.waitUntil(lambda: record.trial.count() == 2, timeout=60000)  # read on the job thread
    assert record.isEnabled()
    type_into(qtbot, record.by, "K. Lee")

    record.scale.setCurrentIndex(record.scale.findData("fugl_meyer"))
    type_into(qtbot, record.scores, "A=20 B=5 C=6 D=3")
    press(qtbot, record, record.record_scale_button)
    assert "Fugl-Meyer UE motor 34 kept for session 1" in record.outcome.text()
    type_into(qtbot, record.scores, "A=40 B=5 C=6 D=3")
    press(qtbot, record, record.record_scale_button)
    assert "A = 40 is out of range; give a whole number 0-36" in record.outcome.text()
    assert len(registry.scale_entries(patient.code)) == 1

    type_into(qtbot, record.note, "tired after the first trial")
    press(qtbot, record, record.note_button)
    assert registry.notes(patient.code)[0].text == "tired after the first trial"
    record.trial.setCurrentIndex(0)
    record.note_on_trial.setChecked(True)
    type_into(qtbot, record.note, "coughed at 12 s")
    press(qtbot, record, record.note_button)
    first = registry.trials(patient.code, 1)[0].id
    assert [(n.text, n.trial_id) for n in registry.notes(patient.code)] == [
        ("tired after the first trial", None), ("coughed at 12 s", first)]
    assert "Note kept for trial 1 of session 1" in record.outcome.text()
    record.note_on_trial.setChecked(False)

    assert record.trial.count() == 2
    record.trial.setCurrentIndex(1)
    type_into(qtbot, record.mark_reason, "let go of the handle")
    press(qtbot, record, record.invalid_button)
    second = registry.trials(patient.code, 1)[1].id
    assert set(registry.invalid_trials(patient.code)) == {second}
    assert record.trial.itemText(1) == "2 (invalid)"
    record.trial.setCurrentIndex(1)
    type_into(qtbot, record.mark_reason, "fine on replay")
    press(qtbot, record, record.valid_button)
    assert registry.invalid_trials(patient.code) == {}

    # the Correct row in the Registration tab's names and units (it listed upper_arm_m
    # and took metres where the tab shows cm); the audit keeps SI
    fields = [record.field.itemText(i) for i in range(record.field.count())]
    assert "Upper arm (cm)" in fields
    assert "Shoulder (cm)" in fields
    assert "Year of birth" in fields
    assert not [text for text in fields if "_" in text]
    record.field.setCurrentIndex(record.field.findData("upper_arm_m"))
    assert record.value.placeholderText() == "in cm"
    assert fields.index("Upper arm (cm)") < fields.index("Forearm (cm)")  # as the form
    type_into(qtbot, record.value, "0.30")  # metres, as it used to take
    type_into(qtbot, record.correct_reason, "measured again")
    press(qtbot, record, record.correct_button)
    assert "Upper arm 0.3 cm is out of range: give 15 to 50 cm" in record.outcome.text()
    assert registry.corrections(patient.code) == []
    type_into(qtbot, record.value, "30")
    with qtbot.waitSignal(tab.patient_selected) as corrected:
        press(qtbot, record, record.correct_button)
    assert corrected.args[0].upper_arm_m == pytest.approx(0.30)
    assert "upper arm 30.0 cm" in tab.measurements_label.text()
    assert record.outcome.text() == ("Upper arm corrected: 31.0 cm → 30.0 cm (kept with why, "
                                     "who and when).")
    (audit,) = registry.corrections(patient.code)
    assert (audit.field, audit.old_value, audit.new_value, audit.corrected_by) == (
        "upper_arm_m", 0.31, 0.3, "K. Lee")
    record.field.setCurrentIndex(record.field.findData("shoulder_m"))
    type_into(qtbot, record.value, "-10, 70")
    type_into(qtbot, record.correct_reason, "chair moved")
    press(qtbot, record, record.correct_button)
    assert registry.patient(patient.code).shoulder_m == pytest.approx((-0.10, 0.70))
    assert record.outcome.text() == ("Shoulder corrected: (-12.0, 73.0) cm → (-10.0, 70.0) cm "
                                     "(kept with why, who and when).")

    type_into(qtbot, record.by, "")
    type_into(qtbot, record.note, "no author")
    press(qtbot, record, record.note_button)
    assert "author: give the name" in record.outcome.text()
    assert len(registry.notes(patient.code)) == 2


def test_a_scale_before_the_first_trial_opens_the_session_and_is_said_on_the_message_line(
        qtbot, tab, registry):
    """The Fugl-Meyer at the start of a session, before the robot's first trial: it was
    refused ("a session begins with its first trial") below the fold of the tab, and the
    window's message line said nothing. Now it opens the session the next trial goes on
    in; a refusal (a typo in the session) is said on the message line too (`said`)."""
    fill_new_patient(qtbot, tab, "Ada", "Lovelace")
    with qtbot.waitSignal(tab.patient_selected) as chosen:
        click(qtbot, tab.create_button)
    code = chosen.args[0].code
    record = tab.clinical
    qtbot.waitUntil(lambda: record.isEnabled(), timeout=60000)
    assert (tab.session.value(), record.session.value()) == (1, 1)
    assert tab.session_note.text() == "a new session"
    type_into(qtbot, record.by, "K. Lee")
    record.scale.setCurrentIndex(record.scale.findData("fugl_meyer"))
    type_into(qtbot, record.scores, "30")
    said = []
    tab.said.connect(lambda text, problem: said.append((text, problem)))
    press(qtbot, record, record.record_scale_button)
    assert said == [("Clinical record: Fugl-Meyer UE motor 30 kept for session 1.", False)]
    assert [s.number for s in registry.sessions(code)] == [1]
    # the Registration's line: the session goes on (read on the job thread)
    qtbot.waitUntil(lambda: tab.session_note.text().startswith("continues the session of"),
                    timeout=60000)
    assert tab.session_note.text().endswith("(0 trials so far)")
    begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                                 session_number=tab.session.value())
    assert (begun.session_number, begun.trial_number) == (1, 1)

    record.session.setValue(9)
    type_into(qtbot, record.scores, "31")
    press(qtbot, record, record.record_scale_button)
    refusal = (f"patient {code} has no session 9; give one of their sessions (1) or 2, "
               "which opens the next")
    assert said[-1] == (f"Clinical record: {refusal}", True)
    assert record.outcome.text() == f"{theme.PROBLEM_SIGN} {refusal}"
    assert len(registry.scale_entries(code)) == 1


def test_the_trials_run_since_the_patient_was_chosen_can_be_marked(qtbot, tab, registry):
    """Found trying the window: the record's trial list was filled when the patient was
    chosen, so the three trials run after it could not be marked ("session 1 has no
    finished trial to mark"); and marking trial 3 said "Trial 1 marked invalid" (the
    list, refilled, chose its first)."""
    fill_new_patient(qtbot, tab, "Ada", "Lovelace")
    with qtbot.waitSignal(tab.patient_selected) as chosen:
        click(qtbot, tab.create_button)
    code = chosen.args[0].code
    click(qtbot, tab.confirm)
    record = tab.clinical
    assert record.trial.count() == 0
    for _ in range(3):
        begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                                     session_number=1)
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.01})
        tab.refresh_numbers()  # what the window does once a trial is finished
    assert [record.trial.itemText(i) for i in range(record.trial.count())] == ["1", "2", "3"]

    type_into(qtbot, record.by, "K. Lee")
    record.trial.setCurrentIndex(2)
    type_into(qtbot, record.mark_reason, "coughed")
    press(qtbot, record, record.invalid_button)
    third = registry.trials(code, 1)[2].id
    assert third in registry.invalid_trials(code)
    assert record.outcome.text() == "Trial 3 marked invalid: coughed."
    assert record.trial.currentText() == "3 (invalid)"
    type_into(qtbot, record.mark_reason, "it was fine")
    press(qtbot, record, record.valid_button)
    assert record.outcome.text() == "Trial 3 marked valid again: it was fine."


def test_the_record_is_kept_off_the_windows_thread_and_says_only_what_was_kept(
        qtbot, tab, registry, monkeypatch):
    """Each action of the record (and the reads that refresh it) asked the registry on the
    window's thread: on a silent network up to its bounded wait each, the window frozen.
    On the job thread the button says "Saving…" and nothing is said kept before the
    registry says so; a write that fails says so in one line; an answer that comes after
    another patient was chosen is not shown under her."""
    from ui.tabs.clinical_record import SAVING

    ada, grace = ada_chosen_after_a_trial(qtbot, tab, registry)
    record = tab.clinical
    assert record.trial.count() == 1
    on_window_thread, release = answering_late(monkeypatch, registry, (
        "add_note", "record_scale", "mark_trial", "correct_patient", "corrections", "trials",
        "invalid_trials", "sessions", "suggest_registration"))
    type_into(qtbot, record.by, "K. Lee")
    type_into(qtbot, record.note, "tired")
    click(qtbot, record.note_button)
    assert record.note_button.text() == SAVING
    assert not record.invalid_button.isEnabled()
    assert record.outcome.text() == ""  # nothing said kept before the registry says so
    release.set()
    qtbot.waitUntil(lambda: not record.saving(), timeout=60000)
    assert record.outcome.text() == "Note kept for session 1."
    assert record.note.text() == ""

    type_into(qtbot, record.mark_reason, "coughed")
    press(qtbot, record, record.invalid_button)
    assert record.outcome.text() == "Trial 1 marked invalid: coughed."
    assert record.trial.currentText() == "1 (invalid)"

    def lost(*_args, **_kwargs):
        raise ConnectionError("the server closed the connection")

    monkeypatch.setattr(registry, "record_scale", lost)
    type_into(qtbot, record.scores, "30")
    press(qtbot, record, record.record_scale_button)
    assert record.outcome.text() == (f"{theme.PROBLEM_SIGN} Not kept: the server closed the "
                                     "connection")
    assert record.scores.text() == "30"  # still there to record again

    release.clear()
    type_into(qtbot, record.note, "second")
    click(qtbot, record.note_button)
    with qtbot.waitSignal(tab.patient_selected, timeout=60000) as chosen:
        tab.choose(grace)
        release.set()
    assert chosen.args[0].code == grace.code
    assert "kept" not in record.outcome.text()  # it was Ada's note, not Grace's
    assert [n.text for n in registry.notes(ada.code)] == ["tired", "second"]
    assert registry.notes(grace.code) == []
    assert on_window_thread == []


def test_the_windows_message_line_says_what_the_record_kept_or_refused(qtbot, tmp_path,
                                                                        monkeypatch):
    """The window's message line (above the tabs, always in view) said nothing of a scale
    kept or refused: the outcome line is below the fold of the Registration tab."""
    from tests.ui.session import open_window

    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        tab, record = win.registration_tab, win.registration_tab.clinical
        patient = win.registry.create_patient("Ada", "Lovelace")
        win.tabs.setCurrentWidget(tab)
        tab.choose(patient)
        qtbot.waitUntil(lambda: record.isEnabled(), timeout=60000)
        type_into(qtbot, record.by, "K. Lee")
        record.scale.setCurrentIndex(record.scale.findData("pain"))
        type_into(qtbot, record.scores, "3")
        press(qtbot, record, record.record_scale_button)
        assert win.message.text() == "Clinical record: Pain (NRS) 3 kept for session 1."
        record.session.setValue(5)
        type_into(qtbot, record.scores, "4")
        press(qtbot, record, record.record_scale_button)
        assert win.message.text() == (
            f"{theme.PROBLEM_SIGN} Clinical record: patient {patient.code} has no session 5; "
            "give one of their sessions (1) or 2, which opens the next")
    finally:
        win.closing_by_signal = True
        win.close()
