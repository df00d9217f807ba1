"""Isometric strength from its trial (issue 31): the robot held the handle at the centre
(core.control.hold) while the patient pushed toward each direction in turn
(core.holdtasks: ready, push, rest); per direction the peak and the mean of the hand's
force along it over the push (core.assessment.strength), the pushes that reached the
robot's limit counted.

Which samples are a push comes from the trial's parameters alone: the task's timetable
(TrialParameters.trajectory()) puts each push at a fixed time after the exercise's first
sample, which is when the patient's screen showed it and when the trial file's
`assessment_cue` event says it began.

A push is *at the robot's limit* (`PushWindow.at_limit`; its figures are lower bounds of
the patient's strength) when its force along the direction reached AT_LINE of the line
the patient was shown (a push the robot could hold was cut there by the protocol), or
when the handle gave more than GAVE_WAY_M off the centre (the robot could not hold the
push: core.control.hold's hold gives at most about 3 mm under a push up to the line,
tests/device/test_hold_loop.py).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from core.assessment.strength import PushWindow, strength_figures as figures_of
from core.trial import TrialParameters

AT_LINE = 0.95
"""A push whose force along its direction reached this share of the line it was shown
reached the robot's limit (the force rises toward the line and stays within a few
per cent of it once there)."""
GAVE_WAY_M = 0.01
"""A handle this far off the centre during a push: the robot could not hold it."""


def push_windows(samples: Mapping[str, np.ndarray], parameters: TrialParameters
                 ) -> list[PushWindow]:
    """Each push of the trial's exercise samples (time s, position m, force N in the
    robot's frame) as a PushWindow on the samples' clock, flagged at the robot's limit
    (module notes)."""
    t = np.asarray(samples["time"], dtype=float)
    position = np.asarray(samples["position"], dtype=float)
    force = np.asarray(samples["force"], dtype=float)
    start = float(t[0])
    centre = np.asarray(parameters.centre_m, dtype=float)
    out = []
    for stretch in parameters.trajectory().stretches:
        if stretch.phase != "push":
            continue
        values = dict(stretch.values)
        begin, end = start + stretch.start_s, start + stretch.stop_s
        inside = (t >= begin) & (t <= end)
        at_limit = False
        if inside.any():
            along = force[inside] @ np.asarray(stretch.push)
            gave = float(np.hypot(*(position[inside] - centre).T).max())
            at_limit = bool(along.max() >= AT_LINE * values["line_N"] or gave > GAVE_WAY_M)
        out.append(PushWindow(values["direction_rad"], begin, end, at_limit))
    return out


def strength_figures(samples: Mapping[str, np.ndarray],
                     parameters: TrialParameters) -> dict[str, float]:
    """The strength task's figures (core.assessment.FIGURES) of one trial's exercise
    samples (app.assessments.figures.CHANNELS_NEEDED)."""
    windows = push_windows(samples, parameters)
    return figures_of(samples["time"], samples["force"], windows)


def lines_N(parameters: TrialParameters) -> dict[int, float]:
    """The line each direction's push was shown, N, by direction in whole degrees (the
    report draws it on the polar plot: what the robot could hold there)."""
    out: dict[int, float] = {}
    for stretch in parameters.trajectory().stretches:
        if stretch.phase == "push":
            values = dict(stretch.values)
            out[int(values["direction_deg"])] = float(values["line_N"])
    return out
