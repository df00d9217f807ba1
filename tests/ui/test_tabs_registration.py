"""The Registration tab: find or register a patient, get the session and trial numbers from
the registry, have a used number refused with the registry's words."""

from __future__ import annotations

import threading

import pytest
from PySide6.QtCore import Qt

from app.errors import DuplicateNumberError
from app.records.datadir import DataDir
from app.records.registry import Registry
from core.trial import THESIS_SUBJECT
from tests.ui.shown import shown
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


def answered(qtbot, tab) -> None:
    """Once the registry answered what the tab asked on the job thread."""
    qtbot.waitUntil(lambda: not tab.waiting(), timeout=60000)


def answering_late(monkeypatch, registry, names) -> tuple[list[str], threading.Event]:
    """The registry's calls `names` answered, off the window's thread, only once the test
    sets the event returned (a silent network); the calls made on the window's thread
    listed (and answered at once: there nothing could set the event)."""
    on_window_thread: list[str] = []
    release = threading.Event()

    def watched(name):
        call = getattr(registry, name)

        def late(*args, **kwargs):
            if threading.current_thread() is threading.main_thread():
                on_window_thread.append(name)
            else:
                release.wait(60)  # a bound for a hang
            return call(*args, **kwargs)
        return late

    for name in names:
        monkeypatch.setattr(registry, name, watched(name))
    return on_window_thread, release


def ada_chosen_after_a_trial(qtbot, tab, registry):
    """Ada (one finished trial in session 1) chosen, and Grace (none) registered."""
    ada = registry.create_patient("Ada", "Lovelace")
    grace = registry.create_patient("Grace", "Hopper")
    begun = registry.begin_trial(ada.code, THESIS_SUBJECT, backend="simulator",
                                 session_number=1)
    registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.01})
    with qtbot.waitSignal(tab.patient_selected, timeout=60000):
        tab.choose(ada)
    return ada, grace


def fill_new_patient(qtbot, tab, first, last):
    qtbot.keyClicks(tab.first_name, first)
    qtbot.keyClicks(tab.last_name, last)
    for spin, text in ((tab.birth_year, "1961"), (tab.body_mass, "82"),
                       (tab.upper_arm, "31"), (tab.forearm, "28"),
                       (tab.shoulder_x, "-12"), (tab.shoulder_y, "73")):
        spin.setFocus()
        spin.selectAll()
        qtbot.keyClicks(spin, text)
        spin.interpretText()


def test_create_patient_numbers_and_duplicate_refused(qtbot, tab, registry):
    fill_new_patient(qtbot, tab, "Ada", "Lovelace")
    with qtbot.waitSignal(tab.patient_selected) as chosen:
        click(qtbot, tab.create_button)
    patient = chosen.args[0]
    assert (patient.first_name, patient.last_name, patient.birth_year) == ("Ada", "Lovelace",
                                                                           1961)
    assert patient.body_mass_kg == 82.0
    assert patient.upper_arm_m == pytest.approx(0.31)
    assert patient.shoulder_m == (-0.12, 0.73)
    assert registry.patient(patient.code) == patient
    assert patient.code in tab.patient_label.text()
    assert (tab.session.value(), tab.trial.value()) == (1, 1)
    assert tab.session_note.text() == "a new session"

    with qtbot.waitSignal(tab.registered) as registered:
        click(qtbot, tab.confirm)
    _, registration = registered.args
    assert (registration.patient_code, registration.session_number,
            registration.trial_number, registration.new_session) == (patient.code, 1, 1, True)

    # A trial runs with those numbers; the next ones come from the registry.
    registry.begin_trial(patient.code, THESIS_SUBJECT, backend="simulator", session_number=1,
                         trial_number=1)
    with qtbot.waitSignal(tab.registered) as registered:
        tab.refresh_numbers()
    assert (tab.session.value(), tab.trial.value()) == (1, 2)
    assert "1 trial so far" in tab.session_note.text()
    # the numbers shown are the ones the next Start uses
    assert registered.args[1].trial_number == 2
    assert tab.registration().trial_number == 2

    # The therapist types the used number: refused, naming the next free one.
    tab.trial.setFocus()
    tab.trial.selectAll()
    qtbot.keyClicks(tab.trial, "1")
    with qtbot.assertNotEmitted(tab.registered):
        click(qtbot, tab.confirm)
        answered(qtbot, tab)
    assert tab.trial_problem.isVisible()
    assert "already has a trial 1" in tab.trial_problem.text()
    assert "use 2" in tab.trial_problem.text()
    assert tab.registration() is None


@pytest.mark.parametrize(("session", "trial", "said"), [
    (2, 1, "has no session yet: session 2 would leave a gap; use 1"),
    (1, 3, "session 1 has no trial yet: trial 3 would leave a gap; use 1"),
])
def test_confirm_refuses_numbers_that_start_would(qtbot, tab, registry, session, trial, said):
    """Numbering is gap-free: Confirm took session 2 of a patient with none, and only
    Start then said "session 2 would leave a gap" (the window's state machine)."""
    patient = registry.create_patient("Ada", "Lovelace")
    with qtbot.waitSignal(tab.patient_selected, timeout=60000):
        tab.choose(patient)
    for box, value in ((tab.session, session), (tab.trial, trial)):
        box.setFocus()
        box.selectAll()
        qtbot.keyClicks(box, str(value))
    with qtbot.assertNotEmitted(tab.registered):
        click(qtbot, tab.confirm)
        answered(qtbot, tab)
    assert tab.registration() is None
    assert said in tab.trial_problem.text()
    assert f"Patient {patient.code}" in tab.trial_problem.text()  # a sentence, as the others
    with pytest.raises(Exception, match="would leave a gap"):  # what Start would meet
        registry.begin_trial(patient.code, THESIS_SUBJECT, backend="simulator",
                             session_number=session, trial_number=trial)


def test_refusal_from_the_registry_is_shown_as_it_says(qtbot, tab, registry):
    code = registry.create_patient("Alan", "Turing").code
    registry.begin_trial(code, THESIS_SUBJECT, backend="simulator", session_number=1,
                         trial_number=1)
    with pytest.raises(DuplicateNumberError) as refused:
        registry.begin_trial(code, THESIS_SUBJECT, backend="simulator", session_number=1,
                             trial_number=1)
    tab.search()  # on the tab's own thread
    qtbot.waitUntil(lambda: tab.results.count() == 1, timeout=60000)
    with qtbot.waitSignal(tab.patient_selected):
        tab.results.setCurrentRow(0)
    tab.show_refusal(refused.value)
    assert tab.trial_problem.isVisible()
    assert str(refused.value) in tab.trial_problem.text()


def test_search_by_name_fragment_or_code(qtbot, tab, registry):
    ada = registry.create_patient("Ada", "Lovelace")
    registry.create_patient("Grace", "Hopper")
    qtbot.keyClicks(tab.search_field, "love")
    qtbot.waitUntil(lambda: tab.results.count() == 1, timeout=2000)
    assert "Lovelace, Ada" in tab.results.item(0).text()
    tab.search_field.clear()
    qtbot.keyClicks(tab.search_field, ada.code)
    qtbot.waitUntil(lambda: tab.results.count() == 1 and ada.code in tab.results.item(0).text(),
                    timeout=2000)
    with qtbot.waitSignal(tab.patient_selected) as chosen:
        tab.results.setCurrentRow(0)
    assert chosen.args[0].code == ada.code


def test_a_namesake_needs_confirmation(qtbot, tab, registry):
    first = registry.create_patient("Ada", "Lovelace", birth_year=1950)
    qtbot.keyClicks(tab.first_name, "ada")
    qtbot.keyClicks(tab.last_name, "LOVELACE")
    click(qtbot, tab.create_button)
    answered(qtbot, tab)
    assert tab.create_problem.isVisible()
    assert first.code in tab.create_problem.text()
    assert len(registry.patients()) == 1
    assert tab.same_name.isVisible()
    tab.same_name.setChecked(True)
    with qtbot.waitSignal(tab.patient_selected):
        click(qtbot, tab.create_button)
    assert len(registry.patients()) == 2
    assert tab.selected_patient().code != first.code


def test_names_are_required_to_register(qtbot, tab, registry):
    click(qtbot, tab.create_button)
    assert "first or last name" in tab.create_problem.text()
    assert registry.patients() == []


def test_picking_a_patient_shows_their_stored_measurements(qtbot, tab, registry):
    """Choosing a patient shows what the registry holds for them (in the form's units), so
    the therapist sees which body values the trial will use."""
    measured = registry.create_patient("Ada", "Lovelace", body_mass_kg=82.0, upper_arm_m=0.31,
                                       forearm_m=0.28, shoulder_m=(-0.12, 0.73))
    bare = registry.create_patient("Alan", "Turing")
    tab.search()
    with qtbot.waitSignal(tab.patient_selected):
        tab.choose(measured)
    text = tab.measurements_label.text()
    for part in ("82.0 kg", "upper arm 31.0 cm", "forearm 28.0 cm", "(-12.0, 73.0) cm"):
        assert part in text, part
    with qtbot.waitSignal(tab.patient_selected):
        tab.choose(bare)
    assert "No measurements stored" in tab.measurements_label.text()


def test_the_registry_is_searched_off_the_windows_thread(qtbot, tab, registry, monkeypatch):
    """A search on a station whose network went silent waited the registry's bounded wait
    (5 s) on the window's thread, the window frozen; it runs on the tab's own thread, and
    the list shows what the newest search found."""
    registry.create_patient("Ada", "Lovelace")
    registry.create_patient("Grace", "Hopper")
    asked = []
    search = registry.search_patients

    def watched(text):
        asked.append(threading.current_thread() is threading.main_thread())
        return search(text)

    monkeypatch.setattr(registry, "search_patients", watched)
    tab.search_field.setText("hop")
    tab.search()
    qtbot.waitUntil(lambda: tab.results.count() == 1, timeout=60000)
    assert "Hopper, Grace" in tab.results.item(0).text()
    assert tab.found.text() == "1 patient found"
    assert asked
    assert not any(asked), "the registry was searched on the window's thread"



def test_confirm_and_a_new_patient_wait_for_the_registry_off_the_windows_thread(
        qtbot, tab, registry, monkeypatch):
    """Register new patient and Confirm asked the registry on the window's thread, each call
    up to the registry's bounded wait on a silent network (docs/stations.md), the window
    frozen. On the job thread the button says it waits; a Confirm whose numbers were
    edited before the registry answered confirms nothing (the numbers shown are the truth)."""
    from ui.tabs.registration import CHECKING, SAVING

    on_window_thread, release = answering_late(monkeypatch, registry, (
        "find_patients", "create_patient", "suggest_registration", "sessions", "trials",
        "next_trial_number", "invalid_trials"))
    fill_new_patient(qtbot, tab, "Ada", "Lovelace")
    click(qtbot, tab.create_button)
    assert tab.create_button.text() == SAVING
    assert not tab.create_button.isEnabled()
    with qtbot.waitSignal(tab.patient_selected, timeout=60000):
        release.set()
    assert (tab.session.value(), tab.trial.value()) == (1, 1)
    release.clear()

    click(qtbot, tab.confirm)
    assert tab.confirm.text() == CHECKING
    assert not tab.confirm.isEnabled()
    tab.trial.setValue(2)  # edited before the registry answered
    with qtbot.assertNotEmitted(tab.registered):
        release.set()
        answered(qtbot, tab)
    assert tab.registration() is None
    assert tab.confirm.isEnabled()
    tab.trial.setValue(1)  # a new session's first trial: the only number Start takes
    with qtbot.waitSignal(tab.registered, timeout=60000) as registered:
        click(qtbot, tab.confirm)
    assert registered.args[1].trial_number == 1
    assert on_window_thread == []


def test_while_a_patient_loads_nothing_of_the_one_before_is_shown(qtbot, tab, registry,
                                                                   monkeypatch):
    """Found on the real window: while Grace's record was read, Ada's session note ("1
    trial so far") and her trials in the clinical record stood under Grace's name."""
    _, grace = ada_chosen_after_a_trial(qtbot, tab, registry)
    assert "1 trial so far" in tab.session_note.text()
    assert tab.clinical.trial.count() == 1
    _, release = answering_late(monkeypatch, registry, ("suggest_registration",))
    tab.choose(grace)
    assert grace.code in tab.patient_label.text()
    assert tab.session_note.text() == ""
    assert tab.clinical.trial.count() == 0
    assert not tab.clinical.isEnabled()
    with qtbot.waitSignal(tab.patient_selected, timeout=60000) as chosen:
        release.set()
    assert chosen.args[0] == grace
    assert tab.session_note.text() == "a new session"
