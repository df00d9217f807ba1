"""A whole trial held in memory written at once (`write_trial`: headless runs, tests,
conversions), through the same writer as a live trial (device.recording.trialfile.writer)."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from core.trial import TrialParameters
from device.recording.record import CHANNELS, Channel
from device.recording.trialfile.layout import SubjectInfo
from device.recording.trialfile.writer import TrialFileWriter


def write_trial(
    path: str | os.PathLike,
    records: np.ndarray,
    *,
    parameters: TrialParameters,
    subject: SubjectInfo,
    robot: Mapping | object,
    backend: str,
    sample_period_s: float,
    channels: tuple[Channel, ...] = CHANNELS,
    events: Iterable[Mapping] = (),
    status: str = "complete",
    summary: Mapping | None = None,
    metrics: Mapping | None = None,
    assistance: Mapping | None = None,
) -> Path:
    """Write a whole trial held in memory (headless runs, tests, conversions).

    Events are mappings with time_s, tick, kind, message and optional values, as
    the reader returns them.
    """
    writer = TrialFileWriter(
        path, parameters=parameters, subject=subject, robot=robot, backend=backend,
        sample_period_s=sample_period_s, channels=channels, live=False,
        flush_interval_s=None,
    )
    try:
        writer.append(records)
        for event in events:
            writer.add_event(event["time_s"], event["tick"], event["kind"], event["message"],
                             event.get("values"))
    except BaseException:
        writer.close("recording_lost")
        raise
    return writer.close(status, summary, metrics, assistance)
