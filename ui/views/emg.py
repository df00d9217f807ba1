"""What the EMG tab shows for a trial file, computed without Qt: each muscle's envelope in
% MVC on the trial's ticks (app.emg.session.trial_envelopes), its MVC's flags, or the one
line that says why there is nothing to show."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from app.emg.session import trial_envelopes
from app.errors import AppError
from core.errors import CoreError
from device.errors import DeviceError
from device.recording.emgfile import read_emg


@dataclass(frozen=True, slots=True, eq=False)
class EmgView:
    time_s: np.ndarray = field(default_factory=lambda: np.empty(0))
    percent: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))  # (N, C) % MVC
    muscles: tuple[str, ...] = ()
    flags: dict = field(default_factory=dict)
    message: str = ""

    @property
    def peaks(self) -> dict[str, float]:
        """Each muscle's highest % MVC over the trial."""
        return {m: float(np.nanmax(self.percent[:, i])) if np.isfinite(self.percent[:, i]).any()
                else float("nan") for i, m in enumerate(self.muscles)}


def emg_view(path: Path | None) -> EmgView:
    if path is None:
        return EmgView(message="No trial file yet: EMG shows here once a trial is saved.")
    try:
        if read_emg(path) is None:
            return EmgView(message="This trial has no EMG. Import it with "
                                   "`rehab emg import TRIAL FILE`.")
        env = trial_envelopes(path)
    except (AppError, CoreError, DeviceError) as exc:
        return EmgView(message=str(exc))
    return EmgView(env.time_s, 100.0 * env.values, env.muscles, env.flags)
