"""The Assessments tab's figures, and the proposal and Replay list read again after an
offline station's sync, read on the window's job thread (ui.window.assessments,
ui.main_window.read_proposal_and_trials). On a shared registry whose network drops
everything each read held the window for its bounded wait
(app.records.registry.postgres.deadline). Here each registry call answers only once the
test lets it (tests/ui/held.py): a window that waits for it on its own thread never returns
to the test, and the call gives up after 30 s (a bound for a hang, never a measure of
speed). Meanwhile the tab says "Loading…" and works otherwise; an answer for a patient no
longer chosen is never shown; a registry gone is said with its cause; closing does not
wait."""

from __future__ import annotations

import pytest

from core.assessment.protocol import protocol
from core.trial import THESIS_SUBJECT
from tests.app.assessments.registered import register
from tests.ui.held import BOUND_S, Held
from tests.ui.session import open_window, register_patient
from ui.tabs.assessments import LOADING

pytestmark = pytest.mark.slow

WAIT_MS = int(BOUND_S * 1000)
"""A bound for a hang, never a measure of speed."""

REACHING = THESIS_SUBJECT.replace(assist="transparent", shape="targets")


def _read(qtbot, win) -> None:
    qtbot.waitUntil(lambda: not win.assessment_reading(), timeout=WAIT_MS)


def _shown_again(qtbot, win, held: Held) -> None:
    """The tab shown again (its figures read again), the read held."""
    win.tabs.setCurrentWidget(win.parameters_tab)
    win.tabs.setCurrentWidget(win.assessments_tab)
    qtbot.waitUntil(held.asked.is_set, timeout=WAIT_MS)
    assert held.waited == [], "the window waited for the read on its own thread"


def _loading(win) -> None:
    tab = win.assessments_tab
    assert tab.results.toPlainText().startswith(LOADING)
    assert (tab.pdf_button.text(), tab.pdf_button.isEnabled()) == (LOADING, False)
    assert tab.polar.isHidden()
    # the rest of the tab works meanwhile
    assert tab.task.isEnabled()
    assert tab.use_button.isEnabled()


def another_patient(registry):
    """A second patient with every measurement (the tab reads their record as the
    first's)."""
    return registry.create_patient("Grace", "Hopper", body_mass_kg=60.0, upper_arm_m=0.29,
                                   forearm_m=0.27, shoulder_m=(-0.12, 0.73))


def test_the_figures_are_read_off_the_window_and_another_patient_s_never_shown(
        qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        register_patient(qtbot, win)
        registry, tab = win.registry, win.assessments_tab
        first = win.patient.code
        other = another_patient(registry).code
        for code, seconds in ((first, 0.4), (other, 0.6)):
            register(registry, code, {"vgr_reaction_time_s": seconds}, parameters=REACHING)
        win.tabs.setCurrentWidget(tab)
        _read(qtbot, win)
        assert f"Patient {first}, session 1" in tab.results.toPlainText()
        assert tab.pdf_button.isEnabled()
        shown: list[str] = []
        show = tab.show_results
        monkeypatch.setattr(tab, "show_results", lambda lines, *a, **k: (
            shown.append("\n".join(lines)), show(lines, *a, **k)))

        held = Held(monkeypatch, registry, "trials_for_patient", code=first)
        _shown_again(qtbot, win, held)
        _loading(win)
        assert win.save_assessment_pdf("reaching", tmp_path / "a.pdf") is None  # not yet
        # another patient chosen while the first one's figures are read
        win.registration_tab.choose(registry.patient(other))
        held.release()
        qtbot.waitUntil(lambda: f"Patient {other}, session 1" in tab.results.toPlainText(),
                        timeout=WAIT_MS)
        _read(qtbot, win)
        assert held.waited == [True], "the window waited for the figures' read"
        assert not [text for text in shown if f"Patient {first}" in text], \
            "the first patient's figures were shown after another was chosen"
        saved = win.save_assessment_pdf("reaching", tmp_path / "b.pdf")
        assert saved is not None
        assert saved.read_bytes().startswith(b"%PDF")
    finally:
        win.close()


def test_closing_while_the_figures_are_read_does_not_wait(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    register_patient(qtbot, win)
    code = win.patient.code
    register(win.registry, code, {"vgr_reaction_time_s": 0.4}, parameters=REACHING)
    held = Held(monkeypatch, win.registry, "trials_for_patient", code=code)
    _shown_again(qtbot, win, held)
    _loading(win)
    win.close()
    assert held.waited == [], "closing waited for the figures' read"
    held.release()
    win.jobs.shutdown(wait=True)  # the job thread ends after the read
    assert held.waited == [True]


def test_a_registry_gone_is_said_with_its_cause(qtbot, tmp_path, monkeypatch,
                                                server_registries):
    """The department's server unreachable (the network to it cut: tests/netcut.py) as the
    tab reads the figures: the message line says whose figures could not be read and why,
    and the tab says so where they would be."""
    from app.records.datadir import DataDir
    from app.records.registry import Registry
    from tests.netcut import NetworkCut

    url = server_registries.new()
    network = NetworkCut(url.port)
    registry = Registry(DataDir(tmp_path / "data", "test"), server=network.url(url))
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False, registry=registry)
    try:
        register_patient(qtbot, win)
        code, tab = win.patient.code, win.assessments_tab
        win.tabs.setCurrentWidget(tab)
        _read(qtbot, win)
        assert "has no visually guided reaching yet" in tab.results.toPlainText()
        network.cut()
        win.tabs.setCurrentWidget(win.parameters_tab)
        win.tabs.setCurrentWidget(tab)
        _read(qtbot, win)
        said = win.messages.last
        assert said.problem
        assert win.message.text().endswith(said.text)
        assert said.text.startswith(f"{code}'s {protocol('reaching').name} could not be "
                                    "read: cannot reach the registry's server "), said.text
        assert tab.results.toPlainText().startswith("The figures cannot be shown: ")
        assert not tab.pdf_button.isEnabled()
    finally:
        win.close()
        network.cut()


def test_after_a_sync_the_proposal_and_replay_list_are_read_off_the_window(
        qtbot, tmp_path, monkeypatch, server_registries):
    """An offline station's trial sent to the server as the network returns: the patient's
    proposal and Replay list are read again (the trial has the server's id now) on the job
    thread, the list saying "Loading…" and Start waiting meanwhile."""
    from app.records.datadir import DataDir
    from app.records.station import StationRegistry
    from tests.netcut import NetworkCut

    url = server_registries.new()
    network = NetworkCut(url.port)
    station = StationRegistry(DataDir(tmp_path / "data", "test"), network.url(url),
                              station="robot-7")
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False, registry=station)
    try:
        register_patient(qtbot, win)
        code = win.patient.code
        qtbot.waitUntil(lambda: win.reading_after == 0, timeout=WAIT_MS)
        network.cut()
        register(station, code, {"vgr_reaction_time_s": 0.4}, parameters=REACHING)
        assert station.offline
        network.restore()
        held = Held(monkeypatch, station, "pending_proposal", code=code)
        win.check_station()  # the timer's tick, at once: the sync, then the reads
        qtbot.waitUntil(held.asked.is_set, timeout=WAIT_MS)
        assert held.waited == [], "the window read the proposal on its own thread"
        assert not station.offline
        assert win.replay.list_heading.text() == f"Trials of {code}: {LOADING}"
        assert win.replay.trials.count() == 0  # the offline id is no longer the trial's
        assert win.reading_after == 1  # Start waits for it
        held.release()
        qtbot.waitUntil(lambda: win.reading_after == 0, timeout=WAIT_MS)
        assert held.waited == [True], "the window waited for the reads after the sync"
        (trial,) = station.trials_for_patient(code)
        assert win.replay.list_heading.text() == f"Trials of {code}"
        assert [win.replay.trials.item(i).data(0x0100) for i in
                range(win.replay.trials.count())] == [trial.id]
        assert trial.status == "complete"
    finally:
        win.closing_by_signal = True
        win.close()
        network.cut()


def test_another_patient_s_record_failing_meanwhile_is_said_on_the_tab(qtbot, tmp_path,
                                                                      monkeypatch):
    """The first patient's figures answered while another patient's record is being read
    (dropped: "Loading…" for the other), then that record's read failing: the tab said
    "Loading…" for ever. It says the record could not be read and what to do."""
    from app.errors import RegistryUnreachable

    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    try:
        register_patient(qtbot, win)
        registry, tab = win.registry, win.assessments_tab
        first = win.patient.code
        other = another_patient(registry)
        win.tabs.setCurrentWidget(tab)
        _read(qtbot, win)
        held = Held(monkeypatch, registry, "trials_for_patient", code=first)
        _shown_again(qtbot, win, held)
        suggest = registry.suggest_registration

        def unreachable(code, *args, **kwargs):
            if code == other.code:
                raise RegistryUnreachable("cannot reach the registry's server (test)")
            return suggest(code, *args, **kwargs)

        monkeypatch.setattr(registry, "suggest_registration", unreachable)
        win.registration_tab.choose(other)
        held.release()
        qtbot.waitUntil(lambda: not win.registration_tab.waiting(), timeout=WAIT_MS)
        _read(qtbot, win)
        text = tab.results.toPlainText()
        assert not text.startswith(LOADING), text
        assert text == (f"{other.code}'s record could not be read: cannot reach the "
                        "registry's server (test). Choose the patient again on the "
                        "Registration tab."), text
        assert (tab.pdf_button.text(), tab.pdf_button.isEnabled()) == ("Save as PDF…", False)
    finally:
        win.close()
