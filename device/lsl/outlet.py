"""The robot's state and the trial's events on the Lab Streaming Layer, so LabRecorder
records the robot beside EEG or EMG on one clock.

Two streams, their source ids fixed per station (`station_source_id`: the host's name), so
LabRecorder finds them again after a restart of the console:

* `rehab-robot` (type `MoCap`, regular at the loop's rate, float64): handle position x, y
  (m), the hand's force x, y (N), the subject's shoulder and elbow torques (N·m, eq.
  3.27), the applied joint torques τ1, τ2 (N·m), and the phase code. Each channel's
  `label`, `unit` and `type` are in the description after the XDF MoCap meta-data (sccn/xdf
  wiki, "MoCap Meta Data": `PositionX`/`PositionY` in metres with the `object` they belong
  to); the meta-data lists no type for forces and torques, so those say what they are in
  the same style (`ForceX`, `JointTorque`…). An `acquisition` element names the maker and
  model.
* `rehab-robot-events` (type `Markers`, irregular, string): one JSON object per event the
  trial file records (device.loop.messages.TrialMarker: `start` with the trial's settings,
  `stop`, `fault`, `assistance`; the recorder's `recording`), and one per change of the
  phase channel (`phase`), each stamped at the sensor read of the tick it belongs to.

Every sample is stamped at its sensor read on the loop's clock of its own connection
(device.lsl.timeline), so no tick of a trial's start is lost and the stream never goes
back in time across a Disconnect and Connect.
"""

from __future__ import annotations

import json
import logging
import socket
import time

import numpy as np

from device.lsl.library import pylsl
from device.lsl.timeline import MarkerQueue, RingClocks

log = logging.getLogger(__name__)

ROBOT_STREAM = "rehab-robot"
EVENT_STREAM = "rehab-robot-events"
# (record field, column, label, unit, type)
ROBOT_CHANNELS = (
    ("position", 0, "position_x", "meters", "PositionX"),
    ("position", 1, "position_y", "meters", "PositionY"),
    ("force", 0, "force_x", "newtons", "ForceX"),
    ("force", 1, "force_y", "newtons", "ForceY"),
    ("subject_torque", 0, "shoulder_torque", "newton meters", "JointTorque"),
    ("subject_torque", 1, "elbow_torque", "newton meters", "JointTorque"),
    ("torque_applied", 0, "robot_torque_1", "newton meters", "MotorTorque"),
    ("torque_applied", 1, "robot_torque_2", "newton meters", "MotorTorque"),
    ("phase", None, "phase", "code", "Phase"),
)
PHASE_NAMES = {0: "no control", 1: "approach", 2: "exercise", 3: "hold"}
"""device.recording.record's `phase` channel."""


def station_source_id() -> str:
    """The robot stream's source id: the same on this station every time the console runs
    (LabRecorder and the XDF readers tell a restarted source from a new one by it)."""
    return f"rehab-console@{socket.gethostname()}"


def marker_text(kind: str, message: str = "", **values) -> str:
    """One marker: a JSON object with the event's kind first (the XDF readers give it as a
    string; json.loads gives it back)."""
    return json.dumps({"event": kind, "message": message, **values}, default=str,
                      ensure_ascii=False)


class RobotStateOutlet:
    """The robot's state and events as two LSL streams (module docstring)."""

    def __init__(self, rate_hz: float = 500.0, *, source_id: str | None = None) -> None:
        lsl = pylsl()
        source_id = source_id or station_source_id()
        info = lsl.StreamInfo(ROBOT_STREAM, "MoCap", len(ROBOT_CHANNELS), rate_hz,
                              lsl.cf_double64, source_id)
        channels = info.desc().append_child("channels")
        for name, _, label, unit, kind in ROBOT_CHANNELS:
            ch = channels.append_child("channel")
            ch.append_child_value("label", label)
            ch.append_child_value("unit", unit)
            ch.append_child_value("type", kind)
            if name == "position":
                ch.append_child_value("object", "handle")
        acquisition = info.desc().append_child("acquisition")
        acquisition.append_child_value("manufacturer", "rehab console")
        acquisition.append_child_value("model", "planar 2-DOF parallelogram robot")
        self._state = lsl.StreamOutlet(info, chunk_size=0, max_buffered=60)
        markers = lsl.StreamInfo(EVENT_STREAM, "Markers", 1, lsl.IRREGULAR_RATE,
                                 lsl.cf_string, source_id + "-events")
        self._events = lsl.StreamOutlet(markers)
        self.clocks = RingClocks()
        self._markers = MarkerQueue()
        self._phase: int | None = None
        self._last_stamp = -np.inf
        self.pushed = 0
        self.dropped = 0
        """Records not pushed: met before their clock (none when the loop's ClockStarted
        is read after them, device.lsl.timeline) or not after the last stamp pushed."""

    @staticmethod
    def rows(records: np.ndarray) -> np.ndarray:
        """The state channels of a batch of loop records (device.recording.record)."""
        out = np.empty((records.shape[0], len(ROBOT_CHANNELS)))
        for j, (name, column, _, _, _) in enumerate(ROBOT_CHANNELS):
            values = records[name]
            out[:, j] = values if column is None else values[:, column]
        return out

    def clock_started(self, first_seq: int, origin_monotonic_s: float) -> None:
        """The loop began ticking (device.loop.messages.ClockStarted). Markers still waiting
        for a record of an earlier connection go out at their send time."""
        for marker, stamp in self._markers.ready(self.clocks, flush=True):
            self._push_marker(marker, stamp)
        self.clocks.started(first_seq, origin_monotonic_s)
        self._phase = None

    def push_records(self, records: np.ndarray, first_seq: int) -> None:
        """Push consecutive records from ring sequence number `first_seq`, each stamped at
        its sensor read, with a marker where the phase changes; then the markers whose
        records have come."""
        if records.shape[0]:
            stamps = self.clocks.stamps(records["wall_time"], first_seq)
            keep = np.isfinite(stamps) & (stamps > np.fmax.accumulate(
                np.concatenate(([self._last_stamp], stamps[:-1]))))
            self.dropped += int(records.shape[0] - np.count_nonzero(keep))
            records, stamps = records[keep], stamps[keep]
            if records.shape[0]:
                self._phase_markers(records["phase"], stamps)
                self._state.push_chunk(self.rows(records), timestamp=stamps.tolist())
                self._last_stamp = float(stamps[-1])
                self.pushed += records.shape[0]
        for marker, stamp in self._markers.ready(self.clocks):
            self._push_marker(marker, stamp)

    def _phase_markers(self, phases: np.ndarray, stamps: np.ndarray) -> None:
        phases = phases.astype(int)
        before = np.concatenate(([-1 if self._phase is None else self._phase], phases[:-1]))
        for k in np.flatnonzero(phases != before):
            phase = int(phases[k])
            self._events.push_sample([marker_text(
                "phase", PHASE_NAMES.get(phase, "unknown"), phase=phase)], float(stamps[k]))
        self._phase = int(phases[-1])

    def mark(self, marker) -> None:
        """A trial event at its record (device.loop.messages.TrialMarker): pushed when that
        record's stamp is known."""
        self._markers.add(marker)
        for waiting, stamp in self._markers.ready(self.clocks):
            self._push_marker(waiting, stamp)

    def _push_marker(self, marker, stamp: float) -> None:
        self._events.push_sample([marker_text(marker.kind, marker.message, tick=marker.tick,
                                              **marker.values)], stamp)

    def push_event(self, kind: str, message: str = "",
                   monotonic_s: float | None = None, **values) -> None:
        """An event that belongs to no record (the recorder's, the console's), stamped now
        or at `monotonic_s`."""
        self._events.push_sample([marker_text(kind, message, **values)],
                                 time.monotonic() if monotonic_s is None else monotonic_s)

    def have_consumers(self) -> bool:
        return self._state.have_consumers()

    def close(self) -> None:
        for marker, stamp in self._markers.ready(self.clocks, flush=True):
            self._push_marker(marker, stamp)
        del self._state, self._events
