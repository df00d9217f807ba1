"""Position sense from its trial (issue 31): the robot took the relaxed hand to each target
and back with the patient's screen blank, then let go (core.holdtasks: centre, out, there,
back, settle, match, home); the patient moved the hand to where it had been and held it.
The errors of the matches against the targets (core.assessment.position_sense), and how
many targets the patient did not match at all.

A match's *reproduced position* is the hand's mean position over its last HELD_S, the
time the patient is asked to hold still before the way home. A match in which the hand
never went further than NOT_MOVED_SHARE of the target's distance from the centre was not
made (a passive or absent patient: the hand stays where the robot left it): NaN, left out
of the errors and counted (`position_not_reproduced_count`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from core.assessment.position_sense import position_figures as figures_of
from core.trial import TrialParameters

HELD_S = 0.5
"""The end of the match the reproduced position is averaged over."""
NOT_MOVED_SHARE = 0.25
"""A hand that went no further from the centre than this share of the target's distance
did not try to match it (2.5 cm for the protocol's 10 cm)."""


def matches(samples: Mapping[str, np.ndarray], parameters: TrialParameters
            ) -> tuple[np.ndarray, np.ndarray]:
    """(targets (K, 2) m, reproduced (K, 2) m, NaN rows for matches not made) of one
    trial's exercise samples (time s, position m), in the order of the timetable."""
    t = np.asarray(samples["time"], dtype=float)
    position = np.asarray(samples["position"], dtype=float)
    start = float(t[0])
    centre = np.asarray(parameters.centre_m, dtype=float)
    targets, reproduced = [], []
    for stretch in parameters.trajectory().stretches:
        if stretch.phase != "match":
            continue
        target = np.asarray(dict(stretch.values)["target_m"], dtype=float)
        begin, end = start + stretch.start_s, start + stretch.stop_s
        during = (t >= begin) & (t < end)
        held = (t >= end - HELD_S) & (t < end)
        point = np.full(2, np.nan)
        if held.any():
            reach = float(np.hypot(*(position[during] - centre).T).max())
            if reach > NOT_MOVED_SHARE * float(np.hypot(*(target - centre))):
                point = position[held].mean(axis=0)
        targets.append(target)
        reproduced.append(point)
    return np.array(targets).reshape(-1, 2), np.array(reproduced).reshape(-1, 2)


def position_figures(samples: Mapping[str, np.ndarray],
                     parameters: TrialParameters) -> dict[str, float]:
    """The position-sense task's figures (core.assessment.FIGURES) of one trial's exercise
    samples (app.assessments.figures.CHANNELS_NEEDED)."""
    return figures_of(*matches(samples, parameters))
