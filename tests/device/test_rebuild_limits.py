"""A Build between trials with the real robot connected gives the supervisor that trial's
limits. It kept the first Build's: the hardware stays connected on a Build (only the
simulator is reopened), so a force limit the therapist lowered for a fragile arm went
unheard (50 N still latched, not 20 N) and the exercise area stayed the first exercise's.
Found on the stand-in boards (tests/device/fakes) with resources/hardware.example.toml."""

import shutil
import sys
from pathlib import Path

import pytest

from core.trial import THESIS_SUBJECT
from device.loop.commands import AREA_CHECK_TICKS
from device.loop.messages import BackendConfig, Build, Connect, Reply
from device.loop.process import LoopConfig
from device.loop.states import State
from device.safety.limits import SafetyLimits
from tests.device.bare_loop import bare_loop

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
HOMING = (2.0943951, 0.5235988)  # resources/hardware.example.toml: 120°, 30°


def _purge(package):
    for name in [n for n in sys.modules if n == package or n.startswith(package + ".")]:
        del sys.modules[name]


@pytest.fixture
def connected(monkeypatch, tmp_path):
    """A loop connected to the stand-in Q8 and NI card with the example settings."""
    monkeypatch.syspath_prepend(str(HERE / "fakes"))
    _purge("quanser")
    _purge("nidaqmx")
    from nidaqmx import _fake
    from quanser import hardware

    hardware.fake_reset()
    # the cards' time moves only when the test says: the Q8's 20 ms watchdog must not
    # expire because the host stalled this process between two ticks (a shared CI machine)
    clock = _fake.ManualClock()
    _fake.fake_reset().clock = clock
    _fake.fake_install_device(_fake.FakeDevice("Dev1"))
    hardware.fake_install_board("q8_usb", "0", clock=clock.now)
    shutil.copy(HERE / "data" / "FT00000_Nano25_v11.cal", tmp_path / "FT00000.cal")
    settings = tmp_path / "robot.toml"
    shutil.copy(ROOT / "resources" / "hardware.example.toml", settings)
    try:
        with bare_loop(1024, LoopConfig(compiled=False, realtime=False,
                                        timing_check_s=0.0)) as (loop, _console):
            loop.said = []
            loop._send = loop.said.append
            loop.hardware = BackendConfig(kind="quanser", hardware_settings=str(settings))
            loop.card_clock = clock
            loop._command(Build(1, THESIS_SUBJECT.replace(repetitions=1), loop.hardware))
            loop._command(Connect(2))
            assert loop.state == State.CONNECTED, loop.said
            yield loop
    finally:
        _purge("quanser")
        _purge("nidaqmx")


def test_a_build_while_connected_to_the_robot_gives_the_supervisor_its_limits(connected):
    loop = connected
    first = loop.supervisor
    assert first.limits.force_limit_N == 50.0
    other = THESIS_SUBJECT.replace(repetitions=1, centre_m=(-0.20, 0.35))
    loop._command(Build(3, other, loop.hardware, limits=SafetyLimits(force_limit_N=20.0)))
    reply = [m for m in loop.said if isinstance(m, Reply)][-1]
    assert reply.ok, reply.message
    assert loop.state == State.CONNECTED
    assert loop.supervisor.limits.force_limit_N == 20.0
    assert loop.engine.supervisor is loop.supervisor
    assert loop.supervisor.limits.region_m == loop.limits.region_m
    assert loop.supervisor.limits.region_m != first.limits.region_m
    # the sensor's range from its calibration, as at Connect
    assert loop.supervisor.limits.sensor_planar_range_N == first.limits.sensor_planar_range_N


def test_a_force_limit_above_the_connected_sensor_is_refused_at_build(connected):
    loop = connected
    built = loop.plan
    ceiling = loop.supervisor.limits.force_ceiling_N
    loop._command(Build(3, THESIS_SUBJECT.replace(repetitions=2), loop.hardware,
                        limits=SafetyLimits(force_limit_N=ceiling, sensor_planar_range_N=1000.0)
                        .replace(force_limit_N=ceiling + 10.0)))
    reply = [m for m in loop.said if isinstance(m, Reply)][-1]
    assert not reply.ok
    assert reply.message.startswith("build refused: ")
    assert "force_limit_N" in reply.message
    assert loop.plan is built  # nothing of the refused Build taken
    assert loop.supervisor.limits.force_limit_N == 50.0


def test_the_robot_a_trial_runs_on_is_named_by_its_settings(connected):
    """Every Quanser station's trials said "quanser (<settings file>)": which robot ran was
    nowhere, and a model learned on one robot passed the Build of another."""
    from device.loop.messages import Start
    from device.recording.trialfile.layout import SubjectInfo

    loop = connected
    assert loop.opened.robot_name == "rehab-robot-1"  # the example's [robot] name
    assert loop.opened.label.startswith("quanser (robot rehab-robot-1, ")
    assert any("connected to the quanser (robot rehab-robot-1, " in str(m) for m in loop.said)
    sent = []
    loop._to_recorder = sent.append
    # the homing pose is outside the exercise area: a person guides the handle inside
    from quanser import hardware

    board = hardware._BOARDS[("q8_usb", "0")]
    robot = loop.plan.robot
    target = robot.ik_terms(-0.25, 0.30)
    for ch, (now, there, motor) in enumerate(zip(HOMING, target, robot.motors, strict=True)):
        board.encoder_position[ch] += motor.counts_from_joint_angle(float(there) - now)
    loop.t0 = loop.clock.now()
    loop._beat = (loop.heartbeat.value, loop.t0)  # as the loop's _ticks begins
    for k in range(AREA_CHECK_TICKS + 1):
        # the console beats every tick here: a host that stalls this process between two
        # ticks (a shared CI machine, 0.5 s and more) is not a console lost
        loop.heartbeat.value += 1
        loop.card_clock.advance(loop.config.period_s)
        loop._tick(k, loop.clock.now(), 0.0)
    loop._command(Start(4, "/tmp/robot.h5", SubjectInfo("P1", 70.0, 0.3, 0.3, "right")))
    begun = [m for m in sent if type(m).__name__ == "BeginTrial"]
    started = [m for m in sent if getattr(m, "kind", "") == "start"]
    assert begun, [m for m in loop.said if isinstance(m, Reply)][-1]
    assert started
    assert "robot rehab-robot-1" in begun[0].backend
    assert started[0].values["robot"] == "rehab-robot-1"
