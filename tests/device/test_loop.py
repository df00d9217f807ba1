"""The real-time loop in its own process: state machine, trials, fault injection end to end,
crash safety and leaks. These tests run the real loop, recorder and ring at 2 ms."""

import contextlib
import gc
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from app.trials.analysis import analyse
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.loop.backends import SIMULATED_HEARTBEAT_TIMEOUT_S
from device.loop.client import DeviceClient, LoopLost
from device.loop.messages import BackendConfig, FaultRaised, TrialEnded
from device.loop.process import LoopConfig
from device.loop.recorder_watch import RECORDER_SILENT_TICKS
from device.loop.states import State
from device.recording.messages import RecorderNotice
from device.recording.trialfile import SubjectInfo
from device.safety.faults import Fault
from device.sim.faultinjection import EXPECTED_FAULT
from tests.device.settle import disconnected
from tests.patience import HANG_S

PARAMS = THESIS_SUBJECT.replace(repetitions=1)
LONG = THESIS_SUBJECT.replace(repetitions=20)
BRIEF = PARAMS.replace(duration_s=2.0)
"""A trial for claims that do not depend on its length (the suite's time: real-time
trials): the approach, one lap of 2 s (the fastest the D's 0.5 m/s allows) and the hold."""
TINY = PARAMS.replace(shape="circle", radius_m=0.05, duration_s=1.0)
"""The shortest trial there is (1 s, 0.31 m/s), for claims about what trials leave behind."""
SUBJECT = SubjectInfo.from_parameters("PTEST01", PARAMS)

pytestmark = pytest.mark.slow


def is_(kind):
    return lambda event: isinstance(event, kind)


def closed_file(client, timeout=10.0) -> RecorderNotice:
    events = client.wait_for(lambda e: isinstance(e, RecorderNotice) and e.kind == "closed",
                             timeout)
    return events[-1]


@pytest.fixture(scope="module")
def client():
    with DeviceClient() as c:
        yield c


def connect(client, params=PARAMS, backend=None):
    disconnected(client)
    client.estop(False)
    reply = client.build(params, backend or BackendConfig())
    assert reply.ok, reply.message
    reply = client.connect()
    assert reply.ok, reply.message
    client.wait_for_samples(10)  # a few readings, so Start finds one


def test_commands_out_of_order_are_refused_with_a_reason(client):
    if client.state != State.IDLE:
        pytest.skip("needs a fresh loop")
    reply = client.start_trial("/tmp/never.h5", SUBJECT)
    assert not reply.ok
    assert "build and connect first" in reply.message
    assert not client.connect().ok
    assert not client.stop().ok


def test_a_whole_trial_is_recorded_with_its_timing(client, tmp_path):
    """The tick engine runs compiled by default (device.loop.engine)."""
    whole_trial(client, tmp_path)


def test_a_whole_trial_with_every_tick_in_python(tmp_path):
    """The same trial's claims, one lap of 2 s (BRIEF): the ticks' code, not the trial's
    length, is what differs. One virtual patient (seed 1): at 2 s a lap, the fastest the
    D allows, a healthy virtual patient's directional performance spreads from 21 to 60 %
    over draws and its RMSE nears 5 mm (a new draw each run failed the claims now and
    then); seed 1 follows at 57.5 % and 4.4 / 3.9 mm, compiled or not."""
    with DeviceClient(loop_config=LoopConfig(compiled=False)) as python_loop:
        whole_trial(python_loop, tmp_path, BRIEF, BackendConfig(seed=1))


def whole_trial(client, tmp_path, params=PARAMS, backend=None):
    connect(client, params, backend)
    path = tmp_path / "trial.h5"
    assert client.start_trial(str(path), SUBJECT).ok
    events = client.wait_for(is_(TrialEnded), 20)
    faults = [e.message for e in events if isinstance(e, FaultRaised)]
    assert events[-1].status == "complete", faults
    notice = closed_file(client)
    assert notice.status == "complete"
    data = read_trial(path)
    assert data.status == "complete"
    n = data.n_samples
    # the handle held at the start while the torque ramps up, the exercise, the 0.5 s hold
    assert n == 250 + round(params.duration_s / 0.002) + 250
    np.testing.assert_array_equal(data.channels["tick"], np.arange(n))
    assert data.summary["ticks_missing"] == 0
    # every tick's lateness is measured and kept; on the simulator it faults nothing, and
    # the simulated robot moved by exactly one period per tick (bench/loop_jitter.py has
    # the timing figures: a test cannot bet on how promptly this machine wakes the loop)
    lateness = data.channels["lateness"]
    assert np.isfinite(lateness).all()
    assert (lateness >= 0.0).all()
    assert data.summary["timing"] == "simulated"
    assert data.summary["robot_clock_s"] == pytest.approx(data.summary["ticks"] * 0.002,
                                                          abs=1e-9)
    # the simulated robot it ran, as a headless trial's file names it: the window's
    # assessments were scored as robot 'simulator', which no norms hold (brief hI)
    plant = (backend or BackendConfig()).plant
    assert data.summary["plant"] == plant
    assert json.loads(data.summary["plant_parameters"])["kind"] == plant
    from app.norms.controls import robot_kind
    from app.population.norms import ROBOT

    assert robot_kind(data.backend, data.summary) == ROBOT
    kinds = [e["kind"] for e in data.events]
    assert kinds == ["start", "stop"]
    # the robot and the virtual patient followed the D together, as headless
    metrics = analyse(data.channels, data.parameters).metrics
    assert metrics.rmse_x_m < 0.005
    assert metrics.rmse_y_m < 0.005
    assert metrics.directional_performance_pct > 50
    compute = data.channels["compute_time"]
    assert np.isfinite(compute).all()
    assert np.all(compute > 0.0)


def test_stop_ends_the_trial_early_and_saves_it(client, tmp_path):
    connect(client, LONG)
    path = tmp_path / "stopped.h5"
    assert client.start_trial(str(path), SUBJECT).ok
    # 300 of the trial's ticks, however long this machine takes to run them (a bound of
    # 200-1000 samples after a 0.6 s sleep depended on how promptly the loop ran)
    client.wait_for_samples(300)
    assert client.stop().ok
    assert closed_file(client).status == "stopped_early"
    client.wait_state(State.CONNECTED, 5)
    data = read_trial(path)
    assert data.status == "stopped_early"
    assert data.n_samples >= 300
    np.testing.assert_array_equal(data.channels["tick"], np.arange(data.n_samples))


def _open_fds(pid: int | str = "self") -> set[tuple[str, str]]:
    """A process's open file descriptors with what each is (a pipe's, a socket's or a
    shared segment's inode, a file's path): a leak is one that was not there before, so
    an unrelated descriptor closed meanwhile, or its number taken again by another, is not
    counted as none leaked (a count went 35 -> 33 under load when a finished test's
    objects were collected in between)."""
    folder = Path(f"/proc/{pid}/fd")
    found = set()
    for fd in os.listdir(folder):
        with contextlib.suppress(FileNotFoundError):  # the listing's own descriptor
            found.add((fd, os.readlink(folder / fd)))
    return found


def test_a_trial_twice_in_a_row_leaks_nothing(client, tmp_path):
    def shm():
        # this process's segments only: other test runs on the machine make and free theirs
        mine = f"_{os.getpid()}_"
        return {p.name for p in Path("/dev/shm").iterdir() if mine in p.name}

    def fds():
        gc.collect()  # what earlier tests left for the collector is closed now, not later
        return _open_fds()

    # multiprocessing opens its resource tracker's pipe and its shared heap's arena once per
    # process, at first use: the module's client has started (and stays as it is), so that
    # the count below is what trials leave, whichever test ran before this one
    assert client.loop_pid is not None
    before_shm, before_fds = shm(), fds()
    with DeviceClient() as c:
        connect(c, TINY)
        for i in range(2):
            path = tmp_path / f"t{i}.h5"
            assert c.start_trial(str(path), SUBJECT).ok
            notice = closed_file(c, 20)
            assert notice.status == "complete", read_trial(path).events
            c.wait_state(State.CONNECTED, 5)
            assert read_trial(path).status == "complete"
        loop_fds = _open_fds(c.loop_pid)
        path = tmp_path / "t2.h5"
        assert c.start_trial(str(path), SUBJECT).ok
        closed_file(c, 20)
        c.wait_state(State.CONNECTED, 5)
        assert _open_fds(c.loop_pid) - loop_fds == set()
    assert shm() == before_shm
    assert fds() - before_fds == set()


# late and stalls fault only on the wall clock (hardware); on the simulator a slow read is
# recorded and shown but faults nothing (their own tests below and in tests/ui)
@pytest.mark.parametrize("scenario", [s for s in sorted(EXPECTED_FAULT)
                                      if s not in ("late", "stalls")])
def test_backend_faults_zero_the_torque_latch_and_are_recorded(client, tmp_path, scenario):
    # robot time counts from Connect: 2 s leaves a loaded machine time to start the trial
    # before the fault fires (at 1.2 s a slow Start once found it already latched)
    latched(client, tmp_path, BackendConfig(fault_scenario=scenario, fault_at_s=2.0),
            EXPECTED_FAULT[scenario])


def test_a_late_tick_trips_the_watchdog_of_a_robot_on_the_wall_clock(tmp_path):
    """The hardware's 10 ms watchdog, proved by injection: a simulator on the wall-clock
    timing of a real robot, one read 15 ms slow. The loop runs on a clock of its own
    (device.loop.realtime.OwnClock), on which only that injected delay is late, so no
    stall of this machine can trip the watchdog first or hide it."""
    with DeviceClient(loop_config=LoopConfig(clock="own")) as c:
        fault = latched(c, tmp_path, BackendConfig(fault_scenario="late", fault_at_s=2.0,
                                                   timing="real"), Fault.LATE_TICK)
    # the tick after the slow read started its 15 ms less the period late
    assert fault.detail["lateness_s"] == pytest.approx(0.013, abs=1e-9)
    assert fault.detail["limit_s"] == 0.010


def latched(client, tmp_path, backend: BackendConfig, expected: Fault) -> FaultRaised:
    """Start a long trial on `backend`, wait for its injected fault, and check that it is
    `expected`, that the torque is zero from the first record that carries it on, that it
    stays latched and that the trial file records it. Returns the FaultRaised."""
    connect(client, LONG, backend)
    client.live_records()  # start the live view from here
    path = tmp_path / f"{backend.fault_scenario}.h5"
    assert client.start_trial(str(path), SUBJECT).ok
    events = client.wait_for(is_(FaultRaised), 10)
    fault = events[-1]
    assert fault.code == expected, fault.message
    assert closed_file(client).status == "faulted"
    time.sleep(0.1)
    records = client.live_records()
    faulted = np.flatnonzero(records["fault"] != 0)
    assert faulted.size, "the fault never reached the records"
    first = faulted[0]
    # zero torque in the first record that carries the fault, and every one after
    np.testing.assert_array_equal(records["torque_applied"][first:], 0.0)
    assert records["fault"][first - 1] == 0
    # latched
    assert client.state == State.FAULTED
    assert (records["fault"][first:] == fault.code).all()
    # recorded as an event in a file that opens afterwards
    data = read_trial(path)
    assert data.status == "faulted"
    faults = [e for e in data.events if e["kind"] == "fault"]
    assert faults
    assert faults[0]["values"]["code"] == fault.code
    return fault


def test_a_late_tick_on_the_simulator_is_recorded_and_stops_nothing(client, tmp_path):
    """A 15 ms stall in the middle of a simulated trial: the trial completes, the stall is
    in the file's lateness, and the simulated robot was stepped by one period at it."""
    connect(client, PARAMS, BackendConfig(fault_scenario="late", fault_at_s=1.5,
                                          fault_options=(("sleep_s", 0.015),)))
    path = tmp_path / "late.h5"
    assert client.start_trial(str(path), SUBJECT).ok
    events = client.wait_for(is_(TrialEnded), 20)
    assert not [e for e in events if isinstance(e, FaultRaised)]
    assert events[-1].status == "complete"
    closed_file(client)
    data = read_trial(path)
    assert data.status == "complete"
    assert data.summary["ticks_missing"] == 0
    # the tick after the slow read started at least 15 − 2 ms late (float32 in the file)
    assert data.channels["lateness"].max() >= 0.013 - 1e-6
    assert data.summary["timing"] == "simulated"
    assert data.summary["robot_clock_s"] == pytest.approx(data.summary["ticks"] * 0.002,
                                                          abs=1e-9)


def test_estop_zeroes_the_torque_and_latches_until_released_and_cleared(client, tmp_path):
    connect(client, LONG)
    client.live_records()
    path = tmp_path / "estop.h5"
    assert client.start_trial(str(path), SUBJECT).ok
    time.sleep(1.0)
    client.estop(True)
    fault = client.wait_for(is_(FaultRaised), 5)[-1]
    assert fault.code == Fault.ESTOP, fault.message
    closed_file(client)
    records = client.live_records()
    first = np.flatnonzero(records["fault"] != 0)[0]
    np.testing.assert_array_equal(records["torque_applied"][first:], 0.0)
    reply = client.clear_fault()
    assert not reply.ok  # still held
    assert "cannot be cleared" in reply.message
    client.estop(False)
    client.wait_for_samples(2)  # a whole tick has seen the e-stop released
    assert client.clear_fault().ok
    assert client.state == State.CONNECTED
    assert [e["kind"] for e in read_trial(path).events][-2:] == ["fault", "stop"]


def test_lost_heartbeat_stops_the_trial(tmp_path):
    with DeviceClient(auto_heartbeat=False) as c:
        c.heartbeat()
        reply = c.build(LONG)
        assert reply.ok
        assert c.connect().ok
        path = tmp_path / "heartbeat.h5"
        for _ in range(6):
            c.heartbeat()
            c.wait_for_samples(25)
        assert c.start_trial(str(path), SUBJECT).ok
        for _ in range(10):
            time.sleep(0.05)
            silent_from = time.monotonic()  # before the last beat: the loop saw it after
            c.heartbeat()
        fault = c.wait_for(is_(FaultRaised), 15)[-1]
        assert fault.code == Fault.HEARTBEAT_LOST
        limit = fault.detail["limit_s"]
        assert limit == SIMULATED_HEARTBEAT_TIMEOUT_S  # a simulated robot's own limit
        # not before the timeout, however promptly the loop woke
        assert fault.monotonic_s - silent_from > limit
        assert closed_file(c).status == "faulted"
        # and on the first tick after it: the tick before still had its heartbeat in time
        data = read_trial(path)
        first = np.flatnonzero(data.channels["fault"] != 0)[0]
        wall = data.channels["wall_time"]
        age = fault.detail["heartbeat_age_s"]
        assert limit < age <= limit + (wall[first] - wall[first - 1]) + 1e-9


def test_stalled_recorder_stops_the_trial_with_recording_lost(tmp_path):
    """Issue 28 #6: a stopped recorder (SIGSTOP) was noticed only when the 16 s ring
    overflowed (16.2 s, the last 3.55 s lost). Its beat now stops the trial within
    RECORDER_SILENT_TICKS of the loop's ticks (3 s), counted in ticks, so no machine's
    stall makes it early or late; continued, the recorder writes every sample."""
    with DeviceClient() as c:
        connect(c, LONG)
        path = tmp_path / "stalled.h5"
        assert c.start_trial(str(path), SUBJECT).ok
        c.live_records()
        c.wait_for(lambda e: isinstance(e, RecorderNotice) and e.kind == "opened", 10)
        os.kill(c.recorder_pid, signal.SIGSTOP)
        try:
            _wait_stopped(c.recorder_pid)
            stopped_at = c.live_records()["tick"][-1]  # no beat comes after this tick
            fault = c.wait_for(is_(FaultRaised), 10)[-1]
        finally:
            os.kill(c.recorder_pid, signal.SIGCONT)
        assert fault.code == Fault.RECORDING_LOST
        assert fault.detail["cause"] == "recorder stopped responding"
        assert "stopped responding" in fault.message
        notice = closed_file(c)
        assert notice.status == "recording_lost"
    data = read_trial(path)
    assert data.status == "recording_lost"
    faulted = np.flatnonzero(data.channels["fault"] == int(Fault.RECORDING_LOST))
    first_fault = data.channels["tick"][faulted[0]]
    # the last beat was seen at the latest by the tick after stopped_at (when the loop
    # ran no tick between that beat and this test's look at the ring)
    assert stopped_at < first_fault <= stopped_at + 1 + RECORDER_SILENT_TICKS
    ticks = data.channels["tick"]
    np.testing.assert_array_equal(ticks, np.arange(len(ticks)))  # nothing lost
    assert ticks[-1] == first_fault
    assert any(e["kind"] == "fault" for e in data.events)


def _wait_stopped(pid: int, timeout: float = 10.0) -> None:
    """Until the process is stopped (state T), however long the system takes."""
    deadline = time.monotonic() + timeout
    while True:
        with open(f"/proc/{pid}/stat") as f:
            if f.read().rsplit(")", 1)[1].split()[0] in ("T", "t"):
                return
        assert time.monotonic() < deadline, f"process {pid} did not stop"
        time.sleep(0.005)


def test_kill_9_of_the_loop_keeps_the_trial_file(tmp_path):
    with DeviceClient() as c:
        connect(c, LONG)
        path = tmp_path / "killed-loop.h5"
        assert c.start_trial(str(path), SUBJECT).ok
        c.live_records()  # the live view from the trial's start
        c.wait_for_samples(500)  # 1 s of the trial's ticks, however long the machine takes
        seen = c.live_records()["tick"]
        os.kill(c.loop_pid, signal.SIGKILL)
        # however long this machine takes to let the recorder see it: how soon is the
        # bench's figure (bench/fault_injection.py, loop SIGKILL: 0.03-0.13 s), not a test's
        events = c.wait_for(lambda e: isinstance(e, RecorderNotice) and e.kind == "closed", 60)
        events += c.events(0.5)
        assert any(isinstance(e, LoopLost) for e in events)
        data = read_trial(path)
        assert data.status == "faulted"
        # every record the loop pushed before the kill: at least all the live view saw
        assert seen.size > 0
        assert data.channels["tick"][-1] >= seen[-1]
        assert data.summary["ticks_missing"] == 0
        assert any("loop process" in e["message"] for e in data.events)


def test_kill_9_of_the_recorder_stops_the_trial_at_once_with_its_cause(tmp_path):
    """The loop used to go on driving the patient with nothing recorded until the ring
    filled (about 16 s), and then blamed the disk. Issue 28 #6: the file then kept only
    what the recorder had flushed (the last 0.15 s lost) and stayed 'recording'; the
    console now saves the samples still in the ring and closes the file."""
    with DeviceClient() as c:
        connect(c, LONG)
        path = tmp_path / "killed-recorder.h5"
        assert c.start_trial(str(path), SUBJECT).ok
        c.live_records()
        deadline = time.monotonic() + 20
        flushed = 0
        while not flushed:  # until the recorder has created the file and flushed some
            assert time.monotonic() < deadline, "the recorder never flushed"
            time.sleep(0.1)
            flushed = read_trial(path).n_samples if path.exists() else 0
        os.kill(c.recorder_pid, signal.SIGKILL)
        killed_at = c.live_records()["tick"][-1]
        events = c.wait_for(lambda e: isinstance(e, RecorderNotice) and e.kind in (
            "closed", "lost"), 10)
        fault = next(e for e in events if isinstance(e, FaultRaised))
        assert fault.code == Fault.RECORDING_LOST
        assert "recorder stopped" in fault.message
        assert fault.detail["cause"] == "recorder process stopped"
        closed = events[-1]
        assert (closed.kind, closed.status) == ("closed", "recording_lost")
        # counted in the loop's ticks, not in how promptly this machine woke anyone:
        # within 0.5 s (250 ticks) of the last tick seen after the kill
        time.sleep(0.1)
        records = c.live_records()
    data = read_trial(path)
    faulted = np.flatnonzero(data.channels["fault"] == int(Fault.RECORDING_LOST))
    assert faulted.size
    first_fault = data.channels["tick"][faulted[0]]
    assert first_fault - killed_at <= 250
    assert data.channels["torque_applied"][faulted[0]].tolist() == [0.0, 0.0]
    assert data.status == "recording_lost"
    # every tick of the trial up to its stop, none lost: the ring's were saved
    ticks = data.channels["tick"]
    np.testing.assert_array_equal(ticks, np.arange(len(ticks)))
    assert ticks[-1] == first_fault
    assert data.n_samples == closed.samples > flushed
    saved = next(e for e in data.events if e["kind"] == "recording")
    assert saved["values"]["cause"] == "recorder process stopped"
    assert saved["values"]["samples_lost"] == 0
    assert [e["kind"] for e in data.events][-2:] == ["fault", "stop"]
    assert records.size  # the live view goes on after the recorder's death


def test_kill_9_of_loop_and_recorder_leaves_a_readable_file(tmp_path):
    with DeviceClient() as c:
        connect(c, LONG)
        path = tmp_path / "killed-both.h5"
        assert c.start_trial(str(path), SUBJECT).ok
        c.wait_for_samples(1000)
        flushed = _flushed(path)  # what a reader sees of it now
        os.kill(c.recorder_pid, signal.SIGKILL)
        os.kill(c.loop_pid, signal.SIGKILL)
        _wait_gone(c.recorder_pid)
        _wait_gone(c.loop_pid)
        data = read_trial(path)  # before this console, closing, takes over the file
    assert data.status == "recording"  # never closed: the crash is visible
    # every sample flushed before the kills (how much the recorder had not flushed yet
    # depends on when it last woke: bench/fault_injection.py's figure, not a test's)
    assert data.n_samples >= flushed > 0
    np.testing.assert_array_equal(data.channels["tick"], np.arange(data.n_samples))


CONSOLE = textwrap.dedent("""
    import sys, time
    from core.trial import THESIS_SUBJECT
    from device.loop.client import DeviceClient
    from device.recording.trialfile import SubjectInfo

    def main():
        params = THESIS_SUBJECT.replace(repetitions=20)
        c = DeviceClient()
        c.start()
        assert c.build(params).ok
        assert c.connect().ok
        c.wait_for_samples(10)
        assert c.start_trial(sys.argv[1], SubjectInfo.from_parameters("PTEST01", params)).ok
        print(c.loop_pid, c.recorder_pid, flush=True)
        time.sleep(60)

    if __name__ == "__main__":
        main()
""")


def test_kill_9_of_the_console_makes_the_loop_safe_and_close_the_file(tmp_path):
    script = tmp_path / "console.py"
    script.write_text(CONSOLE)
    path = tmp_path / "console-killed.h5"
    proc = subprocess.Popen([sys.executable, str(script), str(path)], stdout=subprocess.PIPE,
                            text=True, cwd=Path(__file__).resolve().parents[2])
    try:
        loop_pid, recorder_pid = (int(v) for v in proc.stdout.readline().split())
        time.sleep(1.0)
        killed_at = time.monotonic()
        proc.kill()
        proc.wait(5)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and (_alive(loop_pid) or _alive(recorder_pid)):
            time.sleep(0.05)
        assert not _alive(loop_pid)
        assert not _alive(recorder_pid)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(5)
        proc.stdout.close()
    data = read_trial(path)
    assert data.status == "faulted"
    fault = next(e for e in data.events if e["kind"] == "fault")
    assert fault["values"]["code"] == Fault.HEARTBEAT_LOST
    # seen through the console's pipe closing, not the heartbeat's timeout (how soon is
    # bench/fault_injection.py's 'console SIGKILL' figure: a bound in seconds here
    # depended on how promptly this machine woke the loop)
    assert fault["values"]["heartbeat"] == "no heartbeat received"
    assert fault["values"]["monotonic_s"] > killed_at
    last = np.flatnonzero(data.channels["fault"] != 0)
    np.testing.assert_array_equal(data.channels["torque_applied"][last], 0.0)


def _flushed(path: Path) -> int:
    """The whole samples a reader sees in the live trial file at `path` (once it exists
    and holds some), however long the recorder takes to make and flush it."""
    deadline = time.monotonic() + 20
    while True:
        assert time.monotonic() < deadline, "the recorder never flushed"
        if path.exists():
            with h5py.File(path, "r", swmr=True, locking=False) as f:
                n = min(d.shape[0] for d in f["timeseries"].values())
            if n:
                return n
        time.sleep(0.05)


def _wait_gone(pid: int, timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while _alive(pid):
        assert time.monotonic() < deadline, f"process {pid} still there"
        time.sleep(0.01)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as f:
        return f.read().split()[2] != "Z"


def test_hardware_without_its_driver_is_refused_at_connect(client):
    disconnected(client)
    settings = Path(__file__).resolve().parents[2] / "resources" / "hardware.example.toml"
    reply = client.build(PARAMS, BackendConfig(kind="quanser", hardware_settings=str(settings)))
    assert reply.ok, reply.message
    reply = client.connect()
    assert not reply.ok
    assert "connect failed" in reply.message
    assert "Quanser" in reply.message or "quanser" in reply.message
    assert client.state == State.BUILT


def test_a_build_with_a_learned_model_it_does_not_name_is_refused(client):
    from core.learning.tick import LearnedInverseDynamics

    named = PARAMS.replace(controller="ctpid", learned_model="fnn-robot",
                           learned_model_sha256="a" * 64)
    disconnected(client)  # and no fault latched: the refusal must be the model's
    client.estop(False)
    reply = client.build(named)
    assert not reply.ok
    assert ("build refused: the trial names the learned model 'fnn-robot' but none was given"
            in reply.message)
    spec = {"kind": "fnn", "dof": 2, "hidden": [2], "position_inputs": [0, 1],
            "input_mean": [0.0] * 6, "input_std": [1.0] * 6, "output_mean": [0.0] * 2,
            "output_std": [1.0] * 2}
    params = {"net.0.W": np.zeros((6, 2)), "net.0.b": np.zeros(2),
              "net.1.W": np.zeros((2, 2)), "net.1.b": np.zeros(2)}
    other = LearnedInverseDynamics(spec, params, "fnn-robot", content_sha256="b" * 64)
    reply = client.build(named, model=other)
    assert not reply.ok
    assert "the learned model given is not 'fnn-robot' with hash aaaaaaaaaaaa" in reply.message
    reply = client.build(PARAMS, model=other)
    assert not reply.ok
    assert "a learned model was given for a trial that names none" in reply.message


def test_the_loop_judges_the_console_s_force_estimate_and_drops_a_stale_one(client, tmp_path):
    """A trial that names a force estimate (EMG in place of the sensor): the console sends
    estimates between ticks without waiting for an answer; the loop's assistance judges
    them (a limp arm, which the sensor reads being dragged along, is judged to push along
    the path), and once they stop coming, judges no push. The test sends every 20 ms and
    stamps each estimate with the newest tick it has seen; the loop keeps one for 0.25 s,
    so a stall of the test process shorter than that changes nothing."""
    params = PARAMS.replace(force_estimate="emg-test")
    connect(client, params, BackendConfig(patient="passive"))
    path = tmp_path / "estimated.h5"
    assert client.start_trial(str(path), SUBJECT).ok
    client.live_records()
    sent_until, seen = None, []
    started = time.monotonic()
    # until the trial's file is closed; the deadline only a hang reaches (tests/patience.py)
    while time.monotonic() - started < HANG_S:
        records = client.live_records()
        if len(records) and records[-1]["tick"] * 0.002 < 2.5:
            # 5 N along the desired direction of the tick the console last saw
            last = records[-1]
            dx, dy = last["direction_desired"]
            client.send_force_estimate(5.0 * dx, 5.0 * dy, int(last["tick"]))
            sent_until = int(last["tick"])
        seen += client.events()
        if any(isinstance(e, RecorderNotice) and e.kind == "closed" for e in seen):
            break
        time.sleep(0.02)
    assert [e.status for e in seen if isinstance(e, TrialEnded)] == ["complete"]
    ch = read_trial(path).channels
    exercise = ch["phase"] == 2
    judged = ch["assistance_active"]
    sending = exercise & (ch["tick"] > 50) & (ch["tick"] <= sent_until)
    assert judged[sending].mean() > 0.9
    # the sensor's force, the limp arm dragged along, would have been judged otherwise
    from core.emg.force import in_cone

    by_sensor = in_cone(ch["force"][sending], ch["direction_desired"][sending],
                        params.tolerance_rad)
    assert by_sensor.mean() < 0.5
    stale = exercise & (ch["tick"] > sent_until + round(0.25 / 0.002))
    assert stale.any()
    assert not judged[stale].any()
