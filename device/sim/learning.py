"""A virtual patient that adapts from trial to trial: it learns from the errors it feels
and forgets, so it *slacks* when the robot takes the errors away.

The model is the one Emken, Benitez and Reinkensmeyer fitted to people adapting to a
robot (J NeuroEng Rehabil 2007, 4:8): from one trial to the next the motor command is
kept with a retention factor and corrected in proportion to the error felt,

    a_{n+1} = clip(f_h a_n + g_h min(e_n / e_ref, 1), 0, 1)

with a_n the share of the patient's capability used in trial n (the VirtualPatient's
`effort` is a_n × its profile's effort: 1 for a healthy subject, 0.4 for the weak one),
e_n the RMS distance of the hand from where the patient meant it to be (their own
desired motion, on the trial's clock), e_ref the error a patient clearly feels, and
f_h < 1 the share of last trial's effort kept. With no error felt the effort decays by
f_h each trial: this is the slacking Wolbrecht et al. observed (IEEE TNSRE 2008,
16(3):286) when a robot does the work. A robot that holds the hand on the path
whatever the patient does (the thesis mode's stiff tracker) takes the error away, so
the effort decays; one that lets the patient fall behind before it helps (the as-needed
mode) leaves the error that keeps the effort up.

The defaults: f_h = 0.85 and g_h = 0.15 are of the order of the retention and learning
rates fitted in that literature (retention 0.8–0.95 per trial, learning rates 0.1–0.3);
e_ref = 10 mm is about the hand's position sense in the horizontal plane. They are the
model's choices, not a fit to our patients; the benchmark that uses them prints them
(bench/slacking.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.errors import check_range


@dataclass(frozen=True, slots=True)
class TrialToTrialAdaptation:
    """The adaptation rule above; `next_share` is one step of it."""

    retention: float = 0.85
    learning: float = 0.15
    felt_error_m: float = 0.010

    def __post_init__(self) -> None:
        check_range("retention", self.retention, 0.0, 1.0, "",
                    "the share of last trial's effort kept")
        check_range("learning", self.learning, 0.0, 1.0, "",
                    "the effort added per trial for an error of felt_error_m")
        check_range("felt_error_m", self.felt_error_m, 0.0, 0.2, "m",
                    "the error a patient clearly feels", low_open=True)

    def next_share(self, share: float, error_m: float) -> float:
        """The share of capability used in the next trial after one with `error_m`."""
        felt = min(error_m / self.felt_error_m, 1.0) if math.isfinite(error_m) else 1.0
        value = self.retention * share + self.learning * felt
        return 0.0 if value < 0.0 else (1.0 if value > 1.0 else value)


def intent_error_m(position_m, intended_m) -> float:
    """RMS distance (m) of the hand from where the patient meant it to be: positions
    (N, 2) and intended positions (N, 2), sample by sample; NaN for no samples."""
    position = np.asarray(position_m, dtype=float)
    intended = np.asarray(intended_m, dtype=float)
    if len(position) == 0:
        return math.nan
    return float(np.sqrt(np.mean(np.sum((position - intended) ** 2, axis=1))))
