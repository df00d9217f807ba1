"""ATI F/T calibration files (`.cal`, XML, CalFileVersion 1.0 and 1.1).

A DAQ-family ATI sensor (our Nano25) outputs six strain-gauge voltages G0..G5;
its calibration file holds the 6×6 matrix that turns them into forces and
torques:

    ft = M · (v − v_bias)            (ATIDAQ `ConvertToFT`, v_bias from `Bias`)

Where the matrix comes from
---------------------------
* Version 1.1 files carry six `UserAxis` rows: that *is* M, in the file's
  `ForceUnits` / `TorqueUnits` per volt. ATI's own header says to build the
  matrix from them, so we use them whenever they are present.
* Version 1.0 files have only the six `Axis` rows (`values` divided by `scale`)
  and a `BasicTransform` (Dx Dy Dz Rx Ry Rz). The working matrix is then

      M = TTM(BasicTransform) · (Axis.values / Axis.scale)

  exactly as ATIDAQ's `GetMatrix()` computes it with no user tool transform;
  `tool_transform_matrix` below is its `TTM()`. Checked here against the
  UserAxis rows of a v1.1 file (tests/device/test_atical.py).

Everything we return is in SI: rows Fx, Fy, Fz in N per volt and Tx, Ty, Tz in
N·m per volt, whatever units the file uses; the `max` attributes become the
rated range of each axis in N and N·m.

Software temperature compensation (`BiasSlope`/`GainSlope`/`Thermistor`) needs
a seventh (thermistor) channel that our wiring does not read; a file that offers
it is still accepted (the Nano25's compensation is in hardware, `HWTempComp`),
and `software_temp_comp_available` says so for the log.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from device.errors import BackendError

AXIS_NAMES: tuple[str, ...] = ("Fx", "Fy", "Fz", "Tx", "Ty", "Tz")
NUM_GAUGES = 6

# Unit names as ATIDAQ's ForceConv/TorqueConv/DistConv/AngleConv accept them,
# converted to SI (1 lbf = 4.4482216152605 N, 1 in = 0.0254 m, g_n = 9.80665 m/s²).
_LBF_N = 4.4482216152605
_KGF_N = 9.80665
FORCE_UNITS_TO_N: dict[str, float] = {
    "lb": _LBF_N, "lbf": _LBF_N,
    "klb": 1000.0 * _LBF_N, "klbf": 1000.0 * _LBF_N,
    "N": 1.0, "kN": 1000.0,
    "kg": _KGF_N, "g": _KGF_N / 1000.0,
}
TORQUE_UNITS_TO_NM: dict[str, float] = {
    "in-lb": _LBF_N * 0.0254, "in-lbf": _LBF_N * 0.0254,
    "lb-in": _LBF_N * 0.0254, "lbf-in": _LBF_N * 0.0254,
    "ft-lb": _LBF_N * 0.3048, "lb-ft": _LBF_N * 0.3048,
    "ft-lbf": _LBF_N * 0.3048, "lbf-ft": _LBF_N * 0.3048,
    "N-m": 1.0, "Nm": 1.0,
    "N-mm": 1e-3, "Nmm": 1e-3,
    "kg-cm": _KGF_N * 0.01, "kgcm": _KGF_N * 0.01,
    "kN-m": 1000.0, "kNm": 1000.0,
}
DIST_UNITS_TO_M: dict[str, float] = {"in": 0.0254, "m": 1.0, "cm": 0.01, "mm": 1e-3, "ft": 0.3048}
ANGLE_UNITS_TO_RAD: dict[str, float] = {
    "deg": math.pi / 180.0, "degrees": math.pi / 180.0, "degree": math.pi / 180.0,
    "rad": 1.0, "radians": 1.0, "radian": 1.0,
}

_FIX = (
    "Use the .cal file ATI shipped with this sensor (its serial number is engraved on the "
    "transducer); ask ATI for a copy if it is lost or damaged."
)


class CalibrationFileError(BackendError):
    """An ATI calibration file is missing, malformed, or not for a 6-gauge DAQ sensor."""


@dataclass(frozen=True, slots=True, eq=False)
class AtiCalibration:
    """One calibration of an ATI DAQ F/T sensor, converted to SI.

    `matrix_SI` (6×6, read-only) maps gauge volts G0..G5 to (Fx, Fy, Fz) in N and
    (Tx, Ty, Tz) in N·m; `max_loads_SI` are the rated ranges of the same axes.
    `output_half_range_V` is the sensor electronics' output span (±10 V for
    OutputRange="20" bipolar).
    """

    path: str
    serial: str
    body_style: str
    part_number: str
    cal_date: str
    file_version: str
    force_units: str
    torque_units: str
    matrix_SI: np.ndarray
    max_loads_SI: tuple[float, float, float, float, float, float]
    from_user_axis: bool
    output_half_range_V: float
    software_temp_comp_available: bool

    def convert(self, volts_minus_bias: np.ndarray) -> np.ndarray:
        """Forces and torques (N, N·m) for tared gauge voltages: M · (v − v_bias)."""
        return self.matrix_SI @ np.asarray(volts_minus_bias, dtype=np.float64)


def tool_transform_matrix(
    dx_m: float, dy_m: float, dz_m: float, rx_rad: float, ry_rad: float, rz_rad: float
) -> np.ndarray:
    """The 6×6 force/torque transform of a tool frame, in SI (ATIDAQ `TTM()`).

    With the tool frame displaced by d and rotated by R: F' = R F and
    T' = R (T + F × d). The terms are laid out as in ATIDAQ so a v1.0 file gives
    the matrix ATI's library gives. R is ATIDAQ's change of frame for the angles
    Rx, Ry, Rz, so a pure Rz = +90° reports the old Fy as the new Fx.
    """
    sx, cx = math.sin(rx_rad), math.cos(rx_rad)
    sy, cy = math.sin(ry_rad), math.cos(ry_rad)
    sz, cz = math.sin(rz_rad), math.cos(rz_rad)
    r = np.array(
        [
            [cy * cz, sx * sy * cz + cx * sz, sx * sz - cx * sy * cz],
            [-cy * sz, -sx * sy * sz + cx * cz, sx * cz + cx * sy * sz],
            [sy, -sx * cy, cx * cy],
        ]
    )
    dx, dy, dz = dx_m, dy_m, dz_m
    result = np.zeros((6, 6))
    result[0:3, 0:3] = r
    result[3:6, 3:6] = r
    for i in range(3):
        result[3 + i, 0] = r[i, 2] * dy - r[i, 1] * dz
        result[3 + i, 1] = r[i, 0] * dz - r[i, 2] * dx
        result[3 + i, 2] = r[i, 1] * dx - r[i, 0] * dy
    return result


def load_calibration(path: str | Path, index: int = 1) -> AtiCalibration:
    """Read calibration number `index` (1-based, as ATIDAQ counts) from an ATI .cal file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise CalibrationFileError(
            f"ATI calibration file {path} does not exist. Copy the sensor's .cal file there "
            f"or correct [force_sensor] calibration_file in the hardware settings. {_FIX}"
        ) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CalibrationFileError(
            f"ATI calibration file {path} cannot be read ({exc}). {_FIX}"
        ) from exc
    return parse_calibration(text, str(path), index)


def parse_calibration(text: str, source: str = "<text>", index: int = 1) -> AtiCalibration:
    """Parse the XML text of an ATI .cal file; `source` names it in error messages."""
    where = f"ATI calibration file {source}"
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise CalibrationFileError(f"{where} is not well-formed XML ({exc}). {_FIX}") from None
    if root.tag != "FTSensor":
        raise CalibrationFileError(
            f"{where}: the root element is <{root.tag}>, not <FTSensor>; this is not an ATI "
            f"F/T calibration file. {_FIX}"
        )
    num_gauges = _int_attr(root, "NumGages", where)
    if num_gauges != NUM_GAUGES:
        raise CalibrationFileError(
            f"{where}: <FTSensor NumGages=\"{num_gauges}\"> but the Nano25 backend reads "
            f"{NUM_GAUGES} gauges (G0..G5). Is this the file of another sensor? {_FIX}"
        )
    family = root.get("Family", "")
    if family and family != "DAQ":
        raise CalibrationFileError(
            f"{where}: <FTSensor Family=\"{family}\"> is not a DAQ (analog voltage) sensor; "
            f"this backend reads gauge voltages through an NI card. {_FIX}"
        )
    calibrations = root.findall("Calibration")
    if not calibrations:
        raise CalibrationFileError(f"{where}: no <Calibration> element. {_FIX}")
    if not 1 <= index <= len(calibrations):
        raise CalibrationFileError(
            f"{where}: calibration index {index} requested but the file holds "
            f"{len(calibrations)} <Calibration> element(s); set [force_sensor] "
            f"calibration_index between 1 and {len(calibrations)}."
        )
    cal = calibrations[index - 1]
    cal_where = f"{where}, <Calibration> #{index}"

    force_units = _required(cal, "ForceUnits", cal_where)
    torque_units = _required(cal, "TorqueUnits", cal_where)
    force_factor = _unit(FORCE_UNITS_TO_N, force_units, "ForceUnits", cal_where)
    torque_factor = _unit(TORQUE_UNITS_TO_NM, torque_units, "TorqueUnits", cal_where)
    row_factor = np.array([force_factor] * 3 + [torque_factor] * 3)

    user_rows = _axis_rows(cal, "UserAxis", cal_where, scaled=False)
    if user_rows is not None:
        rows, maxima = user_rows
        matrix_SI = rows * row_factor[:, None]
        from_user_axis = True
    else:
        basic_rows = _axis_rows(cal, "Axis", cal_where, scaled=True)
        if basic_rows is None:
            raise CalibrationFileError(
                f"{cal_where}: neither <UserAxis> nor <Axis> rows; there is no matrix. {_FIX}"
            )
        rows, maxima = basic_rows
        # ATIDAQ applies the transform in the file's units and converts after; scaling
        # the rows to SI first and taking the distances in metres gives the same matrix.
        transform = _basic_transform(cal, cal_where)
        matrix_SI = transform @ (rows * row_factor[:, None])
        from_user_axis = False
    matrix_SI.setflags(write=False)
    max_SI = tuple(float(m * f) for m, f in zip(maxima, row_factor, strict=True))

    output_range = _float_attr(cal, "OutputRange", cal_where, default=20.0)
    bipolar = cal.get("OutputBipolar", "True").strip().lower() != "false"
    half_range = output_range / 2.0 if bipolar else output_range
    temp_comp = any(cal.find(tag) is not None for tag in ("BiasSlope", "GainSlope"))

    return AtiCalibration(
        path=source,
        serial=root.get("Serial", ""),
        body_style=root.get("BodyStyle", ""),
        part_number=cal.get("PartNumber", ""),
        cal_date=cal.get("CalDate", ""),
        file_version=root.get("CalFileVersion", "1.0"),
        force_units=force_units,
        torque_units=torque_units,
        matrix_SI=matrix_SI,
        max_loads_SI=max_SI,  # type: ignore[arg-type]
        from_user_axis=from_user_axis,
        output_half_range_V=half_range,
        software_temp_comp_available=temp_comp,
    )


def _axis_rows(
    cal: ET.Element, tag: str, where: str, *, scaled: bool
) -> tuple[np.ndarray, list[float]] | None:
    """The six rows of `tag` ordered Fx..Tz (values, or values/scale), and their `max`."""
    elements = cal.findall(tag)
    if not elements:
        return None
    by_name: dict[str, ET.Element] = {}
    for element in elements:
        name = element.get("Name")
        if name not in AXIS_NAMES:
            raise CalibrationFileError(
                f"{where}: <{tag} Name=\"{name}\"> is not one of {', '.join(AXIS_NAMES)}. {_FIX}"
            )
        if name in by_name:
            raise CalibrationFileError(f"{where}: <{tag} Name=\"{name}\"> appears twice. {_FIX}")
        by_name[name] = element
    missing = [name for name in AXIS_NAMES if name not in by_name]
    if missing:
        raise CalibrationFileError(
            f"{where}: <{tag}> rows for {', '.join(missing)} are missing; a 6-axis "
            f"calibration needs all of {', '.join(AXIS_NAMES)}. {_FIX}"
        )
    rows = np.zeros((6, NUM_GAUGES))
    maxima: list[float] = []
    for i, name in enumerate(AXIS_NAMES):
        element = by_name[name]
        row_where = f"{where}, <{tag} Name=\"{name}\">"
        values_text = element.get("values")
        if values_text is None:
            raise CalibrationFileError(f"{row_where} has no 'values' attribute. {_FIX}")
        try:
            values = [float(word) for word in values_text.split()]
        except ValueError:
            raise CalibrationFileError(
                f"{row_where}: values=\"{values_text.strip()}\" is not a list of numbers. {_FIX}"
            ) from None
        if len(values) != NUM_GAUGES:
            raise CalibrationFileError(
                f"{row_where}: {len(values)} values, expected one per gauge ({NUM_GAUGES}). "
                f"{_FIX}"
            )
        if not all(math.isfinite(v) for v in values):
            raise CalibrationFileError(f"{row_where}: values contain NaN or infinity. {_FIX}")
        scale = _float_attr(element, "scale", row_where, default=1.0) if scaled else 1.0
        if scale == 0.0:
            raise CalibrationFileError(f"{row_where}: scale=\"0\" cannot divide. {_FIX}")
        rows[i] = np.array(values) / scale
        maximum = _float_attr(element, "max", row_where, default=0.0)
        if maximum < 0.0:
            raise CalibrationFileError(f"{row_where}: max=\"{maximum:g}\" is negative. {_FIX}")
        maxima.append(maximum)
    return rows, maxima


def _basic_transform(cal: ET.Element, where: str) -> np.ndarray:
    """TTM of the file's BasicTransform, in SI (identity when the element is absent)."""
    element = cal.find("BasicTransform")
    if element is None:
        return np.eye(6)
    dist_units = _required(cal, "DistUnits", where)
    dist = _unit(DIST_UNITS_TO_M, dist_units, "DistUnits", where)
    angle_units = cal.get("AngleUnits", "degrees")
    angle = _unit(ANGLE_UNITS_TO_RAD, angle_units, "AngleUnits", where)
    tt_where = f"{where}, <BasicTransform>"
    d = [_float_attr(element, key, tt_where, default=0.0) * dist for key in ("Dx", "Dy", "Dz")]
    r = [_float_attr(element, key, tt_where, default=0.0) * angle for key in ("Rx", "Ry", "Rz")]
    return tool_transform_matrix(d[0], d[1], d[2], r[0], r[1], r[2])


def _required(element: ET.Element, name: str, where: str) -> str:
    value = element.get(name)
    if value is None or not value.strip():
        raise CalibrationFileError(f"{where}: attribute {name} is missing. {_FIX}")
    return value.strip()


def _unit(table: dict[str, float], units: str, attribute: str, where: str) -> float:
    try:
        return table[units]
    except KeyError:
        raise CalibrationFileError(
            f"{where}: {attribute}=\"{units}\" is not a unit ATI's library knows "
            f"({', '.join(table)}). {_FIX}"
        ) from None


def _float_attr(element: ET.Element, name: str, where: str, *, default: float) -> float:
    text = element.get(name)
    if text is None or not text.strip():
        return default
    try:
        value = float(text)
    except ValueError:
        raise CalibrationFileError(f"{where}: {name}=\"{text}\" is not a number. {_FIX}") from None
    if not math.isfinite(value):
        raise CalibrationFileError(f"{where}: {name}=\"{text}\" is not finite. {_FIX}")
    return value


def _int_attr(element: ET.Element, name: str, where: str) -> int:
    text = element.get(name)
    if text is None:
        raise CalibrationFileError(f"{where}: <{element.tag}> has no {name} attribute. {_FIX}")
    try:
        return int(text)
    except ValueError:
        raise CalibrationFileError(
            f"{where}: {name}=\"{text}\" is not a whole number. {_FIX}"
        ) from None
