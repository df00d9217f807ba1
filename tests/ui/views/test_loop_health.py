"""The loop's timing line in the status bar, without Qt: plain words for the therapist
("Timing OK" or a warning with what to do), the figures in the tooltip (issue 27 #14:
the line read "loop: lateness p99 84.75 ms · late 0.44 %")."""

from __future__ import annotations

import numpy as np

from device.loop.pipeline import PERIOD_S
from ui.views.loop_health import HOLD_UPDATES, OK, WARN_ROBOT, WARN_SIMULATOR, LoopHealth


def test_nothing_new_leaves_the_line_as_it_is():
    assert LoopHealth().text() is None


def test_on_time_ticks_read_ok_and_the_figures_stay_in_the_tooltip():
    health = LoopHealth()
    health.add(np.full(250, 0.0001))
    assert health.text() == OK
    assert "ms" not in OK
    assert "%" not in OK
    assert "0.10 ms" in health.figures()
    assert health.text() is None  # the batches were used once


def test_a_late_batch_warns_with_what_to_do_and_the_warning_holds_ten_seconds():
    health = LoopHealth()
    health.add(np.concatenate((np.full(249, 0.0001), [0.0847])))  # one tick 85 ms late
    line = health.text()
    assert line == WARN_SIMULATOR
    assert "close other programs" in line
    assert "lateness" not in line
    health.add(np.concatenate((np.full(249, 0.0001), [0.0847])))
    assert health.text(robot=True) == WARN_ROBOT
    for _ in range(HOLD_UPDATES - 1):
        health.add(np.full(250, 0.0001))
        assert health.text() == WARN_SIMULATOR
    health.add(np.full(250, 0.0001))
    assert health.text() == OK
    assert (health.late_total, health.ticks_total) == (2, 250 * (HOLD_UPDATES + 2))


def test_many_slightly_late_ticks_warn_too():
    health = LoopHealth()
    lateness = np.full(250, 0.0001)
    lateness[:5] = 1.5 * PERIOD_S  # 2 % of the ticks 3 ms late
    health.add(lateness)
    assert health.text() == WARN_SIMULATOR
