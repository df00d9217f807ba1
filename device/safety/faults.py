"""Fault codes of the safety supervisor: what the `fault` channel of every record holds.

A code is a u2 in the per-tick record and a number in the trial file's events, so
the numbers are part of the file format: never renumber or reuse one, only add
new codes at the end (docs/safety.md lists them with their hazards).

Each code carries the line the therapist's banner shows: the cause in plain
language, with the measured values filled in from the supervisor's
`fault_detail`, and what to do about it.
"""

from __future__ import annotations

import enum
import re
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class FaultText:
    """The banner's words for one fault.

    `cause` may name values of the supervisor's `fault_detail` in braces
    ({force_N:.0f}); `action` is what the therapist does next. `clearable` is
    False for causes a clear cannot make safe again (the robot must be
    reconnected first).
    """

    cause: str
    action: str
    clearable: bool = True


class Fault(enum.IntEnum):
    """A latched fault of the supervisor; 0 means none. The values are stable."""

    NONE = 0
    ESTOP = 1
    HEARTBEAT_LOST = 2
    BACKEND_ERROR = 3
    BACKEND_TIMEOUT = 4
    SENSOR_STALE = 5
    ENCODER_JUMP = 6
    NOT_FINITE = 7
    SENSOR_RANGE = 8
    FORCE_LIMIT = 9
    JOINT_SPEED = 10
    EE_SPEED = 11
    WORKSPACE = 12
    LATE_TICK = 13
    RECORDING_LOST = 14
    TORQUE_SATURATED = 15

    @property
    def text(self) -> FaultText:
        return _TEXT[self]

    @property
    def label(self) -> str:
        """Short lower-case name for files and logs, e.g. 'force_limit'."""
        return self.name.lower()

    @property
    def clearable(self) -> bool:
        return _TEXT[self].clearable

    def banner(self, detail: dict | None = None) -> str:
        """The therapist's one line: the cause with its values, a dash, the action."""
        if self is Fault.NONE:
            return _TEXT[self].cause
        text = _TEXT[self]
        return f"{_fill(text.cause, detail or {})} — {text.action}"


_TEXT: dict[Fault, FaultText] = {
    Fault.NONE: FaultText("No fault", ""),
    Fault.ESTOP: FaultText(
        "Emergency stop pressed",
        "the motors are off. Make sure the patient is safe, then press Clear fault",
    ),
    Fault.HEARTBEAT_LOST: FaultText(
        "The console window stopped answering the robot ({heartbeat}; limit {limit_s:.2f} s)",
        "check that the console is running, then clear the fault",
    ),
    Fault.BACKEND_ERROR: FaultText(
        "The robot reported an error: {error}",
        # an error the robot keeps reporting (the Q8's watchdog expired: the card keeps its
        # outputs off) fails every read, so the fault does not clear: reconnect then
        "check the robot's cables and power, then clear the fault; if it does not clear, "
        "reconnect the robot",
    ),
    Fault.BACKEND_TIMEOUT: FaultText(
        "The robot stopped answering: {error}",
        "check the robot's USB/data cable and power, then reconnect",
    ),
    Fault.SENSOR_STALE: FaultText(
        "The robot's sensors stopped updating ({repeats} samples with the same time stamp)",
        "check the data cable, then reconnect the robot",
    ),
    Fault.ENCODER_JUMP: FaultText(
        "Joint {joint} angle jumped by {change_rad:.3f} rad in one sample, faster than any "
        "movement (limit {limit_rad:.3f} rad)",
        "the position may now be wrong: check the encoder cable, then reconnect the robot",
        clearable=False,
    ),
    Fault.NOT_FINITE: FaultText(
        "An invalid number ({value}) appeared in {field}",
        "note the time and report it to the technician, then clear the fault",
    ),
    Fault.SENSOR_RANGE: FaultText(
        "The force sensor is at the end of its range ({axis} = {force_N:.0f} N, "
        "range {range_N:.0f} N)",
        "check that nothing presses on the handle, then clear the fault",
    ),
    Fault.FORCE_LIMIT: FaultText(
        "Force on the handle reached {force_N:.0f} N (limit {limit_N:.0f} N)",
        "check the patient, then clear the fault",
    ),
    Fault.JOINT_SPEED: FaultText(
        "Joint {joint} moved at {speed_rad_s:.1f} rad/s (limit {limit_rad_s:.1f} rad/s, "
        "from the {source})",
        "check the patient and the robot, then clear the fault",
    ),
    Fault.EE_SPEED: FaultText(
        "The handle moved at {speed_m_s:.2f} m/s (limit {limit_m_s:.2f} m/s, from the {source})",
        "check the patient, then clear the fault",
    ),
    Fault.WORKSPACE: FaultText(
        "The handle left the allowed region: {problem}",
        # one action for the three causes (the area, the reach band, a joint limit or the
        # links' spread): the cause names which, so the action does not name it again
        "guide the handle back inside, then clear the fault",
    ),
    Fault.LATE_TICK: FaultText(
        "The control loop ran late: {reason}",
        "close other programs on this computer, then clear the fault",
    ),
    Fault.RECORDING_LOST: FaultText(
        "The trial file fell behind and samples were lost",
        "check free disk space, then clear the fault; the trial is marked incomplete",
    ),
    Fault.TORQUE_SATURATED: FaultText(
        "The robot pushed at full strength for {duration_s:.1f} s without following the path",
        "check the patient for resistance or spasm and that nothing blocks the arm, "
        "then clear the fault",
    ),
}


class _Unknown:
    """Stands in for a value the detail lacks, whatever its format spec."""

    def __format__(self, spec: str) -> str:
        return "?"


class _Missing(dict):
    def __missing__(self, key: str) -> _Unknown:
        return _Unknown()


def _fill(template: str, detail: dict) -> str:
    try:
        return template.format_map(_Missing(detail))
    except (ValueError, TypeError):
        # A value of the wrong type for its format spec: the banner must still show.
        return re.sub(r"\{[^}]*\}", "?", template)
