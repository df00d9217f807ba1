"""Whose clock the robot lives on: the simulator is stepped by the nominal period and its
lateness faults nothing; a real robot gets the wall clock, its watchdog, and a timing
check of this machine before it is connected. No test here waits on the machine's clock."""

from types import SimpleNamespace

import pytest

from core.trial import THESIS_SUBJECT
from device.backend import REAL_TIME, SIMULATED
from device.errors import BackendError
from device.loop import commands as loop_commands
from device.loop.backends import make_backend
from device.loop.messages import BackendConfig, Build, Connect, Notice, Reply
from device.loop.pipeline import TrialPlan
from device.loop.process import LoopConfig
from device.loop.realtime import measure_wakeups, timing_warning
from device.loop.states import State
from device.safety.limits import SafetyLimits
from device.sim.faultinjection import FaultInjectingBackend
from device.sim.simulator import SimulatorBackend
from tests.device.bare_loop import bare_loop

PARAMS = THESIS_SUBJECT.replace(repetitions=1)
LIMITS = SafetyLimits()


class FakeClock:
    """perf_counter and sleep for measure_wakeups: each sleep oversleeps by the next of
    `late_s` (then by nothing)."""

    def __init__(self, late_s):
        self.t = 100.0
        self.late = list(late_s)

    def now(self):
        return self.t

    def sleep(self, seconds):
        self.t += seconds + (self.late.pop(0) if self.late else 0.0)


def test_wakeups_are_measured_against_the_sleep_asked_for():
    clock = FakeClock([0.0, 0.0004, 0.0184, 0.0])
    late = measure_wakeups(0.03, sleep_s=0.0015, clock=clock.now, sleep=clock.sleep)
    assert late[:4] == pytest.approx([0.0, 0.0004, 0.0184, 0.0], abs=1e-12)
    assert all(v == pytest.approx(0.0, abs=1e-12) for v in late[4:])
    # the measurement ends once its time is used up, stall included
    assert 0.03 <= clock.t - 100.0 < 0.03 + 0.0015 + 1e-9
    assert len(late) == 8  # 1.5 + 1.9 + 19.9 ms, then five more of 1.5 ms


def test_a_machine_that_wakes_on_time_gets_no_warning():
    assert timing_warning([0.0001] * 600 + [0.0019], 0.010, 10, 0.002) == ""
    assert timing_warning([], 0.010, 10, 0.002) == ""


def test_a_stall_past_the_watchdog_is_told_in_plain_words():
    warning = timing_warning([0.0001] * 300 + [0.0184], LIMITS.late_tick_s,
                             LIMITS.late_run_ticks, LIMITS.period_s)
    assert "18.4 ms late" in warning
    assert "stops itself at 10 ms" in warning
    assert "Close other programs" in warning
    assert "docs/hardware.md" in warning


def test_a_run_of_late_wakeups_is_told_too():
    late = [0.0001] * 50 + [0.003] * 10 + [0.0001] * 50
    warning = timing_warning(late, 0.010, 10, 0.002)
    assert "10 times in a row" in warning
    assert timing_warning([0.0001] * 50 + [0.003] * 9 + [0.0001], 0.010, 10, 0.002) == ""


def test_the_simulator_is_simulated_unless_asked_for_the_wall_clock():
    plan = TrialPlan.build(PARAMS)
    assert make_backend(BackendConfig(), PARAMS, plan).timing == SIMULATED
    real = make_backend(BackendConfig(timing="real"), PARAMS, plan)
    assert real.timing == REAL_TIME
    assert "wall clock" in BackendConfig(timing="real").label
    wrapped = make_backend(BackendConfig(fault_scenario="late"), PARAMS, plan)
    assert isinstance(wrapped, FaultInjectingBackend)
    assert wrapped.timing == SIMULATED  # the wrapper runs on its robot's clock
    with pytest.raises(BackendError, match="unknown timing 'fast'"):
        make_backend(BackendConfig(timing="fast"), PARAMS, plan)
    with pytest.raises(BackendError, match="only for the simulator"):
        make_backend(BackendConfig(kind="quanser", timing="simulated"), PARAMS, plan)


def test_the_simulator_refuses_an_unknown_timing():
    with pytest.raises(ValueError, match="timing"):
        SimulatorBackend.from_trial(PARAMS, timing="wall")


@pytest.fixture
def in_process_loop(monkeypatch):
    """A DeviceLoop driven command by command in this process (no ticks run), with the
    wake-up measurement replaced: its calls are counted, its result is the test's."""
    calls = []
    result = {"late": [0.0001] * 500}

    def measured(seconds):
        calls.append(seconds)
        return result["late"]

    monkeypatch.setattr(loop_commands, "measure_wakeups", measured)
    with bare_loop(64) as (loop, console):
        yield SimpleNamespace(loop=loop, console=console, calls=calls, result=result)


def _events(console):
    out = []
    while console.poll():
        out.append(console.recv())
    return out


def _connect(rig, backend):
    rig.loop._command(Build(1, PARAMS, backend))
    rig.loop._command(Connect(2))
    events = _events(rig.console)
    replies = [e for e in events if isinstance(e, Reply)]
    assert all(r.ok for r in replies), replies
    assert rig.loop.state == State.CONNECTED
    return [e for e in events if isinstance(e, Notice)]


def test_connecting_a_real_time_robot_on_a_slow_machine_warns_the_therapist(in_process_loop):
    rig = in_process_loop
    rig.result["late"] = [0.0001] * 400 + [0.0184] + [0.0001] * 99
    notices = _connect(rig, BackendConfig(timing="real"))
    assert rig.calls == [1.0]
    assert len(notices) == 1
    assert notices[0].level == "warning"
    assert "18.4 ms late" in notices[0].message


def test_a_machine_that_keeps_time_connects_without_a_word(in_process_loop):
    rig = in_process_loop
    assert _connect(rig, BackendConfig(timing="real")) == []
    assert rig.calls == [1.0]


def test_the_simulator_connects_without_a_timing_check(in_process_loop):
    rig = in_process_loop
    rig.result["late"] = [0.5]
    assert _connect(rig, BackendConfig()) == []
    assert rig.calls == []


def test_the_heartbeat_limit_is_the_robots_on_hardware_and_longer_on_the_simulator():
    """A window held up for half a second on a busy PC ends no simulated trial; the real
    robot (REAL_TIME timing) keeps the 0.5 s limit."""
    from device.loop.backends import SIMULATED_HEARTBEAT_TIMEOUT_S, limits_for_backend
    from device.safety.limits import SafetyLimits

    class Timed:
        def __init__(self, timing):
            self.timing = timing

    limits = SafetyLimits()
    assert limits_for_backend(limits, Timed("real")).heartbeat_timeout_s == 0.5
    assert limits_for_backend(limits, Timed("simulated")).heartbeat_timeout_s == (
        SIMULATED_HEARTBEAT_TIMEOUT_S)


def test_the_kernels_are_loaded_before_the_robot_starts_its_watchdog(monkeypatch):
    """A real robot's open() starts the card's watchdog (20 ms): from then on only ticks
    may follow. The first load of the compiled kernels took a third of a second after it,
    so the first Connect of every console tripped the watchdog ("The Q8 watchdog
    expired") on the robot standing still at its homing pose."""
    from device.compiled import warmup

    order = []
    monkeypatch.setattr(warmup, "load_kernels", lambda groups: order.append("kernels"))
    made = loop_commands.make_backend

    def recording(*args, **kwargs):
        backend = made(*args, **kwargs)
        opened = backend.open

        class Opened(type(backend)):
            def open(self):
                order.append("open (the watchdog starts)")
                opened()

        backend.__class__ = Opened
        return backend

    monkeypatch.setattr(loop_commands, "make_backend", recording)
    monkeypatch.setattr(loop_commands, "measure_wakeups", lambda seconds: [0.0001])
    with bare_loop(64, LoopConfig(compiled=True, realtime=False)) as (loop, console):
        loop._command(Build(1, PARAMS, BackendConfig(timing="real")))
        loop._command(Connect(2))
        replies = [e for e in _events(console) if isinstance(e, Reply)]
        assert all(r.ok for r in replies), replies
        assert order == ["kernels", "open (the watchdog starts)"]
