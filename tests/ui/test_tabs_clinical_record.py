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
from tests.ui.test_tabs_registration import fill_new_patient
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
    assert record.isEnabled()
    type_into(qtbot, record.by, "K. Lee")

    record.scale.setCurrentIndex(record.scale.findData("fugl_meyer"))
    type_into(qtbot, record.scores, "A=20 B=5 C=6 D=3")
    click(qtbot, record.record_scale_button)
    assert "Fugl-Meyer UE motor 34 kept for session 1" in record.outcome.text()
    type_into(qtbot, record.scores, "A=40 B=5 C=6 D=3")
    click(qtbot, record.record_scale_button)
    assert "A = 40 is out of range; give a whole number 0-36" in record.outcome.text()
    assert len(registry.scale_entries(patient.code)) == 1

    type_into(qtbot, record.note, "tired after the first trial")
    click(qtbot, record.note_button)
    assert registry.notes(patient.code)[0].text == "tired after the first trial"
    record.trial.setCurrentIndex(0)
    record.note_on_trial.setChecked(True)
    type_into(qtbot, record.note, "coughed at 12 s")
    click(qtbot, record.note_button)
    first = registry.trials(patient.code, 1)[0].id
    assert [(n.text, n.trial_id) for n in registry.notes(patient.code)] == [
        ("tired after the first trial", None), ("coughed at 12 s", first)]
    assert "Note kept for trial 1 of session 1" in record.outcome.text()
    record.note_on_trial.setChecked(False)

    assert record.trial.count() == 2
    record.trial.setCurrentIndex(1)
    type_into(qtbot, record.mark_reason, "let go of the handle")
    click(qtbot, record.invalid_button)
    second = registry.trials(patient.code, 1)[1].id
    assert set(registry.invalid_trials(patient.code)) == {second}
    assert record.trial.itemText(1) == "2 (invalid)"
    record.trial.setCurrentIndex(1)
    type_into(qtbot, record.mark_reason, "fine on replay")
    click(qtbot, record.valid_button)
    assert registry.invalid_trials(patient.code) == {}

    record.field.setCurrentIndex(record.field.findData("upper_arm_m"))
    type_into(qtbot, record.value, "0.30")
    type_into(qtbot, record.correct_reason, "measured again")
    with qtbot.waitSignal(tab.patient_selected) as corrected:
        click(qtbot, record.correct_button)
    assert corrected.args[0].upper_arm_m == pytest.approx(0.30)
    assert "upper arm 30.0 cm" in tab.measurements_label.text()
    (audit,) = registry.corrections(patient.code)
    assert (audit.old_value, audit.new_value, audit.corrected_by) == (0.31, 0.3, "K. Lee")

    type_into(qtbot, record.by, "")
    type_into(qtbot, record.note, "no author")
    click(qtbot, record.note_button)
    assert "author: give the name" in record.outcome.text()
    assert len(registry.notes(patient.code)) == 2


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
    click(qtbot, record.invalid_button)
    third = registry.trials(code, 1)[2].id
    assert third in registry.invalid_trials(code)
    assert record.outcome.text() == "Trial 3 marked invalid: coughed."
    assert record.trial.currentText() == "3 (invalid)"
    type_into(qtbot, record.mark_reason, "it was fine")
    click(qtbot, record.valid_button)
    assert record.outcome.text() == "Trial 3 marked valid again: it was fine."
