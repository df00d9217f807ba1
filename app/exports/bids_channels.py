"""What each column of a trial is in BIDS-motion terms (BIDS 1.9.0): the rows of a run's
``_channels.tsv`` (app.exports.bids writes them) and the frames its ``channels.json``
describes.

``_channels.tsv`` holds one row per column of ``_motion.tsv``: every component of
every channel of the trial file, named as in the CSV export (app.exports.columns);
name, component, type, tracked_point, units, then reference_frame and
description.

Where this deviates from BIDS 1.9.0 (and why):

* Angles are in rad, not the deg that JNTANG channels SHOULD use: SI units
  throughout the console; `units` says rad.
* Channel types: the robot's joint angles are absolute link angles and the
  subject's arm-frame angles absolute segment angles, so they are ORNT (rotation
  about z, the table normal); the ISB angles are JNTANG. BIDS 1.9 has no type for
  angular velocity (GYRO is a gyroscope), force or torque: those and the
  loop's codes, flags and timing are MISC; wall_time is LATENCY.
* Units are written in CMIXF form (``N.m``); dimensionless channels have ``n/a``.
"""

from __future__ import annotations

from dataclasses import dataclass

from app.exports.columns import (
    FRAME_ARM,
    FRAME_GLOBAL,
    FRAME_ISB,
    FRAME_JOINTS,
    FRAME_NONE,
    FRAME_SENSOR,
    Column,
    table_columns,
)
from app.exports.trialinfo import Trial
from device.recording.record import ARM, GLOBAL, ISB, JOINTS, SENSOR

CHANNEL_TYPES = ("ACCEL", "ANGACCEL", "GYRO", "JNTANG", "LATENCY", "MAGN", "MISC", "ORNT",
                 "POS", "VEL")
"""The channel types of BIDS 1.9.0's motion extension (each is counted in _motion.json)."""
_SEGMENTS = {"shoulder": "upper_arm", "elbow": "forearm"}
# Our frames for people reading channels.json. The global frame's axes are
# fixed to the subject's seat (docs/frames.md): +x to the subject's left, +y
# behind them (they face -y), z up, hence LPS.
FRAMES = {
    FRAME_GLOBAL: {"SpatialAxes": "LPS", "RotationRule": "right-hand",
                   "Description": GLOBAL + "; z normal to the table, up; angles "
                   "counter-clockwise from +x seen from above"},
    FRAME_JOINTS: {"RotationRule": "right-hand", "Description": JOINTS},
    FRAME_SENSOR: {"Description": SENSOR},
    FRAME_ARM: {"RotationRule": "right-hand", "Description": ARM},
    FRAME_ISB: {"Description": ISB},
}


@dataclass(frozen=True, slots=True)
class BidsChannel:
    """One row of `_channels.tsv` and the column of the trial it holds."""

    name: str
    component: str
    type: str
    tracked_point: str
    units: str
    reference_frame: str
    description: str
    column: Column


def bids_units(units: str) -> str:
    """CMIXF units: `N*m` → `N.m`; dimensionless `1` → `n/a`."""
    text = units.strip()
    return "n/a" if text in ("", "1") else text.replace("*", ".")


def bids_channels(trial: Trial) -> tuple[BidsChannel, ...]:
    """The `_channels.tsv` rows of a trial, in the order of the `_motion.tsv` columns."""
    rows = []
    for column in table_columns(trial.arrays, trial.units, trial.frames, trial.descriptions):
        kind, component, point = _classify(column)
        rows.append(BidsChannel(
            column.name, component, kind, point, bids_units(column.units),
            column.frame if column.frame in FRAMES else "n/a", column.description, column,
        ))
    return tuple(rows)


def _classify(column: Column) -> tuple[str, str, str]:
    """(type, component, tracked_point) of a column (the module's doc says why)."""
    units, frame, part = column.units, column.frame, column.component
    if frame == FRAME_GLOBAL:
        kind = {"m": "POS", "m/s": "VEL", "m/s^2": "ACCEL"}.get(units, "MISC")
        return kind, part or "n/a", "handle"
    if frame == FRAME_SENSOR:
        return "MISC", part or "n/a", "force_sensor"
    if frame == FRAME_JOINTS:
        kind = {"rad": "ORNT", "rad/s^2": "ANGACCEL"}.get(units, "MISC")
        return kind, "z", f"robot_joint{part}"
    if frame == FRAME_ARM:
        kind = {"rad": "ORNT", "rad/s^2": "ANGACCEL"}.get(units, "MISC")
        moving = units in ("rad", "rad/s", "rad/s^2")
        return kind, "z", _SEGMENTS.get(part, part) if moving else part
    if frame == FRAME_ISB:
        return ("JNTANG" if units == "rad" else "MISC"), "n/a", part or "n/a"
    if frame == FRAME_NONE:
        return ("LATENCY" if column.channel == "wall_time" else "MISC"), "n/a", "robot"
    return "MISC", "n/a", column.channel
