"""A trial's view records made to order on its timetable, for the tests of what the
patient's screen shows at each moment (ui.views.patient_screen)."""

from __future__ import annotations

import numpy as np

from device.loop.pipeline import PERIOD_S, PHASE_APPROACH, PHASE_EXERCISE, PHASE_HOLD
from device.recording.record import RECORD_DTYPE
from ui.views.trialview import VIEW_CHANNELS


def on_the_path(params, approach: int, hold: int, exercise: int | None = None) -> np.ndarray:
    """Records of the view's channels: `approach` samples of the approach, `exercise` of
    the exercise (default: the trajectory's whole duration), `hold` of the hold; the
    reference from the trajectory (at its start before the exercise) and the hand on it."""
    trajectory = params.trajectory()
    if exercise is None:
        exercise = round(trajectory.total_duration_s / PERIOD_S)
    n = approach + exercise + hold
    dtype = np.dtype([(c, RECORD_DTYPE.fields[c][0]) for c in VIEW_CHANNELS])
    r = np.zeros(n, dtype=dtype)
    r["time"] = np.arange(n) * PERIOD_S
    r["phase"][:approach] = PHASE_APPROACH
    r["phase"][approach:approach + exercise] = PHASE_EXERCISE
    r["phase"][approach + exercise:] = PHASE_HOLD
    sample = trajectory.sample(np.clip(r["time"] - approach * PERIOD_S, 0.0, None))
    r["position_desired"] = sample.position_m
    r["direction_desired"] = sample.direction
    r["position"] = sample.position_m
    return r
