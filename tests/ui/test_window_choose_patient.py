"""Choosing a patient on a station whose registry answers late (a shared registry on a silent
network: docs/stations.md, A silent network): their record is read on the window's job
thread (ui.tabs.registration), so the window goes on handling events and the emergency stop
meanwhile; nobody is confirmed while it loads, so Start waits; and when another patient is
chosen before the answer, the late answer is dropped, never shown for the wrong patient.
Read on the window's thread, the choice held the whole window for the registry's wait."""

from __future__ import annotations

import threading

import pytest
from PySide6.QtCore import QTimer

from app.records.datadir import DataDir
from app.records.registry import Registry
from tests.ui import session
from ui.tabs.registration import LOADING

pytestmark = pytest.mark.slow

WAIT_MS = 60_000
"""A bound for a hang, never a measure of speed."""


def test_a_patient_chosen_late_holds_start_not_the_window(qtbot, tmp_path, monkeypatch):
    registry = Registry(DataDir(tmp_path / "data", "test"))
    win = session.open_window(qtbot, tmp_path, monkeypatch, registry=registry)
    try:
        tab = win.registration_tab
        session.register_patient(qtbot, win)  # Ada, confirmed
        ada = win.patient
        grace = registry.create_patient("Grace", "Hopper", body_mass_kg=70.0,
                                        upper_arm_m=0.30, forearm_m=0.28,
                                        shoulder_m=(-0.12, 0.73))
        session.short_trial(win, duration_s=1.5)
        session.build_and_connect(qtbot, win)
        qtbot.waitUntil(lambda: "start" in session.enabled(win), timeout=WAIT_MS)

        # Grace's record is read only after the window handled an event posted before she
        # was chosen (it can, exactly when the read is not on its thread), then only once
        # the test lets the registry answer.
        handled, release = threading.Event(), threading.Event()
        handled_first: list[bool] = []
        suggest = registry.suggest_registration

        def late(code, *args, **kwargs):
            if code == grace.code:
                handled_first.append(handled.wait(30))
                if threading.current_thread() is not threading.main_thread():
                    release.wait(WAIT_MS / 1000)  # on the window's thread nothing can
            return suggest(code, *args, **kwargs)

        monkeypatch.setattr(registry, "suggest_registration", late)
        shown: list[str] = []
        tab.patient_selected.connect(lambda patient: shown.append(patient.code))
        QTimer.singleShot(0, handled.set)
        tab.choose(grace)
        assert tab.confirm.text() == LOADING
        assert not tab.confirm.isEnabled()
        assert tab.selected_patient() is None
        assert tab.choosing() == grace
        # nobody confirmed while she loads: Start waits, and F5 registers nothing
        assert win.registration is None
        assert "start" not in session.enabled(win)
        win.start_trial()
        assert win.trial_id is None
        assert not win.registering()
        qtbot.waitUntil(lambda: bool(handled_first), timeout=WAIT_MS)
        assert handled_first == [True], "the window handled no event while she loaded"
        # the emergency stop, clicked while the registry has not answered, reaches the loop
        session.click(qtbot, win.robot.estop)
        qtbot.waitUntil(lambda: bool(win.bridge.client.estop_flag.value), timeout=WAIT_MS)
        assert win.banner.isVisible()
        assert tab.waiting()

        # Ada chosen again before Grace's answer: that answer is never shown
        tab.choose(ada)
        release.set()
        qtbot.waitUntil(lambda: not tab.waiting(), timeout=WAIT_MS)
        assert shown == [ada.code]
        assert tab.selected_patient() == ada
        assert win.patient == ada
        assert ada.code in tab.patient_label.text()
        assert tab.confirm.isEnabled()
        with qtbot.waitSignal(tab.registered, timeout=WAIT_MS) as registered:
            session.click(qtbot, tab.confirm)
        assert registered.args[1].patient_code == ada.code
    finally:
        release.set()
        win.closing_by_signal = True
        win.close()
