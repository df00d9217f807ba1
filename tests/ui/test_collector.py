"""The cyclic collector runs on the window's thread only (ui.collector): a Qt object the
window dropped in a reference cycle is destroyed there, never on the job thread whose
allocations pass the collector's threshold."""

from __future__ import annotations

import gc
import threading

import pytest
from PySide6.QtCore import QObject, Qt

from ui.collector import WindowThreadCollector


@pytest.fixture
def eager_collection():
    """Every allocation due a full pass: what a busy job thread does, at once."""
    before = gc.get_threshold()
    gc.collect()
    gc.set_threshold(1, 1, 1)
    yield
    gc.set_threshold(*before)
    gc.enable()


class Page(QObject):
    """One of the window's own classes (PySide's plain QObject keeps no attribute the
    collector could follow)."""


def _dropped_in_a_cycle(died_on: list) -> None:
    """A window's object only a reference cycle keeps (an attribute that holds its
    owner, as a page's kept callbacks do), dropped. Made with no pass on the way, so
    it is the youngest generation's (a pass while it was made would move it to an older
    one, whose full passes the interpreter puts off); automatic collection is left off."""
    gc.disable()
    dropped = Page()
    dropped.itself = dropped
    dropped.destroyed.connect(lambda *_: died_on.append(threading.current_thread()),
                              Qt.ConnectionType.DirectConnection)
    del dropped


def _allocate_on_a_job_thread(*, automatic: bool) -> None:
    """A job thread's allocations; `automatic`: the interpreter's own collection switched
    on by the job thread as it begins (so its first allocation is the one due a pass)."""
    def busy() -> None:
        if automatic:
            gc.enable()
        for _ in range(2000):
            cycle: list = []
            cycle.append(cycle)

    job = threading.Thread(target=busy, name="console-job-test")
    job.start()
    job.join()


def test_a_dropped_qt_object_dies_on_the_window_s_thread(qapp, qtbot, eager_collection):
    collector = WindowThreadCollector(interval_ms=10)  # the eager thresholds, taken
    collector.start()
    assert not gc.isenabled(), "a thread still collects by itself"
    died_on: list[threading.Thread] = []
    try:
        _dropped_in_a_cycle(died_on)
        _allocate_on_a_job_thread(automatic=False)
        assert died_on == [], f"collected on {died_on[0].name}, not the window's thread"
        qtbot.waitUntil(lambda: bool(died_on), timeout=10_000)  # the timer's pass
    finally:
        collector.stop()
    assert died_on == [threading.main_thread()]
    assert gc.isenabled(), "stopped, the interpreter collects by itself again"


def test_without_it_a_job_thread_destroys_the_window_s_object(qapp, eager_collection):
    """What the collector prevents, shown to happen: the test above means something."""
    died_on: list[threading.Thread] = []
    _dropped_in_a_cycle(died_on)
    _allocate_on_a_job_thread(automatic=True)
    assert [t.name for t in died_on] == ["console-job-test"]


def test_a_pass_takes_only_the_generations_due(qapp):
    collector = WindowThreadCollector()
    died_on: list[threading.Thread] = []
    gc.collect()
    gc.disable()
    try:
        _dropped_in_a_cycle(died_on)  # young garbage: a few allocations since the pass
        assert gc.get_count()[0] > 1
        collector.thresholds = (10**9, 10, 10)  # nothing due
        assert collector.collect() == 0
        assert died_on == []
        collector.thresholds = (1, 10**9, 10**9)  # the youngest generation due
        assert collector.collect() > 0
    finally:
        gc.enable()
    assert died_on == [threading.main_thread()]
