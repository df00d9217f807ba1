"""Background work gives way to the loop: a lower priority and the CPUs the loop does not
take, for the calling thread and the threads it starts, never for the rest of the
process; what the OS refuses is said in one line."""

from __future__ import annotations

import os
import threading

from device.background import BACKGROUND_NICE, give_way_to_the_loop, loop_cpu
from device.loop.realtime import LAST_CPU


def in_a_thread(work):
    """Run `work` on a new thread and return what it returned."""
    out = {}

    def run():
        out["value"] = work()

    thread = threading.Thread(target=run)
    thread.start()
    thread.join(30)
    return out["value"]


def own_state():
    tid = threading.get_native_id()
    return os.getpriority(os.PRIO_PROCESS, tid), os.sched_getaffinity(0)


def test_the_calling_thread_and_those_it_starts_give_way_and_the_process_does_not():
    before = own_state()

    def work():
        start = own_state()
        problems = give_way_to_the_loop()
        return start, problems, own_state(), in_a_thread(own_state)

    start, problems, after, child = in_a_thread(work)
    assert problems == []
    assert after[0] == min(19, start[0] + BACKGROUND_NICE)
    cpus = start[1]
    expected = cpus - {loop_cpu(cpus)} if len(cpus) > 1 else cpus
    assert after[1] == expected
    assert child == after  # the model's thread pool, started afterwards, inherits both
    assert own_state() == before  # the window's own threads keep theirs


def test_the_loop_s_cpu_is_the_one_background_work_keeps_off():
    assert loop_cpu({0, 1, 2, 3}) == 3
    assert LAST_CPU == -1  # prepare_process resolves it with loop_cpu


def test_what_the_os_refuses_is_said_and_the_rest_is_done(monkeypatch):
    def refused(*_):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr("device.background.os.setpriority", refused)
    problems = in_a_thread(give_way_to_the_loop)
    assert len(problems) == 1
    assert "could not lower the background work's priority" in problems[0]
    assert "competes with the loop" in problems[0]


def test_with_one_cpu_left_to_it_the_work_stays_where_it_may_run(monkeypatch):
    monkeypatch.setattr("device.background.os.sched_getaffinity", lambda _: {0})
    calls = []
    monkeypatch.setattr("device.background.os.sched_setaffinity",
                        lambda *a: calls.append(a))
    assert in_a_thread(give_way_to_the_loop) == []
    assert calls == []
