"""The loop's health line in the status bar, without Qt."""

from __future__ import annotations

import numpy as np

from device.loop.pipeline import PERIOD_S
from device.safety.faults import Fault
from ui.views.loop_health import LoopHealth


def test_nothing_new_leaves_the_line_as_it_is():
    assert LoopHealth().text() is None


def test_p99_of_the_last_batches_and_the_late_share_since_the_start():
    health = LoopHealth()
    on_time = np.full(99, 0.0001)
    health.add(on_time[:50])
    health.add(np.concatenate((on_time[50:], [2.5 * PERIOD_S])))  # one tick 5 ms late
    p99 = 1e3 * np.percentile(np.concatenate((on_time, [2.5 * PERIOD_S])), 99)
    assert health.text() == f"loop: lateness p99 {p99:.2f} ms · late 1.00 %"
    assert health.text() is None  # the batches were used once
    health.add(np.full(100, 0.0001))
    assert health.text() == "loop: lateness p99 0.10 ms · late 0.50 %"
    assert (health.late_total, health.ticks_total) == (1, 200)


def test_a_fault_is_named_after_the_figures():
    health = LoopHealth()
    health.add(np.zeros(10))
    assert health.text(int(Fault.ESTOP)).endswith(f" · fault {Fault.ESTOP.label}")
