"""Settings of the real robot's hardware: the Quanser Q8 card and the ATI Nano25 on an NI card.

They live in a TOML file (`resources/hardware.example.toml` documents every key)
because they describe one robot's wiring, not the software: which encoder and
analog-output channels drive which joint, which way each encoder counts, the
amplifier's gain, the NI device name, the sensor's calibration file.

Every value is checked when the file is loaded, and a bad one is refused with
the file, the `[section] key`, the value, what is allowed and why, so the
technician can fix the file without reading code. Keys the loader does not know
are refused too: a misspelt key would otherwise silently leave a default in place.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import MISSING, dataclass, fields
from pathlib import Path
from typing import Any

from device.backend import TARE_SPREAD_LIMIT_N
from device.errors import BackendError
from device.safeinput import InputRefused, read_bytes
from device.safewrite import OutputRefused

BOARD_TYPES = ("q8_usb", "q8")
"""HIL board types this backend supports: the Q8-USB and the legacy PCI Q8 (thesis §3.2.2)."""

TERMINAL_CONFIGS = ("DIFF", "RSE", "NRSE", "PSEUDO_DIFF")
"""Names of nidaqmx.constants.TerminalConfiguration members; the ATI outputs are differential."""

Q8_ENCODER_CHANNELS = 8
Q8_ANALOG_OUTPUT_CHANNELS = 8
FORCE_SENSOR_GAUGES = 6

MIN_TARE_S = 0.1
"""The shortest zero at Connect. A zero under load is told from the force's spread over
it (device.backend.tare_of); a hand moves it through its tremor and its grip, whose
physiological tremor is 8–12 Hz, so the zero must last at least about one period of it.
One sample has no spread at all: `tare_samples = 1` let any zero pass."""

_PHYSICAL_CHANNEL = re.compile(r"^\s*([A-Za-z0-9_\-]+)/ai(\d+)(?::(\d+))?\s*$")

ROBOT_NAME = re.compile(r"[A-Za-z0-9](?:[A-Za-z0-9 ._#-]{0,62}[A-Za-z0-9._#-])?")
"""A robot's name: its label or serial number as written on it, 1-64 letters, digits,
spaces, `. _ # -` (no space at either end): recorded in every trial it runs and in every
learned model of it, so it must read the same wherever it is printed."""


class HardwareSettingsError(BackendError):
    """The hardware settings file is missing, not valid TOML, or holds a refused value."""


def _fail(
    where: str, key: str, value: object, allowed: str, why: str = ""
) -> HardwareSettingsError:
    text = f"{where} {key} = {value!r} is not allowed; allowed: {allowed}"
    if why:
        text += f" ({why})"
    return HardwareSettingsError(text + ". Correct the file and connect again.")


# -- value checks: each returns the value normalised, or raises naming the key -------------------


def _string(
    where: str, key: str, value: object, choices: tuple[str, ...] = (), why: str = ""
) -> str:
    if not isinstance(value, str) or not value.strip():
        allowed = " or ".join(repr(c) for c in choices) if choices else "a non-empty string"
        raise _fail(where, key, value, allowed, why)
    if choices and value not in choices:
        raise _fail(where, key, value, " or ".join(repr(c) for c in choices), why)
    return value


def _check_robot_name(value: object, where: str) -> str:
    if not isinstance(value, str) or not ROBOT_NAME.fullmatch(value):
        raise _fail(where, "name", value, "1-64 letters, digits, spaces and . _ # -, as on "
                    "the robot's label", "the robot's own name or serial number: every trial "
                    "and every learned model of this robot records it")
    return value


def _number(
    where: str, key: str, value: object, low: float, high: float, unit: str, why: str = "",
    *, low_open: bool = False,
) -> float:
    bracket = "(" if low_open else "["
    allowed = f"a number in {bracket}{low:g}, {high:g}] {unit}".rstrip()
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _fail(where, key, value, allowed, why)
    number = float(value)
    below = number <= low if low_open else number < low
    if not math.isfinite(number) or below or number > high:
        raise _fail(where, key, value, allowed, why)
    return number


def _integer(where: str, key: str, value: object, low: int, high: int, why: str = "") -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise _fail(where, key, value, f"a whole number from {low} to {high}", why)
    return value


def _pair(where: str, key: str, value: object, item: Callable[[str, object], Any]) -> tuple:
    if not isinstance(value, list | tuple) or len(value) != 2:
        raise _fail(where, key, value, "a list of two values, joint 1 then joint 2")
    return (item(f"{key}[0]", value[0]), item(f"{key}[1]", value[1]))


def _channels(where: str, key: str, value: object, count: int, what: str) -> tuple[int, int]:
    pair = _pair(
        where, key, value,
        lambda k, v: _integer(where, k, v, 0, count - 1, f"the Q8 has {count} {what} channels"),
    )
    if pair[0] == pair[1]:
        raise _fail(where, key, value, "two different channels", "each joint needs its own")
    return pair


def _signs(where: str, key: str, value: object, why: str) -> tuple[int, int]:
    def sign(k: str, v: object) -> int:
        if isinstance(v, bool) or v not in (1, -1):
            raise _fail(where, k, v, "+1 or -1", why)
        return int(v)  # type: ignore[call-overload]

    return _pair(where, key, value, sign)


def physical_channel_list(spec: str) -> list[tuple[str, int]]:
    """The (device, analog input) pairs an NI physical-channel string names, in order.

    Accepts NI's list syntax as used for analog inputs: comma-separated items of
    "Dev1/ai0" or ranges "Dev1/ai0:5" (either direction). Raises ValueError on
    anything else.
    """
    channels: list[tuple[str, int]] = []
    for item in spec.split(","):
        match = _PHYSICAL_CHANNEL.match(item)
        if match is None:
            raise ValueError(item.strip())
        first = int(match.group(2))
        last = int(match.group(3)) if match.group(3) is not None else first
        step = 1 if last >= first else -1
        channels += [(match.group(1), n) for n in range(first, last + step, step)]
    return channels


def count_physical_channels(spec: str) -> int:
    """How many analog-input channels an NI physical-channel string names (see
    `physical_channel_list`)."""
    return len(physical_channel_list(spec))


# -- the settings ---------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class QuanserSettings:
    """The Q8 card: which channels drive which joint, and how volts become current.

    Index 0 of every pair is joint 1 (θ_R1, link l1/l4), index 1 joint 2 (θ_R2,
    link l2/l3). `encoder_signs` make a count increase read as the joint angle
    increasing counter-clockwise (docs/frames.md); `motor_signs` make a positive
    joint torque command turn the joint counter-clockwise. `homing_joint_angles_rad`
    are the absolute link angles of the documented homing pose, where the counts
    are zeroed at connect.
    """

    homing_joint_angles_rad: tuple[float, float]
    amplifier_gain_A_per_V: float
    board_type: str = "q8_usb"
    board_identifier: str = "0"
    card_options: str = "update_rate=normal;decimation=1"
    encoder_channels: tuple[int, int] = (0, 1)
    encoder_signs: tuple[int, int] = (1, 1)
    analog_output_channels: tuple[int, int] = (0, 1)
    motor_signs: tuple[int, int] = (1, 1)
    output_voltage_limit_V: float = 10.0
    watchdog_timeout_s: float = 0.02

    def __post_init__(self) -> None:
        _store(self, _check_quanser(_values_of(self), "QuanserSettings"))


@dataclass(frozen=True, slots=True)
class ForceSensorSettings:
    """The ATI Nano25 read through an NI-DAQmx card (gauges G0..G5 on six AI channels)."""

    calibration_file: str
    physical_channels: str = "Dev1/ai0:5"
    terminal_config: str = "DIFF"
    voltage_range_V: float = 10.0
    sample_rate_Hz: float = 2000.0
    calibration_index: int = 1
    mounting_offset_rad: float = 0.0
    tare_samples: int = 500
    tare_spread_limit_N: float = TARE_SPREAD_LIMIT_N
    read_timeout_s: float = 0.01
    saturation_V: float = 9.9

    def __post_init__(self) -> None:
        _store(self, _check_force(_values_of(self), "ForceSensorSettings"))


@dataclass(frozen=True, slots=True)
class RobotIdentity:
    """Which robot this is: `name`, as on its label (its serial number, or the department's
    own name for it). Two robots of one design differ in their belts, friction and
    handle, so a model learned on one is not a model of the other: every trial records the
    name of the robot it ran on (its `start` event, docs/data-format.md) and a learned model
    keeps the name of the robot its trials ran on (app.learning.library)."""

    name: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "name", _check_robot_name(self.name, "RobotIdentity: [robot]"))


@dataclass(frozen=True, slots=True)
class HardwareSettings:
    """Everything the Quanser backend needs besides the robot model; `source` is the file."""

    quanser: QuanserSettings
    force_sensor: ForceSensorSettings
    source: str = "<settings given in code>"
    robot: RobotIdentity = RobotIdentity("given-in-code")


def _values_of(settings: object) -> dict[str, Any]:
    return {f.name: getattr(settings, f.name) for f in fields(settings)}  # type: ignore[arg-type]


def _store(settings: object, checked: Mapping[str, Any]) -> None:
    # Frozen: the checked, normalised values (tuples, floats) replace what was given.
    for name, value in checked.items():
        object.__setattr__(settings, name, value)


def _check_quanser(v: Mapping[str, Any], where: str) -> dict[str, Any]:
    q = f"{where}: [quanser]"
    out: dict[str, Any] = {}
    out["board_type"] = _string(
        q, "board_type", v["board_type"], BOARD_TYPES,
        'Q8-USB is "q8_usb", the PCI Q8 of the thesis is "q8"',
    )
    ident = v["board_identifier"]
    if not isinstance(ident, str) or not ident.strip().isdigit():
        raise _fail(q, "board_identifier", ident, 'a string such as "0"',
                    '"0" is the first board of its type, "1" the second')
    out["board_identifier"] = ident.strip()
    if not isinstance(v["card_options"], str):
        raise _fail(q, "card_options", v["card_options"], "a string (may be empty)")
    out["card_options"] = v["card_options"]
    out["encoder_channels"] = _channels(
        q, "encoder_channels", v["encoder_channels"], Q8_ENCODER_CHANNELS, "encoder"
    )
    out["encoder_signs"] = _signs(q, "encoder_signs", v["encoder_signs"],
                                  "the direction an encoder counts")
    homing = _pair(
        q, "homing_joint_angles_rad", v["homing_joint_angles_rad"],
        lambda k, x: _number(q, k, x, -2.0 * math.pi, 2.0 * math.pi, "rad"),
    )
    spread = homing[0] - homing[1]
    if not 0.0 < spread < math.pi:
        raise _fail(
            q, "homing_joint_angles_rad", v["homing_joint_angles_rad"],
            "θ_R1 − θ_R2 between 0 and π rad",
            f"the spread is {spread:.3f} rad; the working branch keeps the parallelogram open "
            "(docs/frames.md); are the two angles swapped, or given in degrees?",
        )
    out["homing_joint_angles_rad"] = homing
    out["analog_output_channels"] = _channels(
        q, "analog_output_channels", v["analog_output_channels"],
        Q8_ANALOG_OUTPUT_CHANNELS, "analog-output",
    )
    out["motor_signs"] = _signs(q, "motor_signs", v["motor_signs"],
                                "the direction a positive current turns the joint")
    out["amplifier_gain_A_per_V"] = _number(
        q, "amplifier_gain_A_per_V", v["amplifier_gain_A_per_V"], 0.0, 10.0, "A/V",
        "from the amplifier's data sheet or label", low_open=True,
    )
    out["output_voltage_limit_V"] = _number(
        q, "output_voltage_limit_V", v["output_voltage_limit_V"], 0.0, 10.0, "V",
        "the Q8 analog outputs span ±10 V", low_open=True,
    )
    out["watchdog_timeout_s"] = _number(
        q, "watchdog_timeout_s", v["watchdog_timeout_s"], 0.004, 0.5, "s",
        "at least two 2 ms loop periods, and short enough to stop a runaway motor",
    )
    return out


def _check_force(v: Mapping[str, Any], where: str) -> dict[str, Any]:
    f = f"{where}: [force_sensor]"
    out: dict[str, Any] = {}
    out["calibration_file"] = _string(f, "calibration_file", v["calibration_file"],
                                      why="the path of the sensor's ATI .cal file")
    spec = _string(f, "physical_channels", v["physical_channels"])
    try:
        channels = physical_channel_list(spec)
    except ValueError as exc:
        raise _fail(f, "physical_channels", spec, 'NI channel names such as "Dev1/ai0:5"',
                    f"cannot read {str(exc)!r}") from None
    count = len(channels)
    if count != FORCE_SENSOR_GAUGES:
        raise _fail(f, "physical_channels", spec, f"exactly {FORCE_SENSOR_GAUGES} channels",
                    f"it names {count}; gauges G0..G5 go to six inputs, in order")
    twice = sorted({f"{d}/ai{n}" for d, n in channels if channels.count((d, n)) > 1})
    if twice:
        # one input read as two gauges would give every force a wrong number, silently
        raise _fail(f, "physical_channels", spec, "six different inputs",
                    f"named twice: {', '.join(twice)}; each gauge G0..G5 has its own input")
    out["physical_channels"] = spec
    out["terminal_config"] = _string(
        f, "terminal_config", v["terminal_config"], TERMINAL_CONFIGS,
        'the ATI interface drives differential pairs: use "DIFF"',
    )
    out["voltage_range_V"] = _number(
        f, "voltage_range_V", v["voltage_range_V"], 0.0, 10.0, "V",
        "the ATI outputs swing ±10 V; the input range is ± this value", low_open=True,
    )
    out["sample_rate_Hz"] = _number(
        f, "sample_rate_Hz", v["sample_rate_Hz"], 500.0, 50_000.0, "Hz",
        "at least the 500 Hz loop rate, so every tick sees a new sample",
    )
    out["calibration_index"] = _integer(
        f, "calibration_index", v["calibration_index"], 1, 99,
        "1 is the first <Calibration> in the .cal file",
    )
    out["mounting_offset_rad"] = _number(
        f, "mounting_offset_rad", v["mounting_offset_rad"], -math.pi, math.pi, "rad"
    )
    out["tare_samples"] = _integer(f, "tare_samples", v["tare_samples"], 1, 100_000)
    out["tare_spread_limit_N"] = _number(
        f, "tare_spread_limit_N", v["tare_spread_limit_N"], 0.01, 5.0, "N",
        "how much the force may move during the zero at Connect before it is refused as "
        "taken with a hand on the handle (device.backend.TARE_SPREAD_LIMIT_N)",
    )
    out["read_timeout_s"] = _number(f, "read_timeout_s", v["read_timeout_s"], 0.001, 1.0, "s")
    out["saturation_V"] = _number(
        f, "saturation_V", v["saturation_V"], 0.0, out["voltage_range_V"], "V",
        "a gauge at or beyond this reads as saturated; it cannot exceed the input range",
        low_open=True,
    )
    tare_s = out["tare_samples"] / out["sample_rate_Hz"]
    if tare_s < MIN_TARE_S:
        raise _fail(
            f, "tare_samples", v["tare_samples"],
            f"at least {math.ceil(MIN_TARE_S * out['sample_rate_Hz'])} at "
            f"{out['sample_rate_Hz']:g} Hz",
            f"the zero would last {tare_s:g} s, too short for a hand on the handle to move "
            f"the force by more than tare_spread_limit_N; keep it at least {MIN_TARE_S:g} s",
        )
    if tare_s > 5.0:
        raise _fail(
            f, "tare_samples", v["tare_samples"],
            f"at most {int(5.0 * out['sample_rate_Hz'])} at {out['sample_rate_Hz']:g} Hz",
            f"the tare would take {tare_s:g} s with the patient waiting; keep it under 5 s",
        )
    return out


# -- loading --------------------------------------------------------------------------------------

MAX_HARDWARE_BYTES = 1 << 20
"""The example file is a few kilobytes with its comments; a megabyte is not this file."""


def load_hardware_settings(path: str | Path) -> HardwareSettings:
    """Read and check a hardware settings TOML file.

    `[force_sensor] calibration_file` is resolved relative to the settings file's
    folder when it is not absolute. Raises HardwareSettingsError naming the file
    and the key of the first problem.
    """
    path = Path(path)
    where = str(path)
    try:
        # the checked read: a pipe or /dev/zero named here hung the Connect, a folder
        # failed in the library's words; each is refused in one line
        raw = read_bytes(path, what="hardware settings file", max_bytes=MAX_HARDWARE_BYTES)
    except InputRefused as exc:
        if not os.path.lexists(path):
            raise HardwareSettingsError(
                f"hardware settings file {where} does not exist. Copy "
                "resources/hardware.example.toml there and fill it in for this robot."
            ) from None
        raise HardwareSettingsError(str(exc)) from None
    except OutputRefused as exc:  # a path the system cannot take (a NUL in it)
        raise HardwareSettingsError(f"hardware settings file: {exc}") from None
    try:
        data = tomllib.loads(_text_of(raw, where))
    except tomllib.TOMLDecodeError as exc:
        raise HardwareSettingsError(
            f"hardware settings file {where} is not valid TOML ({exc}). Correct it and "
            "connect again."
        ) from None
    unknown = sorted(set(data) - {"robot", "quanser", "force_sensor"})
    if unknown:
        raise HardwareSettingsError(
            f"{where}: unknown table(s) or key(s) at the top level: {', '.join(unknown)}; "
            "the file has one [robot], one [quanser] and one [force_sensor] table."
        )
    if "robot" not in data:
        # files written before robots were named: say why the table is new
        raise HardwareSettingsError(
            f'{where}: the [robot] table is missing. Add it with this robot\'s name, as on its '
            'label or its serial number (`[robot]` then `name = "…"`): every trial records the '
            "robot it ran on and a learned model runs only on the robot it was learned on "
            "(see resources/hardware.example.toml).")
    robot_values = _section(data, "robot", RobotIdentity, where)
    robot_name = _check_robot_name(robot_values["name"], f"{where}: [robot]")
    q_values = _section(data, "quanser", QuanserSettings, where)
    f_values = _section(data, "force_sensor", ForceSensorSettings, where)
    q_checked = _check_quanser(q_values, where)
    f_checked = _check_force(f_values, where)
    cal = Path(f_checked["calibration_file"])
    if not cal.is_absolute():
        f_checked["calibration_file"] = str(path.parent / cal)
    return HardwareSettings(
        quanser=QuanserSettings(**q_checked),
        force_sensor=ForceSensorSettings(**f_checked),
        source=where,
        robot=RobotIdentity(robot_name),
    )


def _text_of(raw: bytes, where: str) -> str:
    """The file's text: TOML is UTF-8. A byte-order mark, which Windows Notepad writes, is
    dropped; a file saved as UTF-16 ("Unicode") or in a Windows code page ("ANSI", an
    accent in a comment) is refused in one line saying how to save it."""
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        utf16 = raw[:2] in (b"\xff\xfe", b"\xfe\xff")
        line = raw[:exc.start].count(b"\n") + 1
        saved = "as UTF-16 (Unicode)" if utf16 else f"in another encoding (line {line})"
        raise HardwareSettingsError(
            f"hardware settings file {where} is not UTF-8 text: it was saved {saved}. Save "
            "it as UTF-8 (in Notepad: Save as, Encoding UTF-8) and connect again."
        ) from None


def _section(data: Mapping[str, Any], section: str, cls: type, where: str) -> dict[str, Any]:
    """The table's values over the dataclass defaults; refuses unknown and missing keys."""
    table = data.get(section)
    if not isinstance(table, dict):
        raise HardwareSettingsError(
            f"{where}: the [{section}] table is missing. Copy it from "
            "resources/hardware.example.toml and fill it in for this robot."
        )
    known = [f.name for f in fields(cls)]
    unknown = sorted(set(table) - set(known))
    if unknown:
        raise HardwareSettingsError(
            f"{where}: [{section}] has unknown key(s) {', '.join(unknown)}; the known keys are "
            f"{', '.join(known)}. Correct the spelling and connect again."
        )
    values = {f.name: f.default for f in fields(cls) if f.default is not MISSING}
    missing = [name for name in known if name not in values and name not in table]
    if missing:
        raise HardwareSettingsError(
            f"{where}: [{section}] is missing {', '.join(missing)}; this robot's own value must "
            "be given (see resources/hardware.example.toml)."
        )
    values.update(table)
    return values
