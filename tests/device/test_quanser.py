"""QuanserBackend against the fake HIL and NI-DAQmx APIs: safe sequence, units, watchdog, errors."""

import logging
import math
import sys
from pathlib import Path
from types import SimpleNamespace

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
GAIN = 0.5
HOME = (2.0, 0.5)


def _purge(package: str) -> None:
    for name in [n for n in sys.modules if n == package or n.startswith(package + ".")]:
        del sys.modules[name]


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
    yield SimpleNamespace(hil=hardware, board=board, device=device, system=system, clock=clock)
    leaked = set(system.open_tasks)
    _purge("quanser")
    _purge("nidaqmx")
    assert not leaked, "an NI-DAQmx task was left open"


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


def test_it_is_a_backend(fake_rig):
    backend = _backend(fake_rig)
    assert isinstance(backend, Backend)
    assert backend.name == "quanser"


def test_open_follows_the_safe_sequence(fake_rig):
    backend = _opened(fake_rig)
    calls = fake_rig.board.calls
    assert [name for name, _ in calls] == [
        "open",
        "set_card_specific_options",
        "watchdog_clear",
        "set_analog_output_ranges",
        "write_analog",
        "watchdog_set_analog_expiration_state",
        "watchdog_set_digital_expiration_state",
        "set_encoder_quadrature_mode",
        "set_encoder_counts",
        "watchdog_start",
    ]
    args = dict(calls)
    assert args["open"] == ("q8_usb", "0")
    assert args["set_card_specific_options"] == ("update_rate=normal;decimation=1", 32)
    assert args["set_analog_output_ranges"] == ([3, 6], [-10.0, -10.0], [10.0, 10.0])
    assert args["write_analog"] == (list(range(8)), [0.0] * 8)
    assert args["watchdog_set_analog_expiration_state"] == (list(range(8)), [0.0] * 8)
    assert args["watchdog_set_digital_expiration_state"] == (list(range(8)), [2] * 8)
    assert args["set_encoder_quadrature_mode"] == ([2, 5], [4, 4])  # X4
    assert args["set_encoder_counts"] == ([2, 5], [0, 0])
    assert args["watchdog_start"] == (0.02,)
    # The tare (0.1 s of samples on the shared clock) ran before the 20 ms watchdog started:
    # had the watchdog been started first, it would have expired by now.
    assert backend.force_sensor.is_open
    assert fake_rig.board.watchdog_running
    assert not fake_rig.board.watchdog_expired
    _tick(fake_rig, backend)
    backend.close()


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


def test_the_watchdog_is_reloaded_on_every_read(fake_rig):
    backend = _opened(fake_rig)
    before = fake_rig.board.call_names().count("watchdog_reload")
    for _ in range(200):  # 0.4 s: twenty times the watchdog's timeout
        _tick(fake_rig, backend, 0.002)
        backend.write(0.1, 0.1)
    assert fake_rig.board.call_names().count("watchdog_reload") - before == 200
    assert not fake_rig.board.watchdog_expired
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


def test_close_stops_everything_and_is_idempotent(fake_rig):
    backend = _opened(fake_rig)
    backend.write(1.0, 1.0)
    n = len(fake_rig.board.calls)
    backend.close()
    assert fake_rig.board.call_names()[n:] == [
        "watchdog_is_expired", "task_stop_all", "write_analog", "task_delete_all",
        "watchdog_stop", "close",
    ]
    assert dict(fake_rig.board.calls[n:])["write_analog"] == (list(range(8)), [0.0] * 8)
    assert not fake_rig.board.ao_volts.any()
    assert not fake_rig.board.watchdog_running
    assert fake_rig.board.open_handles == 0
    assert fake_rig.system.open_tasks == set()
    assert not backend.is_open
    n = len(fake_rig.board.calls)
    backend.close()
    assert len(fake_rig.board.calls) == n
    with pytest.raises(BackendError, match="not open"):
        backend.read(0.0)
    with pytest.raises(BackendError, match="not open"):
        backend.write(0.0, 0.0)


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
    from device.loop.process import limits_for_backend
    from device.safety.supervisor import SafetyLimits

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
    from device.safety.supervisor import SafetyLimits

    small = SafetyLimits(force_limit_N=150.0)
    with pytest.raises(ParameterError, match="force_limit_N") as error:
        small.for_sensor(125.0, 500.0, "FT12345.cal")
    assert "FT12345.cal rates the sensor for 125 N" in str(error.value)
    assert SafetyLimits().for_sensor(125.0, 500.0).force_ceiling_N == 100.0
