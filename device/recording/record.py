"""The per-tick record: one fixed-size row per 2 ms tick, shared by the loop, the ring
buffer, the recorder, the live view and the trial file.

Each channel has a name, a width, a dtype, SI units and the frame its numbers are
expressed in. The trial file stores each channel as its own dataset with those
attributes (docs/data-format.md). Later instruments (EMG, camera) add channels
with `extend_channels` rather than changing these.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class Channel:
    name: str
    width: int  # 1 for a scalar per tick
    dtype: str
    units: str
    frame: str
    description: str

    @property
    def numpy_field(self) -> tuple:
        if self.width == 1:
            return (self.name, self.dtype)
        return (self.name, self.dtype, (self.width,))


# Frames used below.
GLOBAL = "global: origin on the motor axes, x and y in the table plane (docs/frames.md)"
JOINTS = "robot joints (θ_R1 of links l1/l4, θ_R2 of links l2/l3), absolute, global x-axis"
SENSOR = (
    "force sensor: x', y' in the plane turning with link l4 (θ_R1 + mounting offset), z' normal"
)
ARM = "subject arm: (θ_s, θ_e) absolute, eq. 3.16 convention"
ISB = "subject arm, ISB display convention (eq. 3.37–3.38): (shoulder, elbow)"
NONE = "none"

CHANNELS: tuple[Channel, ...] = (
    Channel("tick", 1, "i8", "1", NONE, "tick index from the start of the trial"),
    Channel("time", 1, "f8", "s", NONE, "nominal trial time, tick × period"),
    Channel("wall_time", 1, "f8", "s", NONE, "monotonic time the sensors were read, from start"),
    Channel("phase", 1, "u1", "1", NONE,
            "0 no control, 1 approach to the start point, 2 exercise, 3 hold at the end"),
    Channel("lateness", 1, "f4", "s", NONE, "how late the tick started after its deadline"),
    Channel("compute_time", 1, "f4", "s", NONE, "time from sensor read to torque written"),
    Channel("robot_angle", 2, "f8", "rad", JOINTS, "measured joint angles (encoder, quantised)"),
    Channel("robot_rate", 2, "f8", "rad/s", JOINTS, "estimated joint rates (filtered difference)"),
    Channel("robot_acceleration", 2, "f8", "rad/s^2", JOINTS, "estimated joint accelerations"),
    Channel("robot_angle_desired", 2, "f8", "rad", JOINTS, "reference joint angles (IK)"),
    Channel("robot_rate_desired", 2, "f8", "rad/s", JOINTS, "reference joint rates"),
    Channel("robot_acceleration_desired", 2, "f8", "rad/s^2", JOINTS,
            "reference joint accelerations"),
    Channel("torque_controller", 2, "f8", "N*m", JOINTS, "controller output before assistance"),
    Channel("torque_commanded", 2, "f8", "N*m", JOINTS,
            "after the performance-based reduction, before the safety supervisor"),
    Channel("torque_applied", 2, "f8", "N*m", JOINTS, "torque written to the motors"),
    Channel("position", 2, "f8", "m", GLOBAL, "end-effector position from the encoders (FK)"),
    Channel("position_desired", 2, "f8", "m", GLOBAL, "desired end-effector position"),
    Channel("velocity_desired", 2, "f8", "m/s", GLOBAL, "desired end-effector velocity"),
    Channel("direction_desired", 2, "f8", "1", GLOBAL, "unit tangent of the path"),
    Channel("force_sensor", 3, "f8", "N", SENSOR, "handle force in the sensor frame (raw)"),
    Channel("force", 2, "f8", "N", GLOBAL, "force of the hand on the handle (eq. 3.35)"),
    Channel("force_angle", 1, "f8", "rad", NONE,
            "angle between the force and the desired direction (NaN when the force is too small)"),
    Channel("assistance_active", 1, "u1", "1", NONE,
            "1 when the force was within tolerance and the robot torque was reduced"),
    Channel("assistance_level", 1, "f8", "1", NONE,
            "assistance level in effect (0-1): the trial's own, or the therapist's live "
            "change from the tick it was taken; NaN while no trial runs"),
    Channel("subject_angle", 2, "f8", "rad", ARM, "subject joint angles (eq. 3.28)"),
    Channel("subject_rate", 2, "f8", "rad/s", ARM, "subject joint rates (eq. 3.32)"),
    Channel("subject_acceleration", 2, "f8", "rad/s^2", ARM,
            "subject joint accelerations (eq. 3.33)"),
    Channel("subject_torque", 2, "f8", "N*m", ARM, "subject net joint torques (eq. 3.27)"),
    Channel("subject_angle_isb", 2, "f8", "rad", ISB, "subject joint angles for display"),
    Channel("singular", 1, "u1", "1", NONE,
            "1 when the damped pseudo-inverse was used near the straight arm"),
    Channel("state", 1, "u1", "1", NONE, "loop state code (device.loop.states)"),
    Channel("fault", 1, "u2", "1", NONE, "latched fault code, 0 when none (docs/safety.md)"),
)

RECORD_DTYPE = np.dtype([c.numpy_field for c in CHANNELS])
CHANNELS_BY_NAME = {c.name: c for c in CHANNELS}


def extend_channels(extra: tuple[Channel, ...]) -> tuple[tuple[Channel, ...], np.dtype]:
    """Channels and record dtype with instrument channels (EMG, video frame index) added."""
    names = {c.name for c in CHANNELS}
    clash = [c.name for c in extra if c.name in names]
    if clash:
        raise ValueError(f"channel names already used: {', '.join(clash)}")
    channels = CHANNELS + tuple(extra)
    return channels, np.dtype([c.numpy_field for c in channels])


def empty_records(n: int, dtype: np.dtype = RECORD_DTYPE) -> np.ndarray:
    """n zeroed records, with float channels set to NaN so missing values show as such."""
    records = np.zeros(n, dtype=dtype)
    for name in dtype.names:
        if records[name].dtype.kind == "f":
            records[name] = np.nan
    return records


# Record layout as plain numbers: what the loop produces per tick and the ring packs.
_STRUCT_CODES = {
    ("b", 1): "?",
    ("i", 1): "b", ("i", 2): "h", ("i", 4): "i", ("i", 8): "q",
    ("u", 1): "B", ("u", 2): "H", ("u", 4): "I", ("u", 8): "Q",
    ("f", 2): "e", ("f", 4): "f", ("f", 8): "d",
}


def flat_names(dtype: np.dtype = RECORD_DTYPE) -> tuple[str, ...]:
    """The order of the plain numbers in a flat record: fields in dtype order,
    sub-array fields flattened in C order (``robot_angle[0]``, ``robot_angle[1]``, …)."""
    names = []
    for name in dtype.names:
        field = dtype.fields[name][0]
        if field.subdtype is None:
            names.append(name)
        else:
            names.extend(f"{name}[{','.join(map(str, i))}]" for i in np.ndindex(field.shape))
    return tuple(names)


def record_struct(dtype: np.dtype = RECORD_DTYPE) -> struct.Struct | None:
    """A struct that packs one record from plain numbers in `flat_names` order, or None
    when a field has no struct code (strings, nested records, non-native byte order)."""
    parts = ["="]
    pos = 0
    fields = sorted((dtype.fields[n][1], dtype.fields[n][0]) for n in dtype.names)
    for offset, field in fields:
        base = field.base
        code = _STRUCT_CODES.get((base.kind, base.itemsize))
        if code is None or not base.isnative or base.fields is not None or offset < pos:
            return None
        if offset > pos:
            parts.append(f"{offset - pos}x")
        count = int(np.prod(field.shape)) if field.shape else 1
        parts.append(f"{count}{code}")
        pos = offset + field.itemsize
    if dtype.itemsize > pos:
        parts.append(f"{dtype.itemsize - pos}x")
    return struct.Struct("".join(parts))


class RecordLog:
    """Records kept in memory for a headless run: packed as they come, one array at the end."""

    def __init__(self, dtype: np.dtype = RECORD_DTYPE) -> None:
        self.dtype = dtype
        self._pack = record_struct(dtype).pack
        self._chunks: list[bytes] = []

    def append(self, values) -> None:
        """One record from plain numbers in `flat_names` order."""
        self._chunks.append(self._pack(*values))

    def __len__(self) -> int:
        return len(self._chunks)

    def to_array(self) -> np.ndarray:
        return np.frombuffer(b"".join(self._chunks), dtype=self.dtype).copy()
