"""One truth: a trial never runs with another patient's arm. Ada's trial built and
connected, then Bob chosen and confirmed, who has no measurements stored: the form kept
Ada's body and shoulder values and Start ran Bob's trial with them (its file and the
registry recorded Ada's arm under Bob's code). Now Start waits and Build is refused until
Bob's values are given and kept in his record (with who checked them and why: the trial
ran with values his record never had, and the same refusal came back each time he was
chosen), and the trial built then carries them."""

from __future__ import annotations

import pytest

from tests.ui import session

pytestmark = pytest.mark.slow

WAIT_MS = 60_000
"""A bound for a hang, never a measure of speed."""


def test_a_patient_without_measurements_never_runs_with_the_last_ones(qtbot, tmp_path,
                                                                      monkeypatch):
    win = session.open_window(qtbot, tmp_path, monkeypatch)
    try:
        tab, form = win.registration_tab, win.parameters_tab
        session.register_patient(qtbot, win)  # Ada, her arm stored, confirmed
        session.short_trial(win, duration_s=1.5)
        session.build_and_connect(qtbot, win)
        qtbot.waitUntil(lambda: "start" in session.enabled(win), timeout=WAIT_MS)
        assert win.built.upper_arm_m == pytest.approx(0.30)

        bob = win.registry.create_patient("Bob", "Bare", side="right")
        tab.choose(bob)
        qtbot.waitUntil(lambda: not tab.waiting() and tab.confirm.isEnabled(), timeout=WAIT_MS)
        session.click(qtbot, tab.confirm)
        qtbot.waitUntil(lambda: win.registration is not None
                        and win.patient.code == bob.code, timeout=WAIT_MS)
        # Ada's trial is not Bob's: Start waits, and F5 registers nothing
        assert "start" not in session.enabled(win)
        win.start_trial()
        assert win.trial_id is None
        assert not win.registering()
        win.build()
        assert "not stored" in win.message.text()

        # Bob's values given in the form: Build takes them
        form.body_mass.setValue(82.0)
        form.upper_arm.setValue(33.0)
        form.forearm.setValue(29.0)
        form.shoulder_x.setValue(-14.0)
        form.shoulder_y.setValue(71.0)
        form.refresh()
        # given, but not in his record: Build waits until they are kept there
        win.build()
        assert "not in their record yet" in win.message.text()
        assert "build" not in session.enabled(win)
        qtbot.keyClicks(form.checked_by, "K. Lee")
        session.click(qtbot, form.keep_measurements)
        qtbot.waitUntil(lambda: "build" in session.enabled(win), timeout=WAIT_MS)
        stored = win.registry.patient(bob.code)
        assert (stored.body_mass_kg, stored.upper_arm_m, stored.forearm_m) == (
            pytest.approx(82.0), pytest.approx(0.33), pytest.approx(0.29))
        assert stored.shoulder_m == pytest.approx((-0.14, 0.71))
        audit = win.registry.corrections(bob.code)
        assert {c.field for c in audit} == {"body_mass_kg", "upper_arm_m", "forearm_m",
                                            "shoulder_m"}
        assert all(c.old_value is None and c.corrected_by == "K. Lee"
                   and c.reason.startswith("confirmed on the Parameters tab") for c in audit)
        assert tab.measurements_label.text().startswith("Stored: body mass 82.0 kg")
        assert "Not stored" not in tab.measurements_label.text()
        assert tab.clinical.by.text() == "K. Lee"  # one name for who records
        assert "Kept in" in win.message.text()
        assert not form.keep_measurements.isVisibleTo(form)
        # a note recorded next: the record showed again the row it had, without them
        qtbot.keyClicks(tab.clinical.note, "measured today")
        session.click(qtbot, tab.clinical.note_button)
        qtbot.waitUntil(lambda: "Note kept" in tab.clinical.outcome.text(), timeout=WAIT_MS)
        assert tab.measurements_label.text().startswith("Stored: body mass 82.0 kg")
        assert "build" in session.enabled(win)
        session.click(qtbot, win.robot.buttons["build"])
        qtbot.waitUntil(lambda: win.built is not None
                        and win.built.upper_arm_m == pytest.approx(0.33),
                        timeout=WAIT_MS)
        built = win.built
        assert (built.body_mass_kg, built.forearm_m) == (pytest.approx(82.0),
                                                         pytest.approx(0.29))
        assert built.shoulder_m == pytest.approx((-0.14, 0.71))
    finally:
        win.close()


def test_measurements_the_registry_refuses_to_keep_are_said_and_build_still_waits(
        qtbot, tmp_path, monkeypatch):
    """The registry's refusal (here: it cannot be written) is said on the message line and
    under the Keep button; nothing runs with values the record does not have."""
    from app.errors import RegistryError

    win = session.open_window(qtbot, tmp_path, monkeypatch)
    try:
        tab, form = win.registration_tab, win.parameters_tab
        bob = win.registry.create_patient("Bob", "Bare", side="right")
        tab.choose(bob)
        qtbot.waitUntil(lambda: not tab.waiting() and tab.confirm.isEnabled(), timeout=WAIT_MS)

        def refused(*_args, **_kwargs):
            raise RegistryError("the registry cannot be written just now")

        monkeypatch.setattr(win.registry, "correct_patient", refused)
        form.checked_by.setText("K. Lee")
        form.keep_measurements.click()
        qtbot.waitUntil(lambda: form.keep_measurements.isEnabled(), timeout=WAIT_MS)
        assert f"{bob.code}'s measurements were not kept" in win.message.text()
        assert "Not kept: the registry cannot be written just now" in form.status.text()
        assert "build" not in session.enabled(win)
        assert win.registry.patient(bob.code).body_mass_kg is None
    finally:
        win.close()
