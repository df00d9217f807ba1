"""QuanserBackend against the fake HIL and NI-DAQmx APIs: safe sequence, units, watchdog, errors.

The tests in "Fake and real" take the `rig` fixture and run twice: `[fake]` on the fakes
(always) and `[rig]` on the real Q8 card and force sensor named by --quanser-board and
--hardware-settings (deselected without them; tests/conftest.py, docs/hardware.md "Checking
the fakes against your robot"). On the real card they command zero torque only: nothing moves.
The other tests use the fakes' control surfaces (`fake_rig`) and run on the fakes only.
"""

import logging
import math
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from device.backend import Backend, SensorReading
from device.errors import BackendError, BackendUnavailable
from device.hardware.forcesensor import AtiForceSensor
from device.hardware.quanser import QuanserBackend
from device.hardware.settings import ForceSensorSettings, HardwareSettings, QuanserSettings

HERE = Path(__file__).parent
FAKES = HERE / "fakes"
CAL = HERE / "data" / "FT00000_Nano25_v11.cal"

K_T = 0.115
GEAR = 307.0 / 16.0
COUNTS_PER_JOINT_REV = 4000 * GEAR
RAD_PER_COUNT = 2 * math.pi / COUNTS_PER_JOINT_REV
GAIN = 0.5
HOME = (2.0, 0.5)
Q8_DIGITAL_OUTPUTS = {"q8_usb": 8, "q8": 32}

PERIOD_S = 0.002
READ_BUDGET_S = 1.0e-3
"""A `read()` (encoders, watchdog reload, newest force sample) takes at most this at the 99th
percentile: with a write and the ≤ 50 µs compute it must fit the 1.8 ms between a tick's
deadline and the loop's next sleep (2 ms period, 200 µs slack; docs/performance.md). And no
single call may take a whole period. docs/hardware.md, "Checking the fakes against your robot"."""
WRITE_BUDGET_S = 0.5e-3
"""The same for a `write()` (one write_analog of the two motor outputs)."""


def _purge(package: str) -> None:
    for name in [n for n in sys.modules if n == package or n.startswith(package + ".")]:
        del sys.modules[name]


def _settings(**quanser) -> HardwareSettings:
    q = dict(
        homing_joint_angles_rad=HOME, amplifier_gain_A_per_V=GAIN,
        encoder_channels=(2, 5), encoder_signs=(1, -1),
        analog_output_channels=(3, 6), motor_signs=(1, -1),
        watchdog_timeout_s=0.02,
    )
    q.update(quanser)
    f = ForceSensorSettings(calibration_file=str(CAL), sample_rate_Hz=1000.0, tare_samples=100)
    return HardwareSettings(QuanserSettings(**q), f, source="robot.toml")


# -- the two rigs: the same questions, asked of the fakes or of the real card --------------------


class FakeRig:
    """The fake Q8-USB and NI card on one manual clock. `hil`, `board`, `device`, `system` and
    `clock` are the fakes' control surfaces, for the tests that run on the fakes only."""

    kind = "fake"
    test_torque = (0.5, -0.5)
    """The torque a shared test commands before checking that something zeroes it: the fake
    may be driven; the real rig is only ever commanded zero."""
    still_counts = 0
    """How many counts a robot standing still may drift between Connect and the first read."""
    operator_timeout_s = 2.0

    def __init__(self, hil, board, device, system, clock) -> None:
        self.hil, self.board, self.device, self.system, self.clock = (
            hil, board, device, system, clock)
        self.settings = _settings()
        self._turning: tuple[int, int, int] | None = None  # (channel, counts a tick, ticks left)

    @property
    def calls(self) -> list[tuple[str, tuple]]:
        return self.board.calls

    def call_names(self) -> list[str]:
        return self.board.call_names()

    def opened(self) -> QuanserBackend:
        backend = _backend(self)
        backend.open()
        return backend

    def wait(self) -> float:
        """One loop period later: the loop time of the next tick."""
        self.clock.advance(0.002)
        if self._turning is not None:
            channel, step, left = self._turning
            self.board.encoder_position[channel] += step
            self._turning = (channel, step, left - 1) if left > 1 else None
        return self.clock.now()

    def tick(self, backend: QuanserBackend) -> SensorReading:
        return backend.read(self.wait())

    def stall(self, seconds: float) -> None:
        self.clock.advance(seconds)

    def stopwatch(self) -> float:
        """Time within a tick: the manual clock, which no call advances (only the [rig]
        figures mean anything)."""
        return self.clock.now()

    def counters_hold_old_counts(self) -> None:
        """The card's counters hold whatever they counted since power-up."""
        self.board.encoder_position[:] = [7, 8, 12345, 9, 10, -999, 11, 12]

    def last_counts(self) -> tuple[int, int]:
        return tuple(self.board.counts(c) for c in self.settings.quanser.encoder_channels)

    def output_volts(self) -> tuple[float, float]:
        return tuple(float(self.board.ao_volts[c])
                     for c in self.settings.quanser.analog_output_channels)

    def watchdog_expired(self) -> bool:
        return self.board.watchdog_expired

    def ask_to_turn(self, joint: int, degrees: float) -> None:
        """The fake operator turns link `joint` counter-clockwise by 1.5 × `degrees` over 50
        ticks; its encoder counts the way `encoder_signs` says it does."""
        q = self.settings.quanser
        counts = round(1.5 * math.radians(degrees) / RAD_PER_COUNT)
        self._turning = (q.encoder_channels[joint], q.encoder_signs[joint] * counts // 50, 50)

    def report(self, text: str) -> None:
        pass

    def assert_released(self) -> None:
        assert self.board.open_handles == 0
        assert not self.board.watchdog_running
        assert not self.board.ao_volts.any()
        assert self.system.open_tasks == set()


class _RecordingCard:
    """A real `quanser.hardware.HIL` that logs every call as the fake board does: (name,
    args), arrays as lists of their first num_channels values, num_channels and output buffers
    left out. `raw` is the card itself, for the rig's own questions (not logged)."""

    def __init__(self, card, log: list[tuple[str, tuple]]) -> None:
        self.raw = card
        self._log = log
        self.last_counts: tuple[int, ...] = ()

    def __getattr__(self, name: str):
        method = getattr(self.raw, name)
        if not callable(method):
            return method

        def call(*args):
            shown = args[:-1] if name.startswith("read_") else args
            count = next((a for a, b in zip(shown[1:], shown, strict=False)
                          if isinstance(a, int) and isinstance(b, np.ndarray)), None)
            self._log.append((name, tuple(
                a.tolist()[:count] for a in shown if isinstance(a, np.ndarray)
            ) if count is not None else tuple(shown)))
            result = method(*args)
            if name == "read_encoder":
                self.last_counts = tuple(int(c) for c in args[-1][: args[1]])
            return result

        return call


class RealRig:
    """The real Q8 card and force sensor of --quanser-board and --hardware-settings, at the
    loop's 2 ms pace on the monotonic clock. Every HIL call is logged (`calls`) on its way to
    the real card. Whatever a test leaves open is closed at teardown (zero volts, watchdog
    stopped). The card's outputs cannot be read back: `output_volts` is what the card was last
    told on the motor outputs, and accepted."""

    kind = "rig"
    test_torque = (0.0, 0.0)
    still_counts = 2
    operator_timeout_s = 30.0

    def __init__(self, config, hardware, monkeypatch) -> None:
        self._config = config
        self.settings = config.settings
        self.calls: list[tuple[str, tuple]] = []
        self._cards: list[_RecordingCard] = []
        self._backends: list[QuanserBackend] = []
        self._ticker = config.ticker()
        real_hil = hardware.HIL

        def recording_hil(*args, **kwargs):
            card = _RecordingCard(real_hil(*args, **kwargs), self.calls)
            self._cards.append(card)
            return card

        monkeypatch.setattr(hardware, "HIL", recording_hil)

    def call_names(self) -> list[str]:
        return [name for name, _ in self.calls]

    def opened(self) -> QuanserBackend:
        backend = QuanserBackend(self.settings)
        self._backends.append(backend)
        backend.open()
        return backend

    def wait(self) -> float:
        return self._ticker.wait()

    def tick(self, backend: QuanserBackend) -> SensorReading:
        return backend.read(self.wait())

    def stall(self, seconds: float) -> None:
        time.sleep(seconds)

    def stopwatch(self) -> float:
        return time.perf_counter()

    def counters_hold_old_counts(self) -> None:
        pass  # they do

    def last_counts(self) -> tuple[int, ...]:
        return self._cards[-1].last_counts

    def output_volts(self) -> tuple[float, float]:
        told: dict[int, float] = {}
        for name, args in self.calls:
            if name == "write_analog":
                told.update(zip(args[0], args[1], strict=True))
        return tuple(told[c] for c in self.settings.quanser.analog_output_channels)

    def watchdog_expired(self) -> bool:
        return bool(self._cards[-1].raw.watchdog_is_expired())

    def ask_to_turn(self, joint: int, degrees: float) -> None:
        link = ("l1 (joint 1, θ_R1)", "l2 (joint 2, θ_R2)")[joint]
        self._config.say(
            f"Turn link {link} by hand COUNTER-CLOCKWISE seen from above, by at least "
            f"{degrees:g}°, now (within {self.operator_timeout_s:g} s). Amplifiers off.")

    def report(self, text: str) -> None:
        self._config.say(text)

    def assert_released(self) -> None:
        """Released: a new Connect finds the card and the NI device free, and reads."""
        backend = self.opened()
        self.tick(backend)
        backend.close()

    def close_all(self) -> None:
        for backend in self._backends:
            try:
                backend.close()
            except BackendError as exc:
                self._config.say(f"closing after the test: {exc}")


@pytest.fixture
def fake_rig(monkeypatch):
    """Fake `quanser` and `nidaqmx` first on sys.path: a Q8-USB and an NI card on one clock."""
    monkeypatch.syspath_prepend(str(FAKES))
    for name in [n for n in sys.modules if n.split(".")[0] in ("quanser", "nidaqmx")]:
        monkeypatch.delitem(sys.modules, name)
    from nidaqmx import _fake
    from quanser import hardware

    hardware.fake_reset()
    system = _fake.fake_reset()
    clock = _fake.ManualClock()
    system.clock = clock
    device = _fake.fake_install_device(_fake.FakeDevice("Dev1"))
    board = hardware.fake_install_board("q8_usb", "0", clock=clock.now)
    yield FakeRig(hardware, board, device, system, clock)
    leaked = set(system.open_tasks)
    _purge("quanser")
    _purge("nidaqmx")
    assert not leaked, "an NI-DAQmx task was left open"


@pytest.fixture
def real_rig(rig_config, monkeypatch):
    """The robot of --quanser-board and --hardware-settings (its vendor packages were checked
    at start-up)."""
    from quanser import hardware

    rig = RealRig(rig_config, hardware, monkeypatch)
    yield rig
    rig.close_all()


@pytest.fixture(params=["fake", pytest.param("rig", marks=pytest.mark.rig("quanser"))])
def rig(request):
    """`[fake]`: the fakes; `[rig]`: the real robot (deselected without --quanser-board)."""
    return request.getfixturevalue("fake_rig" if request.param == "fake" else "real_rig")


def _backend(fake_rig, **quanser) -> QuanserBackend:
    settings = _settings(**quanser)
    sensor = AtiForceSensor(settings.force_sensor, clock=fake_rig.clock.now)
    return QuanserBackend(settings, force_sensor=sensor, clock=fake_rig.clock.now)


def _opened(fake_rig, **quanser) -> QuanserBackend:
    backend = _backend(fake_rig, **quanser)
    backend.open()
    return backend


def _tick(fake_rig, backend: QuanserBackend, dt_s: float = 0.002) -> SensorReading:
    fake_rig.clock.advance(dt_s)
    return backend.read(fake_rig.clock.now())


# -- fake and real: what the fakes model, asked of whichever rig runs -----------------------------


def test_open_follows_the_safe_sequence(rig):
    q = rig.settings.quanser
    backend = rig.opened()
    assert rig.call_names() == [
        "open",
        *(["set_card_specific_options"] if q.card_options else []),
        "watchdog_clear",
        "set_analog_output_ranges",
        "write_analog",
        "watchdog_set_analog_expiration_state",
        "watchdog_set_digital_expiration_state",
        "set_encoder_quadrature_mode",
        "set_encoder_counts",
        "watchdog_start",
    ]
    args = dict(rig.calls)
    assert args["open"] == (q.board_type, q.board_identifier)
    if q.card_options:
        assert args["set_card_specific_options"] == (q.card_options, len(q.card_options) + 1)
    assert args["set_analog_output_ranges"] == (
        list(q.analog_output_channels), [-10.0, -10.0], [10.0, 10.0])
    assert args["write_analog"] == (list(range(8)), [0.0] * 8)
    assert args["watchdog_set_analog_expiration_state"] == (list(range(8)), [0.0] * 8)
    digital = Q8_DIGITAL_OUTPUTS[q.board_type]
    assert args["watchdog_set_digital_expiration_state"] == (list(range(digital)), [2] * digital)
    assert args["set_encoder_quadrature_mode"] == (list(q.encoder_channels), [4, 4])  # X4
    assert args["set_encoder_counts"] == (list(q.encoder_channels), [0, 0])
    assert args["watchdog_start"] == (q.watchdog_timeout_s,)
    # The tare (0.1 s of samples on the fake's clock, 0.25 s by default on the robot's) ran
    # before the 20 ms watchdog started: had the watchdog been started first, it would have
    # expired by now.
    assert backend.force_sensor.is_open
    assert not rig.watchdog_expired()
    rig.tick(backend)
    backend.close()


def test_the_homing_pose_reads_the_homing_angles(rig):
    """Connect zeroes the counters wherever they were: the robot standing still in its homing
    pose reads the homing angles, θ = θ_home + sign · counts · 2π / 76 750."""
    q = rig.settings.quanser
    rig.counters_hold_old_counts()
    backend = rig.opened()
    reading = rig.tick(backend)
    counts = rig.last_counts()
    assert all(abs(c) <= rig.still_counts for c in counts), (
        f"the encoders counted {counts} between Connect and the first read: is the robot "
        "standing still?")
    expected = tuple(home + sign * c * RAD_PER_COUNT for home, sign, c in
                     zip(q.homing_joint_angles_rad, q.encoder_signs, counts, strict=True))
    assert (reading.q1_rad, reading.q2_rad) == pytest.approx(expected, rel=0, abs=1e-12)
    assert (reading.q1_rad, reading.q2_rad) == pytest.approx(
        q.homing_joint_angles_rad, rel=0, abs=rig.still_counts * RAD_PER_COUNT + 1e-12)
    backend.close()


def test_zero_torque_writes_zero_volts(rig):
    q = rig.settings.quanser
    backend = rig.opened()
    rig.tick(backend)
    backend.write(*rig.test_torque)
    backend.write(0.0, 0.0)
    assert rig.calls[-1] == ("write_analog", (list(q.analog_output_channels), [0.0, 0.0]))
    assert backend.commanded_volts == (0.0, 0.0)
    assert rig.output_volts() == (0.0, 0.0)
    backend.close()


def test_safe_state_zeroes_the_outputs(rig):
    q = rig.settings.quanser
    backend = rig.opened()
    rig.tick(backend)
    backend.write(*rig.test_torque)
    n = len(rig.calls)
    backend.safe_state()
    assert rig.calls[n:] == [("write_analog", (list(q.analog_output_channels), [0.0, 0.0]))]
    assert backend.commanded_volts == (0.0, 0.0)
    assert rig.output_volts() == (0.0, 0.0)
    rig.tick(backend)  # still connected: the safe state zeroes the motors, nothing else
    backend.close()


def test_the_watchdog_is_reloaded_on_every_read(rig):
    backend = rig.opened()
    before = rig.call_names().count("watchdog_reload")
    for _ in range(200):  # 0.4 s: twenty times the watchdog's timeout
        rig.tick(backend)
        backend.write(*rig.test_torque)
    assert rig.call_names().count("watchdog_reload") - before == 200
    assert not rig.watchdog_expired()
    backend.close()


@pytest.mark.rig_needs("watchdog_expiry")
def test_a_read_after_the_watchdog_expired_raises_and_a_new_connect_clears_it(rig):
    """[rig] precondition (--rig-allow-watchdog-expiry): the amplifiers' enable is OFF, or the
    motor leads are disconnected. The test commands zero torque, then stops reading for three
    watchdog timeouts: the card switches its outputs to 0 V by itself (they already are),
    the next read raises "The Q8 watchdog expired", and close then a new Connect clear it."""
    timeout_s = rig.settings.quanser.watchdog_timeout_s
    backend = rig.opened()
    rig.tick(backend)
    backend.write(*rig.test_torque)
    rig.stall(3 * timeout_s)  # the loop hung
    with pytest.raises(BackendError, match="Q8 watchdog expired") as info:
        rig.tick(backend)
    assert f"within {timeout_s * 1e3:.0f} ms" in str(info.value)
    assert rig.watchdog_expired()
    assert rig.output_volts() == (0.0, 0.0)
    backend.safe_state()
    backend.close()
    reopened = rig.opened()
    rig.tick(reopened)
    assert not rig.watchdog_expired()
    reopened.close()


def test_close_stops_everything_and_is_idempotent(rig):
    backend = rig.opened()
    rig.tick(backend)
    backend.write(*rig.test_torque)
    n = len(rig.calls)
    backend.close()
    assert rig.call_names()[n:] == [
        "watchdog_is_expired", "task_stop_all", "write_analog", "task_delete_all",
        "watchdog_stop", "close",
    ]
    assert dict(rig.calls[n:])["write_analog"] == (list(range(8)), [0.0] * 8)
    assert rig.output_volts() == (0.0, 0.0)
    assert not backend.is_open
    n = len(rig.calls)
    backend.close()
    assert len(rig.calls) == n
    with pytest.raises(BackendError, match="not open"):
        backend.read(0.0)
    with pytest.raises(BackendError, match="not open"):
        backend.write(0.0, 0.0)
    rig.assert_released()


def test_each_read_and_write_returns_within_its_budget(rig):
    """500 ticks at the loop's pace: reads within READ_BUDGET_S and writes within
    WRITE_BUDGET_S at the 99th percentile, and none longer than a loop period. On the fakes the
    clock does not move inside a call: only [rig] measures."""
    backend = rig.opened()
    reads, writes = [], []
    for _ in range(500):
        now = rig.wait()
        t0 = rig.stopwatch()
        backend.read(now)
        t1 = rig.stopwatch()
        backend.write(*rig.test_torque)
        t2 = rig.stopwatch()
        reads.append(t1 - t0)
        writes.append(t2 - t1)
    backend.close()
    rig.report(f"{_figures('read', reads)}; {_figures('write', writes)}")
    for what, durations, budget_s in (("read", reads, READ_BUDGET_S),
                                      ("write", writes, WRITE_BUDGET_S)):
        advice = (f"{_figures(what, durations)}: allowed p99 {budget_s * 1e3:g} ms, max "
                  f"{PERIOD_S * 1e3:g} ms. A slow median is the card or its USB link; outliers "
                  "alone are the PC: run bench/wakeup.py (docs/hardware.md, 'What the PC must "
                  "hold').")
        assert np.percentile(durations, 99) <= budget_s, advice
        assert max(durations) <= PERIOD_S, advice


def _figures(what: str, durations: list[float]) -> str:
    ms = np.array(durations) * 1e3
    return (f"{what} p50 {np.percentile(ms, 50):.3f} ms, p99 {np.percentile(ms, 99):.3f} ms, "
            f"max {ms.max():.3f} ms")


@pytest.mark.rig_needs("move_by_hand")
def test_turning_each_link_by_hand_counter_clockwise_increases_its_angle(rig):
    """Bench check step 5 as a test: `encoder_signs`. [rig] precondition (--rig-move-by-hand):
    the amplifiers are OFF; when asked, the operator turns link l1, then link l2, by hand
    counter-clockwise seen from above by at least 5°; the angle must grow. Then put the robot
    back in its homing pose."""
    angles = (lambda r: r.q1_rad, lambda r: r.q2_rad)
    backend = rig.opened()
    for joint in (0, 1):
        start = rig.tick(backend)
        rig.ask_to_turn(joint, 5.0)
        reading = start
        while (abs(angles[joint](reading) - angles[joint](start)) < math.radians(5.0)
               and reading.time_s - start.time_s < rig.operator_timeout_s):
            reading = rig.tick(backend)
        turned = math.degrees(angles[joint](reading) - angles[joint](start))
        assert abs(turned) >= 5.0, (
            f"link {joint + 1} did not turn by 5° within {rig.operator_timeout_s:g} s")
        assert turned > 0, (
            f"link {joint + 1} turned counter-clockwise but its angle changed by {turned:+.1f}°: "
            f"[quanser] encoder_signs[{joint}] in {rig.settings.source} has the wrong sign")
    backend.close()
    rig.report("Put the robot back in its homing pose.")


# -- the fakes only: what needs the fakes' control surfaces ---------------------------------------


def test_it_is_a_backend(fake_rig):
    backend = _backend(fake_rig)
    assert isinstance(backend, Backend)
    assert backend.name == "quanser"


def test_legacy_q8_sets_expiration_states_on_all_32_digital_outputs(fake_rig):
    fake_rig.board = fake_rig.hil.fake_install_board("q8", "0", clock=fake_rig.clock.now)
    backend = _opened(fake_rig, board_type="q8", card_options="")
    args = dict(fake_rig.board.calls)
    assert "set_card_specific_options" not in args
    assert args["watchdog_set_digital_expiration_state"] == (list(range(32)), [2] * 32)
    backend.close()


def test_counts_become_joint_angles_with_signs_and_homing(fake_rig):
    fake_rig.board.encoder_position[:] = [7, 8, 12345, 9, 10, -999, 11, 12]  # before Connect
    backend = _opened(fake_rig)
    reading = _tick(fake_rig, backend)
    assert (reading.q1_rad, reading.q2_rad) == HOME  # counts zeroed at the homing pose
    fake_rig.board.encoder_position[2] += 1000
    fake_rig.board.encoder_position[5] -= 2000
    fake_rig.board.encoder_position[[0, 1, 3, 4]] += 777  # other channels must not matter
    reading = _tick(fake_rig, backend)
    assert reading.q1_rad == pytest.approx(HOME[0] + 1000 * 2 * math.pi / COUNTS_PER_JOINT_REV)
    assert reading.q2_rad == pytest.approx(HOME[1] + 2000 * 2 * math.pi / COUNTS_PER_JOINT_REV)
    assert reading.q1_rad - HOME[0] == pytest.approx(math.radians(4.6906), abs=1e-6)
    backend.close()


def test_reading_carries_the_clock_and_the_tared_forces(fake_rig):
    backend = _opened(fake_rig)
    fake_rig.device.volts[:6] = [0.0, 0.1, 0.0, 0.0, 0.0, 0.0]
    reading = _tick(fake_rig, backend)
    assert reading.time_s == fake_rig.clock.now()
    assert (reading.force_x_N, reading.force_y_N, reading.force_z_N) == pytest.approx(
        (-0.034999, 6.12, 0.062)
    )
    backend.close()


@pytest.mark.parametrize(
    ("torques", "limit_V", "volts"),
    [
        ((0.5, 0.3), 10.0, (0.5 / (K_T * GEAR) / GAIN, -0.3 / (K_T * GEAR) / GAIN)),
        ((-0.5, -0.3), 10.0, (-0.5 / (K_T * GEAR) / GAIN, 0.3 / (K_T * GEAR) / GAIN)),
        ((5.0, -5.0), 10.0, (2.0, 2.0)),  # 2.27 A asked: clamped to the rated 1 A = 2 V
        ((5.0, 0.5), 1.5, (1.5, -0.5 / (K_T * GEAR) / GAIN)),  # the voltage limit is lower
        ((-5.0, 5.0), 1.5, (-1.5, -1.5)),
    ],
)
def test_torque_becomes_current_then_volts_with_clamping(fake_rig, torques, limit_V, volts):
    backend = _opened(fake_rig, output_voltage_limit_V=limit_V)
    backend.write(*torques)
    assert fake_rig.board.ao_volts[3] == pytest.approx(volts[0])
    assert fake_rig.board.ao_volts[6] == pytest.approx(volts[1])
    others = np.delete(fake_rig.board.ao_volts, [3, 6])
    assert not others.any()
    assert backend.commanded_volts == pytest.approx(volts)
    backend.close()


def test_half_a_newton_metre_by_hand(fake_rig):
    """0.5 N·m / (0.115 N·m/A × 19.1875) = 0.22660 A; at 0.5 A/V that is 0.45319 V."""
    backend = _backend(fake_rig)
    assert backend.volts_for_torque(0.5, 0.0)[0] == pytest.approx(0.45319, abs=1e-5)


def test_not_finite_torque_is_refused_and_zeroes_the_motors(fake_rig):
    backend = _opened(fake_rig)
    backend.write(0.5, 0.5)
    with pytest.raises(BackendError, match=r"Refused torque command \(nan, 0.5\)"):
        backend.write(float("nan"), 0.5)
    assert not fake_rig.board.ao_volts.any()
    backend.close()


def test_signs_agree_with_a_simulated_motor(fake_rig):
    """Joint 2's encoder counts down and its motor is wired reversed: with both signs
    set to -1, a positive torque still turns both joints the positive way."""
    fake_rig.board.plant_counts_per_V_s[:] = 2000.0
    backend = _opened(fake_rig, encoder_channels=(0, 1), analog_output_channels=(0, 1),
                      encoder_signs=(1, -1), motor_signs=(1, -1))
    backend.write(0.3, 0.3)
    fake_rig.board.advance(0.5)
    reading = _tick(fake_rig, backend)
    assert reading.q1_rad > HOME[0]
    assert reading.q2_rad > HOME[1]
    backend.close()


@pytest.mark.parametrize("blocked_access", ["error", "ignore"])
def test_watchdog_expiry_stops_the_motors_and_is_reported(fake_rig, blocked_access):
    fake_rig.board.blocked_access = blocked_access
    backend = _opened(fake_rig)
    backend.write(0.5, 0.5)
    assert fake_rig.board.ao_volts.any()
    fake_rig.clock.advance(0.05)  # the loop hung for 50 ms
    with pytest.raises(BackendError, match="Q8 watchdog expired") as info:
        backend.read(fake_rig.clock.now())
    assert "within 20 ms" in str(info.value)
    assert not fake_rig.board.ao_volts.any()  # the card zeroed its outputs by itself
    if blocked_access == "error":
        with pytest.raises(BackendError, match="Q8 watchdog expired"):
            backend.write(0.5, 0.5)
    else:
        backend.write(0.5, 0.5)  # silently blocked
    assert not fake_rig.board.ao_volts.any()
    backend.safe_state()
    backend.close()  # a clean close after an expiry: stopped, cleared, zeroed
    assert not fake_rig.board.watchdog_expired
    assert fake_rig.board.open_handles == 0
    reopened = _opened(fake_rig)  # and the next Connect works
    _tick(fake_rig, reopened)
    reopened.close()


def test_safe_state_never_raises(fake_rig, caplog):
    backend = _backend(fake_rig)
    backend.safe_state()  # not open
    backend.open()
    backend.write(0.5, -0.5)
    backend.safe_state()
    assert not fake_rig.board.ao_volts.any()
    fake_rig.board.fail["write_analog"] = 113
    with caplog.at_level(logging.WARNING, logger="device.hardware.quanser"):
        backend.safe_state()
        backend.safe_state()
    assert sum("safe_state" in r.message for r in caplog.records) == 1  # once, not every tick
    fake_rig.board.broken = RuntimeError("USB cable pulled")
    backend.safe_state()
    fake_rig.board.broken = None
    fake_rig.board.fail.clear()
    backend.close()
    backend.safe_state()  # closed


def test_close_with_a_dead_card_still_releases_everything_then_reports(fake_rig):
    backend = _opened(fake_rig)
    fake_rig.board.broken = RuntimeError("USB cable pulled")
    with pytest.raises(BackendError, match=r"incomplete .*USB cable pulled"):
        backend.close()
    assert fake_rig.board.open_handles == 0
    assert fake_rig.system.open_tasks == set()
    backend.close()


def test_board_not_found(fake_rig):
    backend = _backend(fake_rig, board_identifier="1")
    with pytest.raises(BackendUnavailable, match="q8_usb board #1 was not found") as info:
        backend.open()
    text = str(info.value)
    assert "HIL error -108" in text
    assert "board_identifier in robot.toml" in text
    assert fake_rig.system.tasks_created == 0  # the force sensor was not touched
    assert not backend.is_open


def test_board_in_use(fake_rig):
    fake_rig.board.in_use_elsewhere = True
    with pytest.raises(BackendUnavailable, match=r"in use by another program \(HIL error -109"):
        _backend(fake_rig).open()


def test_unknown_encoder_channel(fake_rig):
    fake_rig.board = fake_rig.hil.fake_install_board("q8_usb", "0", encoders=4,
                                                     clock=fake_rig.clock.now)
    backend = _backend(fake_rig)
    with pytest.raises(BackendError, match=r"no encoder channel \[2, 5\].*encoder_channels"):
        backend.open()
    assert fake_rig.board.open_handles == 0
    assert not fake_rig.board.ao_volts.any()


def test_fixed_output_ranges_are_accepted(fake_rig):
    fake_rig.board.ao_range_programmable = False
    backend = _opened(fake_rig)
    backend.close()


def test_a_watchdog_that_cannot_start_refuses_the_connect_and_releases_all(fake_rig):
    fake_rig.board.fail["watchdog_start"] = 614
    backend = _backend(fake_rig)
    with pytest.raises(BackendUnavailable, match="refused the watchdog configuration"):
        backend.open()
    assert fake_rig.board.open_handles == 0
    assert fake_rig.system.open_tasks == set()
    assert not backend.force_sensor.is_open


def test_force_sensor_failure_releases_the_card(fake_rig):
    fake_rig.system.driver_installed = False
    backend = _backend(fake_rig)
    with pytest.raises(BackendUnavailable, match="NI-DAQmx driver is not installed"):
        backend.open()
    names = fake_rig.board.call_names()
    assert names[-2:] == ["watchdog_stop", "close"]
    assert "watchdog_start" not in names
    assert fake_rig.board.open_handles == 0


def test_hil_not_installed(monkeypatch):
    monkeypatch.setitem(sys.modules, "quanser", None)
    backend = QuanserBackend(_settings())
    with pytest.raises(BackendUnavailable, match="python3-quanser-apis") as info:
        backend.open()
    assert "quanser_api" in str(info.value)


def test_hil_without_native_libraries_raises_oserror_at_import(monkeypatch, tmp_path):
    package = tmp_path / "quanser"
    (package / "hardware").mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "hardware" / "__init__.py").write_text(
        "raise OSError(\"cannot load library 'hil': hil.dll not found\")\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    for name in [n for n in sys.modules if n.split(".")[0] == "quanser"]:
        monkeypatch.delitem(sys.modules, name)
    with pytest.raises(BackendUnavailable, match="OSError: cannot load library 'hil'"):
        QuanserBackend(_settings()).open()
    _purge("quanser")


# -- the fake itself: the cffi buffer rules of the real API ---------------------------------------


def test_fake_hil_enforces_the_real_buffer_rules(fake_rig):
    card = fake_rig.hil.HIL("q8_usb", "0")
    fake_rig.board.encoder_position[:3] = [10, 20, 30]
    out = np.zeros(2, dtype=np.int32)
    with pytest.raises(TypeError):
        card.read_encoder([1, 2], 2, out)
    with pytest.raises(ValueError, match="contiguous"):
        card.read_encoder(np.array([[1, 9], [2, 9]], dtype=np.uint32)[:, 0], 2, out)
    card.read_encoder(np.array([1, 2], dtype=np.int64), 2, out)  # the bytes of 1 are [1, 0]
    assert out.tolist() == [20, 10]
    wide = np.zeros(2, dtype=np.int64)
    card.read_encoder(np.array([1, 2], dtype=np.uint32), 2, wide)
    assert wide.tolist() == [20 + (30 << 32), 0]  # two int32s written into one int64
    card.read_encoder(np.array([1, 2], dtype=np.uint32), 2, out)
    assert out.tolist() == [20, 30]
    with pytest.raises(fake_rig.hil.HILError) as info:
        card.read_encoder(np.array([9], dtype=np.uint32), 1, out)
    assert info.value.error_code == -124
    assert str(info.value) == "-124"
    card.close()
    card.close()  # a no-op when not open
    with pytest.raises(fake_rig.hil.HILError) as info:
        fake_rig.hil.HIL("q8_usb", "7")
    assert info.value.error_code == -108


def test_the_supervisor_takes_the_sensor_range_from_its_calibration(fake_rig):
    """The thesis's Nano25 is calibrated for 250 N in the plane (this .cal says so):
    the supervisor's saturation and force ceilings follow the file, not a constant."""
    from device.loop.backends import limits_for_backend
    from device.safety.limits import SafetyLimits

    backend = _opened(fake_rig)
    planar, normal = backend.force_sensor_range_N
    assert planar == pytest.approx(250.0)
    assert normal > planar
    limits = limits_for_backend(SafetyLimits(), backend)
    assert limits.sensor_planar_range_N == planar
    assert limits.sensor_normal_range_N == normal
    backend.close()


def test_a_force_limit_above_a_smaller_sensor_is_refused_by_name():
    from core.errors import ParameterError
    from device.safety.limits import SafetyLimits

    small = SafetyLimits(force_limit_N=150.0)
    with pytest.raises(ParameterError, match="force_limit_N") as error:
        small.for_sensor(125.0, 500.0, "FT12345.cal")
    assert "FT12345.cal rates the sensor for 125 N" in str(error.value)
    assert SafetyLimits().for_sensor(125.0, 500.0).force_ceiling_N == 100.0
