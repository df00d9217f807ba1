"""`rehab hardware check FILE`: a technician checks the robot's settings file before the
robot is powered, not at Connect with a session waiting (the bench check used a `python -c`
line): a good file prints what Connect would use, through the backend's own conversions; a
bad one is one line naming the key, exit 2."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from tests.app.cli.running import run

ROOT = Path(__file__).resolve().parents[3]
EXAMPLE = ROOT / "resources" / "hardware.example.toml"
CALIBRATION = ROOT / "tests" / "device" / "data" / "FT00000_Nano25_v11.cal"


@pytest.fixture
def settings(tmp_path):
    shutil.copy(CALIBRATION, tmp_path / "FT00000.cal")
    path = tmp_path / "robot.toml"
    shutil.copy(EXAMPLE, path)
    return path


def test_the_example_settings_are_printed_as_connect_would_use_them(settings, capsys):
    code, out, err = run(["hardware", "check", str(settings)], capsys)
    assert code == 0, err
    lines = out.splitlines()
    assert lines[0] == f"{settings}: the hardware settings are valid."
    assert lines[1].startswith("[robot] 'rehab-robot-1': every trial on it records this name")
    assert "76750 counts per joint turn" in out
    # the example's homing pose, where the handle stands at every Connect (docs/safety.md H8)
    assert ("θ_R1 120.0°, θ_R2 30.0° (links 90.0° apart), the handle at (8.1, 48) cm"
            in out)
    # 1 A ÷ 0.5 A/V, through the backend's own conversion
    assert "0.5 A/V: the rated 1 A (2.21 N·m at the joint) is 2.00 V" in out
    assert f"calibration: {settings.parent / 'FT00000.cal'}, calibration 1" in out
    assert "rated Fx 250 N, Fy 250 N, Fz 1000 N" in out
    assert "at most 200 N (80% of the sensor's 250 N in the plane); the default 50 N is " \
           "allowed" in out
    assert "500 samples (0.25 s)" in out


@pytest.mark.parametrize(("change", "said"), [
    (("amplifier_gain_A_per_V = 0.5", "amplifier_gain_A_per_V = -1"),
     "[quanser] amplifier_gain_A_per_V = -1 is not allowed"),
    (("encoder_signs = [1, 1]", "encoder_sings = [1, 1]"),
     "[quanser] has unknown key(s) encoder_sings"),
    (('calibration_file = "FT00000.cal"', 'calibration_file = "FT99999.cal"'),
     "FT99999.cal does not exist"),
])
def test_a_bad_file_is_one_line_naming_it_and_exit_2(settings, capsys, change, said):
    settings.write_text(settings.read_text(encoding="utf-8").replace(*change),
                        encoding="utf-8")
    code, out, err = run(["hardware", "check", str(settings)], capsys)
    assert code == 2
    assert out == ""
    assert len(err.strip().splitlines()) == 1
    assert said in err


def test_a_missing_file_is_one_line_and_exit_2(tmp_path, capsys):
    code, _, err = run(["hardware", "check", str(tmp_path / "none.toml")], capsys)
    assert code == 2
    assert "does not exist" in err
    assert len(err.strip().splitlines()) == 1
