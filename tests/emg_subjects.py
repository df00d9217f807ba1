"""Synthetic EMG subjects' trials for the tests of the EMG estimate of the patient's force
(app.emg.estimate, app.emg.feed, `rehab emg model --save`, `rehab run --force-estimate`)."""

from __future__ import annotations

import math
from pathlib import Path

from app.emg.session import Contraction, session_mvc
from app.emg.subjects import Subject, record_trial, write_contractions
from core.trial import THESIS_SUBJECT

WIDE_CONE_RAD = math.radians(30)
"""The cone subject 1's EMG estimate is shown to judge as the sensor does (at the thesis's
20° it is not: docs/validation.md, "EMG in place of the force sensor")."""


def record_session(folder: Path, *, trials: int = 3, repetitions: int = 2,
                   tolerance_rad: float = WIDE_CONE_RAD, number: int = 1) -> list[Path]:
    """A synthetic subject's session: `trials` trials with the motors giving no help, and
    its MVCs stored in each."""
    subject = Subject.drawn(number)
    params = THESIS_SUBJECT.replace(repetitions=repetitions, assistance_level=0.0,
                                    tolerance_rad=tolerance_rad)
    paths = [record_trial(folder / f"S{number}_w{k}.h5", subject, seed=k,
                          parameters=params).path for k in range(trials)]
    contractions = write_contractions(folder, subject, session=1)
    session_mvc(paths, [Contraction(m, p, ch) for m, (p, ch) in contractions.items()],
                full_scale_V=subject.electrodes.full_scale_V)
    return paths
