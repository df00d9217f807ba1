"""ATI .cal parsing: UserAxis (v1.1), the computed matrix (v1.0), units, ranges, bad files."""

import math
from pathlib import Path

import numpy as np
import pytest

from device.errors import BackendError
from device.hardware.atical import (
    FORCE_UNITS_TO_N,
    TORQUE_UNITS_TO_NM,
    CalibrationFileError,
    load_calibration,
    parse_calibration,
    tool_transform_matrix,
)

DATA = Path(__file__).parent / "data"
V11 = DATA / "FT00000_Nano25_v11.cal"
V10 = DATA / "FT00000_Nano25_v10.cal"

LBF_N = 4.4482216152605
LBIN_NM = LBF_N * 0.0254


def _row_scaled(cal_matrix: np.ndarray) -> np.ndarray:
    """Each row divided by its largest entry, to compare rows of very different sizes."""
    return cal_matrix / np.abs(cal_matrix).max(axis=1, keepdims=True)


def test_v11_file_uses_the_user_axis_rows_converted_to_si():
    cal = load_calibration(V11)
    assert cal.from_user_axis
    assert (cal.serial, cal.body_style, cal.part_number, cal.file_version) == (
        "FT00000", "Nano25", "SI-250-6", "1.1",
    )
    # The UserAxis rows of the file, in N/V and N-mm/V.
    fx = [0.21000, -0.34999, 1.62000, -52.40000, -1.04999, 53.10000]
    tz = [3.30002, -332.79998, -7.70000, -321.30004, 22.40002, -320.80004]
    np.testing.assert_allclose(cal.matrix_SI[0], fx, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cal.matrix_SI[5], np.array(tz) * 1e-3, rtol=0, atol=1e-12)
    assert cal.max_loads_SI == pytest.approx((250.0, 250.0, 1000.0, 6.0, 6.0, 3.4))
    assert cal.output_half_range_V == 10.0
    assert not cal.software_temp_comp_available


def test_v10_matrix_matches_a_hand_computation_from_axis_scale_and_basic_transform():
    cal = load_calibration(V10)
    assert not cal.from_user_axis
    # Axis values / scale of the file (lb/V and lb-in/V), converted to SI by hand.
    force_scale, torque_scale = 2.74925384122133, 8.40793412262391
    fx = np.array([0.12979, -0.21632, 1.00125, -32.38618, -0.64896, 32.81882]) / force_scale
    fy = np.array([-0.67986, 37.82508, 0.45736, -18.72712, 0.29667, -19.09796]) / force_scale
    tx = np.array([0.60091, -64.46700, 34.73129, 31.78886, -35.99674, 32.19443]) / torque_scale
    ty = np.array([-39.37358, -1.31252, 21.58115, -53.88498, 17.79949, 53.79382]) / torque_scale
    fx, fy, tx, ty = fx * LBF_N, fy * LBF_N, tx * LBIN_NM, ty * LBIN_NM
    dz = 0.2066929 * 0.0254  # BasicTransform Dz in inches -> m
    # Torques about the displaced origin: T' = T + F × d with d = (0, 0, dz):
    # Tx' = Tx + Fy·dz, Ty' = Ty − Fx·dz; forces unchanged.
    np.testing.assert_allclose(cal.matrix_SI[0], fx, rtol=1e-12)
    np.testing.assert_allclose(cal.matrix_SI[1], fy, rtol=1e-12)
    np.testing.assert_allclose(cal.matrix_SI[3], tx + fy * dz, rtol=1e-12)
    np.testing.assert_allclose(cal.matrix_SI[4], ty - fx * dz, rtol=1e-12)
    assert cal.max_loads_SI[0] == pytest.approx(56.2 * LBF_N)
    assert cal.max_loads_SI[3] == pytest.approx(53.1 * LBIN_NM)


def test_v10_and_v11_files_of_the_same_sensor_in_other_units_agree():
    """The v1.0 file states the same sensor in lb, lb-in and in; computed from its Axis rows
    it must give the v1.1 file's UserAxis matrix (both rounded to 5 digits in the files)."""
    a = load_calibration(V11).matrix_SI
    b = load_calibration(V10).matrix_SI
    np.testing.assert_allclose(_row_scaled(b), _row_scaled(a), rtol=0, atol=1e-5)


def test_user_axis_equals_the_matrix_computed_from_axis_rows():
    """ATI's v1.1 UserAxis = TTM(BasicTransform) · Axis/scale: dropping the UserAxis rows
    from the file must give the same matrix, computed."""
    text = V11.read_text()
    without = "\n".join(line for line in text.splitlines() if "<UserAxis" not in line)
    given = parse_calibration(text).matrix_SI
    computed = parse_calibration(without).matrix_SI
    assert not parse_calibration(without).from_user_axis
    np.testing.assert_allclose(_row_scaled(computed), _row_scaled(given), rtol=0, atol=5e-6)


def test_convert_is_matrix_times_tared_volts():
    cal = load_calibration(V11)
    dv = np.array([0.1, -0.2, 0.3, 0.05, -0.4, 0.25])
    np.testing.assert_allclose(cal.convert(dv), cal.matrix_SI @ dv)
    with pytest.raises(ValueError, match="read-only"):
        cal.matrix_SI[0, 0] = 1.0


def test_tool_transform_translation_adds_force_cross_offset():
    d = np.array([0.01, -0.02, 0.03])
    t = tool_transform_matrix(*d, 0.0, 0.0, 0.0)
    f, m = np.array([3.0, -4.0, 5.0]), np.array([0.1, 0.2, -0.3])
    out = t @ np.concatenate([f, m])
    np.testing.assert_allclose(out[:3], f)
    np.testing.assert_allclose(out[3:], m + np.cross(f, d))


def test_tool_transform_rotation_follows_atidaq_convention():
    """ATIDAQ's TTM rotates the frame: Rz = +90° reports the old Fy as Fx and −Fx as Fy."""
    t = tool_transform_matrix(0.0, 0.0, 0.0, 0.0, 0.0, math.pi / 2)
    out = t @ np.array([1.0, 2.0, 3.0, 0.4, 0.5, 0.6])
    np.testing.assert_allclose(out, [2.0, -1.0, 3.0, 0.5, -0.4, 0.6], atol=1e-15)
    rot = t[:3, :3]
    np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-15)


def test_angle_units_radians_in_basic_transform():
    text = V11.read_text()
    without = "\n".join(line for line in text.splitlines() if "<UserAxis" not in line)
    deg = without.replace('Rz="0"', 'Rz="90"')
    rad = without.replace('Rz="0"', f'Rz="{math.pi / 2!r}"').replace(
        'DistUnits="mm"', 'DistUnits="mm" AngleUnits="radians"'
    )
    a, b = parse_calibration(deg).matrix_SI, parse_calibration(rad).matrix_SI
    np.testing.assert_allclose(a, b, atol=1e-12)
    plain = parse_calibration(without).matrix_SI
    np.testing.assert_allclose(a[0], plain[1], atol=1e-12)  # Fx' = Fy


@pytest.mark.parametrize(
    ("units", "factor"),
    [("lb", LBF_N), ("klb", 1000 * LBF_N), ("kN", 1000.0), ("kg", 9.80665), ("g", 9.80665e-3)],
)
def test_force_units(units, factor):
    assert FORCE_UNITS_TO_N[units] == pytest.approx(factor)
    text = V11.read_text().replace('ForceUnits="N"', f'ForceUnits="{units}"')
    cal = parse_calibration(text)
    np.testing.assert_allclose(cal.matrix_SI[:3], load_calibration(V11).matrix_SI[:3] * factor)
    assert cal.max_loads_SI[2] == pytest.approx(1000.0 * factor)


@pytest.mark.parametrize(
    ("units", "factor"),
    [("N-m", 1.0), ("lb-in", LBIN_NM), ("lb-ft", LBF_N * 0.3048), ("kg-cm", 0.0980665)],
)
def test_torque_units(units, factor):
    assert TORQUE_UNITS_TO_NM[units] == pytest.approx(factor)
    text = V11.read_text().replace('TorqueUnits="N-mm"', f'TorqueUnits="{units}"')
    ref = load_calibration(V11).matrix_SI[3:] * 1e3  # the file's N-mm values
    np.testing.assert_allclose(parse_calibration(text).matrix_SI[3:], ref * factor)


def test_second_calibration_is_chosen_by_index():
    text = V11.read_text()
    start, end = text.index("\t<Calibration"), text.index("</Calibration>") + len("</Calibration>")
    block = text[start:end]
    second = block.replace('ForceUnits="N"', 'ForceUnits="kN"')
    doubled = text[:end] + "\n" + second + text[end:]
    one, two = parse_calibration(doubled, index=1), parse_calibration(doubled, index=2)
    np.testing.assert_allclose(two.matrix_SI[:3], one.matrix_SI[:3] * 1000.0)
    with pytest.raises(CalibrationFileError, match=r"index 3 .* holds 2 <Calibration>"):
        parse_calibration(doubled, index=3)


def _v11_with(old: str, new: str) -> str:
    text = V11.read_text()
    assert old in text
    return text.replace(old, new)


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("<FTSensor><Calibration>", "not well-formed XML"),
        ('<?xml version="1.0"?><Gauges NumGages="6"/>', "root element is <Gauges>"),
        (_v11_with('NumGages="6"', 'NumGages="5"'), 'NumGages="5"'),
        (_v11_with('NumGages="6"', 'NumGages="six"'), 'NumGages="six" is not a whole number'),
        (_v11_with('Family="DAQ"', 'Family="Net"'), 'Family="Net"'),
        (_v11_with('ForceUnits="N" ', ""), "ForceUnits is missing"),
        (_v11_with('TorqueUnits="N-mm"', 'TorqueUnits="furlong-N"'), 'TorqueUnits="furlong-N"'),
        (_v11_with('<UserAxis Name="Tz"', '<UserAxis Name="Qz"'), '<UserAxis Name="Qz">'),
        (_v11_with('<UserAxis Name="Ty"', '<UserAxis Name="Tz"'), "appears twice"),
        (_v11_with(' values="  0.21000', ' values="0.21000 x'), "not a list of numbers"),
        (_v11_with('values="  0.21000  -0.34999', 'values="-0.34999'), "5 values"),
        (_v11_with('values="  0.21000', 'values="nan'), "NaN or infinity"),
        (_v11_with('max="3400"/>\n', 'max="-1"/>\n'), 'max="-1" is negative'),
    ],
)
def test_malformed_files_are_refused_naming_file_and_element(text, fragment):
    with pytest.raises(CalibrationFileError, match=r"x\.cal") as info:
        parse_calibration(text, "x.cal")
    assert fragment in str(info.value)
    assert "ATI" in str(info.value)
    assert isinstance(info.value, BackendError)


def test_axis_rows_problems_in_a_v10_file():
    text = V10.read_text()
    with pytest.raises(CalibrationFileError, match=r'<Axis Name="Fx">: scale="0"'):
        parse_calibration(text.replace('scale="2.74925384122133"', 'scale="0"', 1), "v10.cal")
    with pytest.raises(CalibrationFileError, match=r'<Axis Name="Fz">: scale="abc"'):
        parse_calibration(text.replace('scale="5.68078917214631"', 'scale="abc"'), "v10.cal")
    no_rows = "\n".join(line for line in text.splitlines() if "<Axis" not in line)
    with pytest.raises(CalibrationFileError, match="neither <UserAxis> nor <Axis>"):
        parse_calibration(no_rows, "v10.cal")
    missing_fz = "\n".join(line for line in text.splitlines() if 'Name="Fz"' not in line)
    with pytest.raises(CalibrationFileError, match="rows for Fz are missing"):
        parse_calibration(missing_fz, "v10.cal")
    with pytest.raises(CalibrationFileError, match=r"<BasicTransform>: Dz=\"x\""):
        parse_calibration(text.replace('Dz="0.2066929"', 'Dz="x"'), "v10.cal")
    with pytest.raises(CalibrationFileError, match='DistUnits="yd"'):
        parse_calibration(text.replace('DistUnits="in"', 'DistUnits="yd"'), "v10.cal")


def test_no_calibration_element():
    with pytest.raises(CalibrationFileError, match="no <Calibration> element"):
        parse_calibration('<FTSensor NumGages="6" Family="DAQ"></FTSensor>', "empty.cal")


def test_missing_file_names_the_path_and_the_setting(tmp_path):
    path = tmp_path / "FT99999.cal"
    with pytest.raises(CalibrationFileError, match=r"FT99999\.cal does not exist") as info:
        load_calibration(path)
    assert "calibration_file" in str(info.value)


def test_software_temperature_compensation_is_reported(tmp_path):
    text = _v11_with("</Calibration>", '<BiasSlope values="0 0 0 0 0 0"/></Calibration>')
    assert parse_calibration(text).software_temp_comp_available


def test_unipolar_output_range():
    text = _v11_with('OutputBipolar="True"', 'OutputBipolar="False"').replace(
        'OutputRange="20"', 'OutputRange="10"'
    )
    assert parse_calibration(text).output_half_range_V == 10.0
    assert parse_calibration(_v11_with('OutputRange="20"', 'OutputRange="10"')) \
        .output_half_range_V == 5.0
