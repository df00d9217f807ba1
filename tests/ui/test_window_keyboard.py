"""The window from the keyboard alone: Enter presses the focused button (Space, which does
elsewhere, is the emergency stop here), as a therapist who tabs through the registration
form expects. Tried from a fresh clone under Xvfb: Enter on "Register new patient" did
nothing before."""

from __future__ import annotations

from PySide6.QtCore import Qt

from tests.ui.session import open_window


def test_enter_on_a_focused_button_presses_it_unless_it_is_greyed(
        qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    tab = win.registration_tab
    win.tabs.setCurrentWidget(tab)
    # nobody chosen: the clinical record is hidden and the New patient form in view
    assert tab.clinical.isHidden()
    assert tab.first_name.isVisible()
    qtbot.keyClicks(tab.first_name, "Ada")
    qtbot.keyClicks(tab.last_name, "Lovelace")
    tab.create_button.setFocus()
    qtbot.waitUntil(tab.create_button.hasFocus)
    qtbot.keyClick(tab.create_button, Qt.Key.Key_Return)
    qtbot.waitUntil(lambda: tab.selected_patient() is not None)
    assert [p.first_name for p in win.registry.patients()] == ["Ada"]
    assert tab.clinical.isVisible()

    tab.confirm.setFocus()
    qtbot.waitUntil(tab.confirm.hasFocus)
    qtbot.keyClick(tab.confirm, Qt.Key.Key_Enter)  # the keypad's Enter too
    qtbot.waitUntil(lambda: win.registration is not None)
    assert win.patient.first_name == "Ada"

    # a greyed button is not pressed by Enter either
    tab.create_button.setEnabled(False)
    tab.create_button.setFocus()
    qtbot.keyClick(tab.create_button, Qt.Key.Key_Return)
    assert len(win.registry.patients()) == 1
