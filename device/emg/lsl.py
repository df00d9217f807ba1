"""The Lab Streaming Layer: an inlet for any EMG stream, and an outlet of the robot's state.

pylsl 1.18.6's manylinux_2_35 wheel carries liblsl itself (`pylsl/lib/liblsl.so`), so a
Linux with glibc 2.35 or newer (Debian 12, Ubuntu 22.04) needs nothing else. On an older
glibc pip installs the pure-Python wheel without the library, and importing pylsl fails
with "LSL binary library file was not found": `LslError` says so and what to do.

Clocks: LSL stamps samples with `local_clock()`, which on Linux is CLOCK_MONOTONIC, the
clock of `time.monotonic()` and of the loop's `wall_time` (plus its origin,
docs/data-format.md). The inlet asks liblsl to correct a remote sender's clock onto this
machine's (`proc_clocksync`), so its stamps are this machine's monotonic seconds.

The outlet publishes two streams while a trial runs, so LabRecorder records the robot
beside EEG or EMG on one clock:

* `rehab-robot` (type `MoCap`, regular at the loop's rate, float64): handle position x, y
  (m), the hand's force x, y (N), the subject's shoulder and elbow torques (N·m, eq.
  3.27), the applied joint torques τ1, τ2 (N·m), and the phase code; each channel's label
  and unit are in the stream's description;
* `rehab-robot-events` (type `Markers`, irregular, string): one marker per trial event
  (`start`, `stop`, `fault: …`, `assistance …`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from device.errors import DeviceError

ROBOT_STREAM = "rehab-robot"
EVENT_STREAM = "rehab-robot-events"
DUPLICATE_LOOK_S = 0.5
# (record field, column, label, unit)
ROBOT_CHANNELS = (
    ("position", 0, "position_x", "m"),
    ("position", 1, "position_y", "m"),
    ("force", 0, "force_x", "N"),
    ("force", 1, "force_y", "N"),
    ("subject_torque", 0, "shoulder_torque", "N*m"),
    ("subject_torque", 1, "elbow_torque", "N*m"),
    ("torque_applied", 0, "robot_torque_1", "N*m"),
    ("torque_applied", 1, "robot_torque_2", "N*m"),
    ("phase", None, "phase", "1"),
)


class LslError(DeviceError):
    """A stream is missing or not what was asked; one line."""


def _pylsl():
    try:
        import pylsl
    except (ImportError, RuntimeError, OSError) as exc:
        raise LslError(f"the Lab Streaming Layer library cannot be loaded ({exc}); pylsl 1.18.6 "
                       "ships liblsl for Linux with glibc 2.35 or newer: on an older system "
                       "install liblsl from its releases or use mne-lsl") from None
    return pylsl


@dataclass(frozen=True, slots=True)
class StreamSummary:
    name: str
    type: str
    channel_count: int
    nominal_rate_hz: float
    hostname: str
    source_id: str


def _summary(info) -> StreamSummary:
    return StreamSummary(info.name(), info.type(), info.channel_count(), info.nominal_srate(),
                         info.hostname(), info.source_id())


def find_streams(wait_s: float = 1.0) -> list[StreamSummary]:
    """Every LSL stream seen on the network within `wait_s`."""
    return [_summary(i) for i in _pylsl().resolve_streams(wait_time=wait_s)]


def local_clock() -> float:
    return _pylsl().local_clock()


class LslEmgInlet:
    """An EMG stream's samples, stamped on this machine's monotonic clock.

    Found by name, or else by type (`EMG`). Refused with one line when there is none,
    more than one, or it is not a regular numeric stream with the channels and rate
    asked for."""

    def __init__(self, name: str | None = None, *, stream_type: str = "EMG",
                 timeout_s: float = 3.0, channels: int | None = None,
                 rate_hz: float | None = None, buffer_s: int = 60) -> None:
        pylsl = _pylsl()
        prop, value = ("name", name) if name else ("type", stream_type)
        found = pylsl.resolve_byprop(prop, value, minimum=1, timeout=timeout_s)
        what = f"LSL stream {'named' if name else 'of type'} {value!r}"
        if not found:
            raise LslError(f"no {what} found in {timeout_s:g} s: start the EMG software's LSL "
                           "stream on this network (rehab emg streams lists what is seen)")
        # resolving returns at the first stream; a second one of the name would be
        # recorded in its place by chance, so look a moment longer for another
        found = pylsl.resolve_byprop(prop, value, minimum=2, timeout=DUPLICATE_LOOK_S) or found
        if len(found) > 1:
            sources = ", ".join(f"{i.source_id() or 'no source id'} on {i.hostname()}"
                                for i in found)
            raise LslError(f"{len(found)} LSL streams {'named' if name else 'of type'} "
                           f"{value!r} found ({sources}): stop the extra one or rename it, so "
                           "the recording cannot take the wrong one")
        info = found[0]
        self.summary = _summary(info)
        if info.channel_format() in (pylsl.cf_string, pylsl.cf_undefined):
            raise LslError(f"{what} carries text, not EMG samples")
        if info.nominal_srate() <= 0:
            raise LslError(f"{what} has no regular rate (irregular stream), not EMG")
        if channels is not None and info.channel_count() != channels:
            raise LslError(f"{what} has {info.channel_count()} channels, {channels} expected: "
                           "check the EMG software's stream settings")
        if rate_hz is not None and abs(info.nominal_srate() - rate_hz) > 0.01 * rate_hz:
            raise LslError(f"{what} runs at {info.nominal_srate():g} Hz, {rate_hz:g} Hz "
                           "expected")
        self.rate_hz = float(info.nominal_srate())
        self.channel_count = int(info.channel_count())
        self._inlet = pylsl.StreamInlet(info, max_buflen=buffer_s,
                                        processing_flags=pylsl.proc_clocksync)
        self._buffer = np.empty((max(1024, int(self.rate_hz)), self.channel_count),
                                dtype=np.float32 if info.channel_format() == pylsl.cf_float32
                                else np.float64)
        self.labels = tuple(info.get_channel_labels() or ()) if _has_labels(info) else ()

    def open(self, timeout_s: float = 3.0) -> LslEmgInlet:
        try:
            self._inlet.open_stream(timeout=timeout_s)
            # the first clock-offset estimate takes a while; have it before the trial, not
            # in the first read (which would then hold the first samples back)
            self.clock_offset_s = self._inlet.time_correction(timeout=timeout_s)
        except Exception as exc:  # pylsl raises its TimeoutError or LostError
            raise LslError(f"the LSL stream {self.summary.name!r} did not open in "
                           f"{timeout_s:g} s ({type(exc).__name__})") from None
        return self

    def read(self, timeout_s: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Samples waiting (up to a second's worth): (monotonic stamps (k,), values (k, C))."""
        try:
            # min_samples=1: return as soon as anything came, not when the buffer is full
            _, stamps = self._inlet.pull_chunk(timeout=timeout_s,
                                               max_samples=self._buffer.shape[0],
                                               dest_obj=self._buffer, min_samples=1)
        except Exception as exc:  # pylsl's LostError: the sender went away
            raise LslError(f"the LSL stream {self.summary.name!r} was lost "
                           f"({type(exc).__name__}); check the EMG software") from None
        n = len(stamps)
        return np.asarray(stamps, dtype=float), self._buffer[:n].astype(float)

    def close(self) -> None:
        self._inlet.close_stream()


def _has_labels(info) -> bool:
    try:
        return bool(info.get_channel_labels())
    except Exception:  # a stream without a channel description
        return False


class RobotStateOutlet:
    """The robot's state and events as two LSL streams (module docstring)."""

    def __init__(self, rate_hz: float = 500.0, *, source_id: str = "rehab-console") -> None:
        pylsl = _pylsl()
        info = pylsl.StreamInfo(ROBOT_STREAM, "MoCap", len(ROBOT_CHANNELS), rate_hz,
                                pylsl.cf_double64, source_id)
        channels = info.desc().append_child("channels")
        for _, _, label, unit in ROBOT_CHANNELS:
            ch = channels.append_child("channel")
            ch.append_child_value("label", label)
            ch.append_child_value("unit", unit)
        self._state = pylsl.StreamOutlet(info, chunk_size=0, max_buffered=60)
        markers = pylsl.StreamInfo(EVENT_STREAM, "Markers", 1, pylsl.IRREGULAR_RATE,
                                   pylsl.cf_string, source_id + "-events")
        self._events = pylsl.StreamOutlet(markers)
        self.pushed = 0

    @staticmethod
    def rows(records: np.ndarray) -> np.ndarray:
        """The state channels of a batch of loop records (device.recording.record)."""
        out = np.empty((records.shape[0], len(ROBOT_CHANNELS)))
        for j, (name, column, _, _) in enumerate(ROBOT_CHANNELS):
            values = records[name]
            out[:, j] = values if column is None else values[:, column]
        return out

    def push_records(self, records: np.ndarray, origin_monotonic_s: float) -> None:
        """Push a batch of records, each stamped at its sensor read: the loop's origin plus
        its `wall_time` (the LSL clock is the monotonic clock)."""
        if records.shape[0] == 0:
            return
        stamps = (origin_monotonic_s + records["wall_time"]).tolist()
        self._state.push_chunk(self.rows(records), timestamp=stamps)
        self.pushed += records.shape[0]

    def push_event(self, kind: str, message: str = "",
                   monotonic_s: float | None = None) -> None:
        marker = f"{kind}: {message}" if message else kind
        self._events.push_sample([marker], time.monotonic() if monotonic_s is None
                                 else monotonic_s)

    def have_consumers(self) -> bool:
        return self._state.have_consumers()

    def close(self) -> None:
        del self._state, self._events
