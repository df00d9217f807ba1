"""Synthetic EMG subjects' trials for the tests of the EMG estimate of the patient's force
(app.emg.estimate, app.emg.feed, `rehab emg model --save`, `rehab run --force-estimate`)."""

from __future__ import annotations

import math
from pathlib import Path

from app.emg.subjects import Subject, record_session as record_subject

WIDE_CONE_RAD = math.radians(30)
"""The cone subject 1's EMG estimate is shown to judge as the sensor does (at the thesis's
20° it is not: docs/validation.md, "EMG in place of the force sensor")."""


def record_session(folder: Path, *, number: int = 1) -> list[Path]:
    """Subject `number`'s session of three trials of two repetitions with a 30° cone."""
    return record_subject(folder, Subject.drawn(number), tolerance_rad=WIDE_CONE_RAD)
