"""The rig options of tests/conftest.py, proved by running pytest in a subprocess.

Without the options the `[rig]` variants of test_quanser.py and test_forcesensor.py are
deselected (never skipped); with an option but something missing the run stops with one line;
and with the options, the `[rig]` variants run: here on the fakes put on the path as if they
were the real `quanser` and `nidaqmx` packages, with a stand-in robot on the wall clock.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).parent
ROOT = HERE.parents[1]
FAKES = HERE / "fakes"
CAL = HERE / "data" / "FT00000_Nano25_v11.cal"
RIG_FILES = ("tests/device/test_quanser.py", "tests/device/test_forcesensor.py")

ROBOT_TOML = """\
[robot]
name = "stand-in"

[quanser]
board_type = "q8_usb"
encoder_channels = [2, 5]
encoder_signs = [1, -1]
homing_joint_angles_rad = [2.0, 0.5]
analog_output_channels = [3, 6]
motor_signs = [1, -1]
amplifier_gain_A_per_V = 0.5
watchdog_timeout_s = 0.2  # ample for a shared CI machine: the stand-in runs on the wall clock

[force_sensor]
calibration_file = "{cal}"
sample_rate_Hz = 1000.0
tare_samples = 100
read_timeout_s = 0.1
"""

STAND_IN = '''\
"""The robot for the [rig] tests in a subprocess: the fakes, imported as the real packages,
with a Q8-USB "0" and an NI card "Dev1" on the wall clock, and an operator who turns both
links counter-clockwise during the by-hand test (encoder_signs [1, -1], channels 2 and 5)."""

import threading

from nidaqmx import _fake
from quanser import hardware

board = hardware.fake_install_board("q8_usb", "0")
_fake.fake_install_device(_fake.FakeDevice("Dev1"))
_stop = threading.Event()


def _turn():
    while not _stop.wait(0.002):
        board.encoder_position[2] += 10  # 23 degrees a second
        board.encoder_position[5] -= 10


def pytest_runtest_setup(item):
    if "by_hand" in item.name:
        _stop.clear()
        threading.Thread(target=_turn, daemon=True).start()


def pytest_runtest_teardown(item):
    _stop.set()
'''


@pytest.fixture
def robot_toml(tmp_path) -> Path:
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT_TOML.format(cal=CAL.as_posix()))
    return path


def _pytest(*args: str, path: tuple[Path, ...] = ()) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(p) for p in path] + [env.get("PYTHONPATH", "")])
    return subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", *args],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=240, check=False,
    )


def _one_line(result: subprocess.CompletedProcess) -> str:
    """The run stopped as a usage error with exactly one line on stderr and no traceback."""
    assert "Traceback" not in result.stdout + result.stderr, result.stdout + result.stderr
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.returncode == 4, result.stdout + result.stderr  # pytest's usage error
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("ERROR: ")
    return lines[0]


def test_without_the_options_the_rig_tests_are_deselected_not_skipped():
    result = _pytest(*RIG_FILES, "--collect-only", "-q")
    assert result.returncode == 0, result.stdout + result.stderr
    ids = [line for line in result.stdout.splitlines() if "::" in line]
    fakes = [i for i in ids if i.endswith("[fake]")]
    assert len(fakes) >= 10  # the tests that run on both
    assert not [i for i in ids if "[rig]" in i]
    summary = re.search(r"(\d+)/(\d+) tests collected \((\d+) deselected\)", result.stdout)
    assert summary is not None, result.stdout
    assert int(summary[3]) == len(fakes)  # one [rig] variant deselected for each [fake]
    assert "skipped" not in result.stdout


def test_the_board_option_without_the_quanser_package_is_one_line(tmp_path, robot_toml):
    hide = tmp_path / "hide"
    hide.mkdir()
    (hide / "sitecustomize.py").write_text("import sys\nsys.modules['quanser'] = None\n")
    result = _pytest(RIG_FILES[0], "--collect-only", "-q", "--quanser-board", "0",
                     "--hardware-settings", str(robot_toml), path=(hide,))
    line = _one_line(result)
    assert line.startswith("ERROR: --quanser-board 0: The Quanser HIL Python API cannot be "
                           "loaded here (ModuleNotFoundError: ")
    assert "quanser_api-*.whl" in line
    assert "python3-quanser-apis" in line
    assert sys.executable in line


@pytest.mark.parametrize(
    ("options", "fragments"),
    [
        (["--quanser-board", "0"], ["--quanser-board 0 needs --hardware-settings PATH"]),
        (["--quanser-board", "3", "--hardware-settings", "{toml}"],
         ["--quanser-board 3: Quanser q8_usb board #3 was not found (HIL error -108: ",
          "board_identifier in {toml}"]),
        (["--nidaq-device", "Dev9", "--hardware-settings", "{toml}"],
         ["--nidaq-device Dev9: NI device 'Dev9' cannot be found or accessed"]),
        (["--quanser-board", "0", "--hardware-settings", "{toml}.missing"],
         ["hardware settings file {toml}.missing does not exist"]),
        (["--rig-allow-watchdog-expiry"], ["--rig-allow-watchdog-expiry runs nothing by itself"]),
    ],
    ids=["no-settings", "no-board", "no-ni-device", "no-settings-file", "expiry-alone"],
)
def test_a_missing_piece_is_one_line(robot_toml, options, fragments):
    """The fakes stand in for installed vendor packages with no board and no NI device."""
    options = [o.format(toml=robot_toml) for o in options]
    line = _one_line(_pytest(*RIG_FILES, "-q", "-k", "homing_pose or unloaded_sensor", *options,
                             path=(FAKES,)))
    for fragment in fragments:
        assert fragment.format(toml=robot_toml) in line


@pytest.mark.slow
def test_with_the_options_the_rig_tests_run_on_the_robot(tmp_path, robot_toml):
    """Every [rig] variant but the two latency ones (timed on the wall clock of a shared
    machine) runs against the stand-in robot and passes; nothing is skipped."""
    (tmp_path / "rig_stand_in.py").write_text(STAND_IN)
    result = _pytest(
        *RIG_FILES, "-p", "rig_stand_in", "-m", "rig", "-k", "not budget", "-rA",
        "--quanser-board", "0", "--hardware-settings", str(robot_toml),
        "--rig-allow-watchdog-expiry", "--rig-move-by-hand",
        path=(FAKES, tmp_path),
    )
    out = result.stdout
    assert result.returncode == 0, out + result.stderr
    assert f"rig: Quanser q8_usb #0, NI Dev1/ai0:5 from {robot_toml}; also move by hand, " \
           "watchdog expiry" in out
    passed = [line for line in out.splitlines() if line.startswith("PASSED ")]
    assert passed, out
    assert all(line.endswith("[rig]") for line in passed), out
    for name in ("test_open_follows_the_safe_sequence", "test_the_homing_pose_reads",
                 "test_a_read_after_the_watchdog_expired", "test_turning_each_link_by_hand",
                 "test_an_unloaded_sensor_reads_zero", "test_the_card_samples_continuously"):
        assert any(name in line for line in passed), name
    # Exactly this: no failed, no error, no skipped.
    assert re.search(rf"=+ {len(passed)} passed, \d+ deselected in [\d.]+s", out), out
    assert "SKIPPED" not in out
    assert "Turn link l1 (joint 1, θ_R1) by hand COUNTER-CLOCKWISE" in out
