"""Clinic exploration 2 #2: a number a field cannot take is refused in one line that names
the field, says what is wrong and the range to type in, and is never replaced by a number
nobody typed (body mass "500" became 50 kg: Qt dropped the last keystroke without a word).
The Registration and Parameters forms' every numeric field, and the window's message line."""

from __future__ import annotations

import pytest
from PySide6.QtCore import Qt

from app.records.datadir import DataDir
from app.records.registry import Registry
from tests.ui.session import open_window
from tests.ui.shown import shown
from ui import theme
from ui.tabs.parameters import ParametersTab
from ui.tabs.registration import RegistrationTab
from ui.tabs.registration_new import NOT_MEASURED


def type_into(qtbot, field, text: str, key=Qt.Key.Key_Return) -> None:
    field.setFocus()
    field.selectAll()
    qtbot.keyClicks(field, text)
    if key is not None:
        qtbot.keyClick(field, key)


@pytest.fixture
def registration(qtbot, qapp, tmp_path):
    theme.apply_theme(qapp)
    registry = Registry(DataDir(tmp_path / "data"))
    tab = RegistrationTab(registry)
    shown(qtbot, tab, 1280, 900)
    return tab, registry


def test_a_body_mass_over_the_limit_is_refused_in_words_not_cut_to_50_kg(qtbot,
                                                                         registration):
    tab, registry = registration
    type_into(qtbot, tab.body_mass, "70")
    with qtbot.waitSignal(tab.body_mass.refused) as refused:
        type_into(qtbot, tab.body_mass, "500")
    line = refused.args[0]
    assert line == ("Body mass: 500 kg is more than 250 kg, the most it takes; type a "
                    "number from 20 to 250 kg. It stays at 70 kg.")
    assert tab.body_mass.value() == 70.0  # the value before the edit, not 50
    # typed and Register pressed at once: not registered with a number nobody typed
    tab.first_name.setText("Ada")
    type_into(qtbot, tab.body_mass, "500", key=None)
    tab.create_patient()
    assert not tab.waiting()  # refused at the click: nothing asked of the registry
    assert "Not registered. Body mass: 500 kg is more than 250 kg" in tab.create_problem.text()
    assert registry.search_patients("") == []
    type_into(qtbot, tab.body_mass, "72", key=None)
    with qtbot.waitSignal(tab.patient_selected, timeout=60000) as chosen:
        tab.create_patient()
    patient = chosen.args[0]
    assert patient.body_mass_kg == 72.0


def test_an_optional_field_emptied_is_not_measured(qtbot, registration):
    tab, _ = registration
    type_into(qtbot, tab.upper_arm, "31")
    assert tab.upper_arm.value() == 31.0
    type_into(qtbot, tab.upper_arm, "", key=Qt.Key.Key_Backspace)
    qtbot.keyClick(tab.upper_arm, Qt.Key.Key_Return)
    assert tab.upper_arm.text() == NOT_MEASURED
    assert tab.upper_arm.refusal == ""


@pytest.mark.parametrize(("text", "wrong"), [
    ("10", "10 kg is less than 20 kg, the least it takes"),
    ("abc", "“abc” is not a number"),
    ("70.55", "70.55 kg has more than 1 decimal"),
])
def test_each_kind_of_bad_number_says_what_is_wrong(qtbot, registration, text, wrong):
    tab, _ = registration
    with qtbot.waitSignal(tab.body_mass.refused) as refused:
        type_into(qtbot, tab.body_mass, text)
    assert refused.args[0] == (f"Body mass: {wrong}; type a number from 20 to 250 kg. It "
                               f"stays “{NOT_MEASURED}”.")
    assert tab.body_mass.text() == NOT_MEASURED


def test_every_numeric_field_of_both_forms_refuses_in_words(qtbot, qapp, registration):
    tab, _ = registration
    parameters = ParametersTab()
    qtbot.addWidget(parameters)
    fields = [tab.birth_year, tab.body_mass, tab.upper_arm, tab.forearm, tab.shoulder_x,
              tab.shoulder_y, tab.session, tab.trial, *parameters._spin_boxes()]
    parameters.show()
    for field in fields:
        if not field.isEnabled():
            field.setEnabled(True)
        before = field.value()
        too_big = f"{field.maximum() * 10 + 9:.0f}"
        with qtbot.waitSignal(field.refused) as refused:
            type_into(qtbot, field, too_big)
        line = refused.args[0]
        assert line.startswith(f"{field.field_name()}: {too_big}"), line
        assert "This field" not in line
        assert "the most it takes; type a number from" in line
        assert field.value() == before
    # Build and Start take what is typed: a refusal stops them once
    type_into(qtbot, parameters.repetitions, "3.5", key=None)
    assert parameters.commit_edits() == [
        "Repetitions: 3.5 is not a whole number; type a number from 1 to "
        f"{parameters.repetitions.maximum()}. It stays at {parameters.repetitions.value()}."]
    assert parameters.commit_edits() == []


def test_the_window_says_a_refusal_in_its_message_line(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        win.tabs.setCurrentWidget(win.registration_tab)
        type_into(qtbot, win.registration_tab.body_mass, "500")
        assert "Body mass: 500 kg is more than 250 kg" in win.message.text()
        win.tabs.setCurrentWidget(win.parameters_tab)
        type_into(qtbot, win.parameters_tab.duration, "0.1", key=None)
        win.build()
        assert win.message.text().startswith(
            f"{theme.PROBLEM_SIGN} Build refused: Time per traversal: 0.1 s is less than")
        assert win.built is None
    finally:
        win.close()
