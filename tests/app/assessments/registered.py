"""Trials registered for a patient as the console registers them (begin, its file at the
registry's path, finish with its metrics), without simulating them: a short file with the
figures given as its metrics, for the commands that read the registry and the files'
summaries (the robot the norms take from `{"plant": "realistic"}`)."""

from __future__ import annotations

import datetime

import numpy as np

from core.trial import THESIS_SUBJECT, TrialParameters
from device.recording.record import CHANNELS, RECORD_DTYPE
from device.recording.trialfile import SubjectInfo, write_trial

PERIOD_S = 0.002
SIM = "simulator (healthy, seed 1)"
WHEN = datetime.datetime(2026, 6, 1, 10, tzinfo=datetime.UTC)


def register(registry, code: str, metrics: dict, *, task: str = "reaching",
             parameters: TrialParameters | None = None, when=WHEN, finish: bool = True):
    """Register one trial of `code` (an assessment of `task`, or an exercise when `task`
    is ""), its file written; finished with `metrics` unless `finish` is False (then the
    caller finalizes it). Returns the BegunTrial."""
    patient = registry.patient(code)
    params = (parameters or THESIS_SUBJECT).replace(assessment=task,
                                                     side=patient.side or "right")
    begun = registry.begin_trial(code, params, backend=SIM, started_at=when)
    records = np.zeros(10, dtype=RECORD_DTYPE)
    records["tick"] = np.arange(10)
    records["time"] = np.arange(10) * PERIOD_S
    begun.path.parent.mkdir(parents=True, exist_ok=True)
    write_trial(begun.path, records, parameters=params,
                subject=SubjectInfo.from_parameters(code, params), robot={}, backend=SIM,
                sample_period_s=PERIOD_S, channels=CHANNELS, summary={"plant": "realistic"},
                metrics=metrics)
    if finish:
        registry.finish_trial(begun.trial_id, "complete", metrics, when)
    return begun
