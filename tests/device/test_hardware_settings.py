"""Hardware settings: the example file loads, and every bad value is refused naming file and key."""

import math
from pathlib import Path

import pytest

from device.errors import BackendError
from device.hardware.settings import (
    ForceSensorSettings,
    HardwareSettingsError,
    QuanserSettings,
    count_physical_channels,
    load_hardware_settings,
)

EXAMPLE = Path(__file__).resolve().parents[2] / "resources" / "hardware.example.toml"

GOOD = """
[robot]
name = "Lab robot #2"

[quanser]
board_type = "q8"
board_identifier = "1"
card_options = ""
encoder_channels = [2, 5]
encoder_signs = [1, -1]
homing_joint_angles_rad = [2.0, 0.5]
analog_output_channels = [3, 4]
motor_signs = [-1, 1]
amplifier_gain_A_per_V = 0.25
output_voltage_limit_V = 5.0
watchdog_timeout_s = 0.01

[force_sensor]
calibration_file = "sensors/FT12345.cal"
calibration_index = 2
physical_channels = "PXI1Slot2/ai0, PXI1Slot2/ai1:4, PXI1Slot2/ai5"
terminal_config = "DIFF"
voltage_range_V = 10.0
sample_rate_Hz = 1000.0
tare_samples = 100
saturation_V = 9.5
read_timeout_s = 0.02
mounting_offset_rad = 0.1
"""


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "robot.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _load_with(tmp_path: Path, key: str, value: str):
    """GOOD with `key = value` replaced (the key's line must exist)."""
    lines = GOOD.splitlines()
    hits = [i for i, line in enumerate(lines) if line.split("=")[0].strip() == key]
    assert len(hits) == 1, key
    lines[hits[0]] = f"{key} = {value}"
    return load_hardware_settings(_write(tmp_path, "\n".join(lines)))


def test_the_example_file_loads_with_the_documented_values():
    settings = load_hardware_settings(EXAMPLE)
    q, f = settings.quanser, settings.force_sensor
    assert settings.source == str(EXAMPLE)
    assert (q.board_type, q.board_identifier) == ("q8_usb", "0")
    assert (q.encoder_channels, q.analog_output_channels) == ((0, 1), (0, 1))
    assert q.homing_joint_angles_rad == pytest.approx((math.radians(120), math.radians(30)))
    assert q.watchdog_timeout_s == 0.02
    assert f.physical_channels == "Dev1/ai0:5"
    assert (f.terminal_config, f.voltage_range_V) == ("DIFF", 10.0)
    assert Path(f.calibration_file) == EXAMPLE.parent / "FT00000.cal"


def test_every_key_of_the_example_is_documented_by_a_comment_above_it():
    lines = EXAMPLE.read_text(encoding="utf-8").splitlines()
    keys = [i for i, line in enumerate(lines) if line and line[0].isalpha()]
    assert len(keys) == 23
    for i in keys:
        assert lines[i - 1].startswith("#"), lines[i]


def test_a_complete_file_loads_every_value(tmp_path):
    s = load_hardware_settings(_write(tmp_path, GOOD))
    q, f = s.quanser, s.force_sensor
    assert (q.board_type, q.board_identifier, q.card_options) == ("q8", "1", "")
    assert (q.encoder_channels, q.encoder_signs) == ((2, 5), (1, -1))
    assert (q.analog_output_channels, q.motor_signs) == ((3, 4), (-1, 1))
    assert q.homing_joint_angles_rad == (2.0, 0.5)
    assert (q.amplifier_gain_A_per_V, q.output_voltage_limit_V, q.watchdog_timeout_s) == (
        0.25, 5.0, 0.01,
    )
    assert f.calibration_file == str(tmp_path / "sensors" / "FT12345.cal")
    assert (f.calibration_index, f.tare_samples, f.sample_rate_Hz) == (2, 100, 1000.0)
    assert (f.saturation_V, f.read_timeout_s, f.mounting_offset_rad) == (9.5, 0.02, 0.1)


def test_defaults_fill_optional_keys_and_absolute_calibration_path_is_kept(tmp_path):
    cal = tmp_path / "elsewhere" / "FT1.cal"
    text = (
        "[robot]\nname = 'R1'\n[quanser]\nhoming_joint_angles_rad = [2.0, 0.5]\n"
        "amplifier_gain_A_per_V = 0.5\n"
        f"[force_sensor]\ncalibration_file = '{cal}'\n"
    )
    s = load_hardware_settings(_write(tmp_path, text))
    assert s.quanser == QuanserSettings(homing_joint_angles_rad=(2.0, 0.5),
                                        amplifier_gain_A_per_V=0.5)
    assert s.force_sensor == ForceSensorSettings(calibration_file=str(cal))


@pytest.mark.parametrize(
    ("key", "value", "fragment"),
    [
        ("board_type", '"q4"', "'q8_usb' or 'q8'"),
        ("board_type", "8", "'q8_usb' or 'q8'"),
        ("board_identifier", "0", "a string such as"),
        ("board_identifier", '"first"', "a string such as"),
        ("card_options", "1", "a string (may be empty)"),
        ("encoder_channels", "[0, 8]", "from 0 to 7"),
        ("encoder_channels", "[1, 1]", "two different channels"),
        ("encoder_channels", "[0]", "a list of two values"),
        ("encoder_channels", "[0.0, 1]", "a whole number"),
        ("encoder_signs", "[1, 0]", "+1 or -1"),
        ("encoder_signs", "[true, 1]", "+1 or -1"),
        ("homing_joint_angles_rad", "[0.5, 2.0]", "θ_R1 − θ_R2 between 0 and π"),
        ("homing_joint_angles_rad", "[120, 30]", "a number in [-6.28319, 6.28319] rad"),
        ("homing_joint_angles_rad", '["a", 0]', "a number in"),
        ("homing_joint_angles_rad", "[nan, 0.5]", "a number in"),
        ("analog_output_channels", "[-1, 0]", "from 0 to 7"),
        ("motor_signs", "[2, 1]", "+1 or -1"),
        ("amplifier_gain_A_per_V", "0", "a number in (0, 10] A/V"),
        ("amplifier_gain_A_per_V", "inf", "a number in (0, 10] A/V"),
        ("output_voltage_limit_V", "12.0", "(0, 10] V"),
        ("watchdog_timeout_s", "0.001", "[0.004, 0.5] s"),
        ("watchdog_timeout_s", "2.0", "[0.004, 0.5] s"),
        ("calibration_file", '""', "a non-empty string"),
        ("physical_channels", '"Dev1/ai0:4"', "exactly 6 channels"),
        ("physical_channels", '"Dev1/port0"', 'NI channel names such as "Dev1/ai0:5"'),
        ("tare_samples", "1", "allowed: at least 100 at 1000 Hz (the zero would last 0.001 s"),
        ("tare_samples", "99", "allowed: at least 100 at 1000 Hz (the zero would last 0.099 s"),
        ("physical_channels", '"Dev1/ai0:2, Dev1/ai2:4"', "named twice: Dev1/ai2;"),
        ("physical_channels", '"Dev1/ai0:2, Dev1/ai0:2"', "named twice: Dev1/ai0, Dev1/ai1"),
        ("terminal_config", '"diff"', "'DIFF'"),
        ("voltage_range_V", "20.0", "(0, 10] V"),
        ("sample_rate_Hz", "100.0", "[500, 50000] Hz"),
        ("calibration_index", "0", "from 1 to 99"),
        ("mounting_offset_rad", "4.0", "[-3.14159, 3.14159] rad"),
        ("tare_samples", "0", "from 1 to 100000"),
        ("tare_samples", "6000", "the tare would take 6 s"),
        ("read_timeout_s", "0.0", "[0.001, 1] s"),
        ("saturation_V", "10.5", "(0, 10] V"),
    ],
)
def test_each_bad_value_is_refused_naming_file_section_and_key(tmp_path, key, value, fragment):
    with pytest.raises(HardwareSettingsError) as info:
        _load_with(tmp_path, key, value)
    text = str(info.value)
    assert str(tmp_path / "robot.toml") in text
    section = "[force_sensor]" if key in ForceSensorSettings.__dataclass_fields__ else "[quanser]"
    assert f"{section} {key}" in text
    assert fragment in text
    assert "Correct the file" in text
    assert isinstance(info.value, BackendError)


def test_saturation_cannot_exceed_the_input_range(tmp_path):
    text = GOOD.replace("voltage_range_V = 10.0", "voltage_range_V = 5.0")
    with pytest.raises(HardwareSettingsError, match=r"saturation_V = 9.5 .* \(0, 5\] V"):
        load_hardware_settings(_write(tmp_path, text))


def test_unknown_key_is_refused_with_the_known_ones(tmp_path):
    text = GOOD.replace("amplifier_gain_A_per_V", "amplifer_gain_A_per_V")
    with pytest.raises(HardwareSettingsError, match=r"unknown key.*amplifer_gain_A_per_V") as info:
        load_hardware_settings(_write(tmp_path, text))
    assert "amplifier_gain_A_per_V" in str(info.value).split("known keys are")[1]


def test_missing_required_key_is_named(tmp_path):
    text = "\n".join(line for line in GOOD.splitlines() if not line.startswith("homing"))
    with pytest.raises(HardwareSettingsError, match=r"\[quanser\] is missing "
                                                    r"homing_joint_angles_rad"):
        load_hardware_settings(_write(tmp_path, text))


def test_missing_table_unknown_table_bad_toml_and_missing_file(tmp_path):
    force_only = '[robot]\nname = "R"\n' + GOOD[GOOD.index("[force_sensor]"):]
    with pytest.raises(HardwareSettingsError, match=r"the \[quanser\] table is missing"):
        load_hardware_settings(_write(tmp_path, force_only))
    with pytest.raises(HardwareSettingsError, match="top level: amplifier"):
        load_hardware_settings(_write(tmp_path, GOOD + "\n[amplifier]\ngain = 1\n"))
    with pytest.raises(HardwareSettingsError, match=r"not valid TOML .*line 3"):
        load_hardware_settings(_write(tmp_path, "[quanser]\nboard_type = 'q8'\nx = = 1\n"))
    with pytest.raises(HardwareSettingsError, match=r"does not exist\. Copy resources/hardware"):
        load_hardware_settings(tmp_path / "nope.toml")


def test_settings_built_in_code_are_checked_too():
    with pytest.raises(HardwareSettingsError, match=r"QuanserSettings: \[quanser\] motor_signs"):
        QuanserSettings(homing_joint_angles_rad=(2.0, 0.5), amplifier_gain_A_per_V=0.5,
                        motor_signs=(1, 3))
    with pytest.raises(HardwareSettingsError,
                       match=r"ForceSensorSettings: \[force_sensor\] physical_channels"):
        ForceSensorSettings(calibration_file="a.cal", physical_channels="Dev1/ai0:6")
    q = QuanserSettings(homing_joint_angles_rad=[2, 0], amplifier_gain_A_per_V=1)  # type: ignore[arg-type]
    assert q.homing_joint_angles_rad == (2.0, 0.0)
    assert isinstance(q.amplifier_gain_A_per_V, float)


@pytest.mark.parametrize(
    ("spec", "count"),
    [("Dev1/ai0:5", 6), ("Dev1/ai5:0", 6), ("Dev1/ai3", 1),
     ("Dev1/ai0, Dev1/ai2:3,Dev2/ai7", 4), ("cDAQ1Mod1/ai0:5", 6)],
)
def test_count_physical_channels(spec, count):
    assert count_physical_channels(spec) == count


@pytest.mark.parametrize("spec", ["Dev1", "Dev1/ao0", "Dev1/ai0-5", "", "Dev1/ai0,"])
def test_count_physical_channels_refuses_other_syntax(spec):
    with pytest.raises(ValueError):  # noqa: PT011 - the message is the offending item
        count_physical_channels(spec)


@pytest.mark.parametrize(("encoding", "fragment"), [
    ("utf-16", "it was saved as UTF-16 (Unicode)"),
    ("cp1252", "it was saved in another encoding (line 1)"),
])
def test_a_file_saved_in_another_encoding_is_refused_in_one_line(tmp_path, encoding, fragment):
    """Notepad's "Unicode" and "ANSI" (an accent in a comment) escaped as a bare
    UnicodeDecodeError: the Connect said "'utf-8' codec can't decode byte 0xff"."""
    path = tmp_path / "robot.toml"
    path.write_bytes(("# réglage du robot\n" + GOOD).encode(encoding))
    with pytest.raises(HardwareSettingsError) as caught:
        load_hardware_settings(path)
    assert str(caught.value) == (
        f"hardware settings file {path} is not UTF-8 text: {fragment}. Save it as UTF-8 "
        "(in Notepad: Save as, Encoding UTF-8) and connect again.")


def test_a_byte_order_mark_is_read_past(tmp_path):
    """Notepad writes one before UTF-8 text; tomllib refused it as "Invalid statement
    (at line 1, column 1)"."""
    path = tmp_path / "robot.toml"
    path.write_bytes(b"\xef\xbb\xbf" + GOOD.encode())
    assert load_hardware_settings(path).quanser.board_type == "q8"


@pytest.mark.parametrize("kind", ["fifo", "device", "folder", "oversize"])
def test_a_file_that_is_not_a_small_plain_file_is_refused_at_once(tmp_path, kind):
    """path.read_bytes() on a pipe waited for a writer forever (the Connect hung), on
    /dev/zero until memory ran out: the checked read refuses each in one line."""
    import os
    path = tmp_path / "robot.toml"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "device":
        path = Path("/dev/zero")
    elif kind == "folder":
        path.mkdir()
    else:
        path.write_bytes(b"# " + b"x" * (2 << 20) + b"\n" + GOOD.encode())
    with pytest.raises(HardwareSettingsError) as caught:
        load_hardware_settings(path)
    message = str(caught.value)
    assert message.startswith(f"hardware settings file {path} ")
    assert "\n" not in message
    assert {"fifo": "not a plain file", "device": "not a plain file", "folder": "is a folder",
            "oversize": "more than such a file can be"}[kind] in message


def test_the_robot_is_named_as_on_its_label(tmp_path):
    """Every Quanser station's trials were "quanser", so a learned model of one robot passed
    the Build of another: the file names its robot, and that name is checked."""
    assert load_hardware_settings(_write(tmp_path, GOOD)).robot.name == "Lab robot #2"
    assert load_hardware_settings(EXAMPLE).robot.name == "rehab-robot-1"


def test_a_file_without_the_robot_table_says_what_to_add(tmp_path):
    """A file written before robots were named: one line naming the table and why."""
    without = GOOD.replace('[robot]\nname = "Lab robot #2"\n', "")
    with pytest.raises(HardwareSettingsError) as caught:
        load_hardware_settings(_write(tmp_path, without))
    text = str(caught.value)
    assert "the [robot] table is missing" in text
    assert "serial number" in text
    assert "learned model" in text
    with pytest.raises(HardwareSettingsError, match=r"\[robot\] is missing name"):
        load_hardware_settings(_write(tmp_path, GOOD.replace('name = "Lab robot #2"', "")))
    with pytest.raises(HardwareSettingsError, match=r"\[robot\] has unknown key\(s\) serial"):
        load_hardware_settings(_write(tmp_path, GOOD.replace('name = "Lab robot #2"',
                                                             'name = "A"\nserial = "1"')))


@pytest.mark.parametrize("name", ['""', '" R1"', '"R1 "', '"R1\\n"', '"a/b"', "7",
                                  '"' + "x" * 65 + '"', '"Robot ü"'])
def test_a_robot_name_that_would_not_read_the_same_everywhere_is_refused(tmp_path, name):
    with pytest.raises(HardwareSettingsError, match=r"\[robot\] name = .* is not allowed"):
        load_hardware_settings(_write(tmp_path, GOOD.replace('"Lab robot #2"', name)))
