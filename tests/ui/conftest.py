"""The window's tests."""

from __future__ import annotations

import pytest


@pytest.fixture(autouse=True)
def _fake_emg_waited_for(monkeypatch):
    """A window test's fake EMG source (the Trigno stand-in, an LSL sender) is a thread of
    the test's own process: a shared CI machine that stalls the process for over a second
    made the capture end as a stopped source (seen once in a fresh-clone check). No window
    test is about that ending (tests/app/emg/test_emg_live.py is, with its own limit), so
    here a source is taken as stopped after 30 s without a sample."""
    monkeypatch.setattr("device.emg.capture.STALL_S", 30.0)


@pytest.fixture(autouse=True)
def _collected_on_the_window_s_thread(qapp):
    """Each window test runs as the console does (ui.gui): Python's cyclic collector only
    on the window's thread, between events (ui.collector). A collection inside Qt's event
    dispatch freed a widget a test had dropped while Qt still used it: a worker crashed in
    pytest-qt's `processEvents` after a tab's test (seen once in a fresh-clone check). What
    is left is collected once the test's widgets are closed, before the next test."""
    import gc

    from ui.collector import WindowThreadCollector

    collector = WindowThreadCollector()
    collector.start()
    yield
    collector.stop()
    collector.deleteLater()
    gc.collect()
