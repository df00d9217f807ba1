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

    kind: str  # "opened" | "closed" | "error"
    path: str
    status: str = ""
    message: str = ""
    samples: int = 0
