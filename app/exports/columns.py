"""A trial's channels as flat, named columns (one per component) and their text form.

Column names: ``<channel>_<component>_<unit>``, e.g. ``position_x_m``,
``robot_angle_1_rad``, ``subject_torque_elbow_Nm``, ``force_sensor_z_N``,
``time_s``, ``phase``. The component comes from the channel's frame
(docs/data-format.md): x/y in the global frame, 1/2 for the robot joints
(θ_R1, θ_R2), shoulder/elbow in the subject-arm frames (arm, isb), x/y/z in the
force-sensor frame; a channel of width 1 has none, and a frame this console
does not know gets 1, 2, 3… The unit part is the channel's `units` text with
``*`` and ``^`` dropped and ``/`` as ``_`` (``rad/s^2`` → ``rad_s2``, ``N*m`` →
``Nm``); dimensionless channels (units ``1``) have none, and a channel whose
name already ends in its unit does not get it twice.

Numbers as text (`format_values`): by default every value reads back exactly
as the dtype stored in the trial file — float64 as Python's shortest repr that
round-trips (at most 17 significant digits), float32 with 9 significant digits,
float16 with 5, integers in full. `digits=n` writes floats with n significant
digits instead (relative error at most 5·10⁻ⁿ), for smaller files. Missing
values (NaN) are written as the caller's `missing` text, infinities as ``Inf``
and ``-Inf``. The decimal mark is always ``.``, whatever the locale.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from app.exports.files import ExportError
from device.recording.record import ARM, GLOBAL, ISB, JOINTS, NONE, SENSOR

FRAME_GLOBAL, FRAME_JOINTS, FRAME_SENSOR, FRAME_ARM, FRAME_ISB, FRAME_NONE, FRAME_OTHER = (
    "global", "joints", "sensor", "arm", "isb", "none", "other"
)
_FRAME_KEYS = {GLOBAL: FRAME_GLOBAL, JOINTS: FRAME_JOINTS, SENSOR: FRAME_SENSOR, ARM: FRAME_ARM,
               ISB: FRAME_ISB, NONE: FRAME_NONE}
_COMPONENTS = {
    FRAME_GLOBAL: ("x", "y", "z"),
    FRAME_JOINTS: ("1", "2"),
    FRAME_SENSOR: ("x", "y", "z"),
    FRAME_ARM: ("shoulder", "elbow"),
    FRAME_ISB: ("shoulder", "elbow"),
}
_NOT_NAME = re.compile(r"[^A-Za-z0-9_]+")
# Significant digits that make a float of this many bytes read back exactly.
_ROUND_TRIP_DIGITS = {2: 5, 4: 9, 8: 17}
_DEDUPLICATE_FROM = 64
_DEDUPLICATE_SHARE = 0.5


@dataclass(frozen=True, slots=True)
class Column:
    """One column of a flattened trial: component `index` of `channel` (None for a
    channel of width 1)."""

    name: str
    channel: str
    index: int | None
    component: str
    units: str
    frame: str
    description: str


def frame_key(frame: str) -> str:
    """The short name of a channel's frame text: global, joints, sensor, arm, isb,
    none, or other for a frame this console does not know."""
    if frame in _FRAME_KEYS:
        return _FRAME_KEYS[frame]
    short = frame.strip().lower()
    return short if short in (*_COMPONENTS, FRAME_NONE) else FRAME_OTHER


def components(frame: str, width: int) -> tuple[str, ...]:
    """Component labels of a channel of `width` values per sample in `frame`."""
    if width <= 1:
        return ("",) if width == 1 else ()
    known = _COMPONENTS.get(frame_key(frame), ())
    if width <= len(known):
        return known[:width]
    return tuple(str(i + 1) for i in range(width))


def unit_suffix(units: str) -> str:
    """The unit as it ends a column name: `rad/s^2` → `rad_s2`, `N*m` → `Nm`, `1` → ''."""
    text = units.strip()
    if text in ("", "1"):
        return ""
    text = text.replace("*", "").replace("^", "").replace("/", "_")
    return _NOT_NAME.sub("", text.replace(" ", "_"))


def table_columns(
    arrays: Mapping[str, np.ndarray],
    units: Mapping[str, str],
    frames: Mapping[str, str],
    descriptions: Mapping[str, str],
) -> tuple[Column, ...]:
    """Every component of every channel, in channel order, with unique names."""
    columns: list[Column] = []
    taken: set[str] = set()
    for channel, values in arrays.items():
        width = 1 if values.ndim == 1 else int(np.prod(values.shape[1:]))
        frame = frames.get(channel, "")
        unit = units.get(channel, "")
        suffix = unit_suffix(unit)
        for i, component in enumerate(components(frame, width)):
            parts = [channel] + ([component] if component else [])
            if suffix and not (len(parts) == 1 and channel.endswith("_" + suffix)):
                parts.append(suffix)
            name = _unique("_".join(parts), taken)
            columns.append(Column(name, channel, None if width == 1 else i, component, unit,
                                  frame_key(frame), descriptions.get(channel, "")))
    return tuple(columns)


def column_values(arrays: Mapping[str, np.ndarray], column: Column) -> np.ndarray:
    """The 1-D values of one column (a view, not a copy)."""
    values = arrays[column.channel]
    if column.index is None:
        return values
    return values.reshape(values.shape[0], -1)[:, column.index]


def format_values(values: np.ndarray, *, digits: int | None = None,
                  missing: str = "NaN") -> list[str]:
    """The values of one column as text (see the module's doc for the precision)."""
    kind = values.dtype.kind
    if kind == "b":
        return ["1" if v else "0" for v in values.tolist()]
    if kind in "iu":
        return list(map(str, values.tolist()))
    if kind != "f":
        return list(map(str, values.tolist()))
    if values.size >= _DEDUPLICATE_FROM:
        # Encoders, the force sensor and codes repeat values a lot: formatting each
        # distinct value once is several times faster. Unique by bit pattern keeps
        # -0.0 apart from 0.0.
        bits = values.view(f"u{values.dtype.itemsize}")
        distinct, inverse = np.unique(bits, return_inverse=True)
        if distinct.size <= _DEDUPLICATE_SHARE * values.size:
            texts = _format_floats(distinct.view(values.dtype), digits, missing)
            return list(map(texts.__getitem__, inverse.tolist()))
    return _format_floats(values, digits, missing)


def _format_floats(values: np.ndarray, digits: int | None, missing: str) -> list[str]:
    if digits is None:
        if values.dtype.itemsize == 8:
            text = list(map(float.__repr__, values.tolist()))
        else:
            exact = _ROUND_TRIP_DIGITS.get(values.dtype.itemsize, 17)
            text = list(map(f"%.{exact}g".__mod__, values.tolist()))
    else:
        text = list(map(f"%.{int(digits)}g".__mod__, values.tolist()))
    finite = np.isfinite(values)
    if not finite.all():
        for i in np.flatnonzero(~finite).tolist():
            v = values[i]
            text[i] = missing if np.isnan(v) else ("Inf" if v > 0 else "-Inf")
    return text


def check_digits(digits: int | None) -> int | None:
    """`digits` if it is None or a whole number 1-17; ExportError otherwise."""
    if digits is None:
        return None
    if isinstance(digits, bool) or not isinstance(digits, int | np.integer) or not (
        1 <= digits <= 17
    ):
        raise ExportError(f"digits = {digits!r}: give a whole number of significant digits "
                          "1-17, or None to write every value exactly")
    return int(digits)


def _unique(name: str, taken: set[str]) -> str:
    candidate, n = name, 2
    while candidate in taken:
        candidate, n = f"{name}_{n}", n + 1
    taken.add(candidate)
    return candidate
