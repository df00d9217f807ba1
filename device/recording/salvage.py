"""A dead recorder's trial saved by the console: the samples that were still in the ring,
added to the trial file, which is then closed (issue 28, item 6).

The recorder flushes every 0.25 s, and a killed one takes with it what it had read from
the ring and not yet flushed (some 0.15 s; the loop stops the trial within 50 ms of the
death). Those records are still in the shared-memory ring, which the console owns and
the loop only overwrites a ring (16 s) later: the console takes over the file from the
dead writer (`TrialFileWriter.resume`), appends the trial's records after its last
whole sample, adds what the dead recorder could no longer write (the loop's fault and
stop, which went to it; why the file was taken over), and closes it `recording_lost`.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass

import numpy as np

from device.errors import DeviceError
from device.recording.messages import RecorderNotice
from device.recording.ring import RecordRing
from device.recording.trialfile import TrialFileWriter


@dataclass(frozen=True, slots=True)
class LostFault:
    """The fault the loop raised for the trial, as the console heard it."""

    message: str
    detail: dict


def salvage(path: str, ring: RecordRing, first_seq: int, end_seq: int,
            fault: LostFault | None = None, period_s: float = 0.002) -> RecorderNotice:
    """Finish the trial file at `path` whose recorder died: the trial's records (ring
    sequence numbers `first_seq` to `end_seq`) that the file lacks, the fault, and the
    close. Returns the notice the recorder would have sent: "closed", or "lost" with
    why when the file could not be finished (it then keeps what reached it)."""
    try:
        writer = TrialFileWriter.resume(path)
    except (DeviceError, OSError) as exc:
        return RecorderNotice("lost", path, "recording_lost",
                              f"the recorder stopped and its file could not be finished: {exc}")
    try:
        before = writer.n_samples
        last_tick = _last_tick(writer)
        # the trial's tick k is its ring record first_seq + k: one record per tick
        records, lost = _trial_records(ring, first_seq + last_tick + 1, end_seq)
        records = records[records["tick"] > last_tick]
        if len(records):
            writer.append(records)
        saved = len(records)
        ticks = (f" (ticks {int(records['tick'][0])}-{int(records['tick'][-1])})"
                 if saved else "")
        end_time, end_tick = _end(records, writer, period_s)
        writer.add_event(end_time, end_tick, "recording",
                         f"the recorder process stopped; the console saved the {saved} "
                         f"samples still in the ring{ticks}"
                         + (f", {lost} were already overwritten" if lost else ""),
                         {"cause": "recorder process stopped", "samples_saved": saved,
                          "samples_lost": lost})
        if fault is not None:
            tick, time_s = _fault_tick(records, period_s)
            writer.add_event(time_s, tick, "fault", fault.message, fault.detail)
        writer.add_event(end_time, end_tick, "stop", "stopped: the recorder process stopped",
                         {})
        writer.close("recording_lost", {"recorder_lost": 1.0,
                                        "samples_saved_from_ring": np.int64(saved)})
    except (DeviceError, OSError) as exc:
        if not writer.closed:
            with contextlib.suppress(DeviceError, OSError):
                writer.close("recording_lost")
        return RecorderNotice("lost", path, "recording_lost",
                              f"the recorder stopped and its file could not be finished: {exc}")
    return RecorderNotice("closed", path, "recording_lost",
                          f"the recorder process stopped; the console saved the {saved} "
                          "samples it had not written", before + saved)


def _trial_records(ring: RecordRing, from_seq: int, end_seq: int) -> tuple[np.ndarray, int]:
    """The ring's records `from_seq` to `end_seq`, and how many of them were overwritten."""
    stop = min(end_seq, ring.write_count)
    if stop <= from_seq:
        return np.empty(0, dtype=ring.dtype), 0
    batch = ring.read_new(from_seq, stop - from_seq)
    return batch.records, int(batch.lost)


def _last_tick(writer: TrialFileWriter) -> int:
    n = writer.n_samples
    if n == 0:
        return -1
    return int(writer.read_stretch("tick", n - 1, n)[0])


def _end(records: np.ndarray, writer: TrialFileWriter, period_s: float) -> tuple[float, int]:
    """The trial time and tick of the last sample the file now has."""
    if len(records):
        return float(records["time"][-1]), int(records["tick"][-1])
    tick = _last_tick(writer)
    return (tick * period_s if tick >= 0 else math.nan), tick


def _fault_tick(records: np.ndarray, period_s: float) -> tuple[int, float]:
    """The tick at which the fault latched (its first record with a fault code), or -1."""
    faulted = np.flatnonzero(records["fault"] != 0) if len(records) else np.empty(0)
    if not faulted.size:
        return -1, math.nan
    tick = int(records["tick"][faulted[0]])
    return tick, tick * period_s
