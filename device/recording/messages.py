"""What the loop tells the recorder about a trial, and what the recorder tells the console.

    loop ──BeginTrial, TrialEvent, EndTrial──▶ recorder ──RecorderNotice──▶ console

Records themselves travel through the shared-memory ring (device.recording.ring); these
messages say which of them belong to which trial file, and what happened in it.
"""

from __future__ import annotations

from dataclasses import dataclass

from core.trial import TrialParameters
from device.recording.trialfile import SubjectInfo


# ------------------------------------------------------------------ loop → recorder
@dataclass(frozen=True, slots=True)
class BeginTrial:
    """Records from ring sequence number `first_seq` on belong to the trial at `path`."""

    path: str
    first_seq: int
    parameters: TrialParameters
    subject: SubjectInfo
    robot: dict
    backend: str
    sample_period_s: float


@dataclass(frozen=True, slots=True)
class TrialEvent:
    time_s: float
    tick: int
    kind: str
    message: str
    values: dict


@dataclass(frozen=True, slots=True)
class EndTrial:
    """The trial's records end before ring sequence number `end_seq`."""

    end_seq: int
    status: str
    summary: dict
    assistance: dict | None = None
    """The trial file's /assistance group (docs/data-format.md), or None."""


# ------------------------------------------------------------------ recorder → console
@dataclass(frozen=True, slots=True)
class RecorderNotice:
    """The recorder opened or closed a trial file, or could not write it."""

    kind: str  # "opened" | "closed" | "error" | "lost" (a dead recorder's file unfinished)
    path: str
    status: str = ""
    message: str = ""
    samples: int = 0


# ------------------------------------------------------------------ recorder → loop
# What the recorder's shared `recording_failed` flag holds (the loop reads it every tick
# and faults RECORDING_LOST while it is not RECORDING_OK), so the fault names the cause.
RECORDING_OK = 0
WRITE_FAILED = 1
"""A write to the trial file failed (a disk error, the file system gone)."""
DISK_SHORT = 2
"""The disk is full: the recorder ends the trial's file on the space it holds."""
STOPPED_BY_SIGNAL = 64
"""Plus the signal's number: the recorder process was told to stop (SIGINT, SIGTERM,
SIGHUP, device.stopsignals)."""

RECORDER_BEAT_S = 0.05
"""How often the recorder raises its beat counter, which the loop watches for a stopped
recorder (device.loop.recorder_watch)."""
