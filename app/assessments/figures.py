"""An assessment trial's figures from its recorded channels: the task's cues (or the
robot-led task's events) on the trial's clock, the hand's samples over the exercise, and
metrics' pure functions of them (core.assessment), keyed as core.assessment.FIGURES.

The exercise's first sample is the clock's zero for the cues (core.assessment.protocol.cues:
the reference's segments start there, and the patient's screen follows the same clock).
A task whose figures this console cannot compute yet gives none, with a note saying so.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np

from app.assessments.position import position_figures
from app.assessments.strength import strength_figures
from core.assessment.protocol import cues
from core.reaches import Reach
from core.trial import TrialParameters

CHANNELS_NEEDED = ("time", "phase", "position", "subject_angle", "force")
"""The recorded channels a task's figures may read."""


def assessment_figures(channels: Mapping[str, np.ndarray], parameters: TrialParameters,
                       exercise: slice | np.ndarray) -> tuple[dict[str, float], tuple[str, ...]]:
    """The figures of the assessment trial (`parameters.assessment`) and notes; ({}, ())
    for an exercise. `exercise` selects the exercise phase's samples of `channels`."""
    task = parameters.assessment
    if not task:
        return {}, ()
    of_task = TASK_FIGURES.get(task)
    if of_task is None:
        return {}, (f"the {task} task's figures are not computed by this console yet",)
    chosen = through_rest(channels, exercise) if task in MEASURED_TO_REST else exercise
    samples = {name: np.asarray(values)[chosen] for name, values in channels.items()
               if name in CHANNELS_NEEDED}
    return _plain(of_task(samples, parameters)), ()


MEASURED_TO_REST = ("circle",)
"""The tasks whose figures also read the hold after the exercise (the circle's smoothness
over a movement from rest to rest: core.assessment.circle)."""


def through_rest(channels: Mapping[str, np.ndarray], exercise: slice | np.ndarray
                 ) -> np.ndarray:
    """The samples `exercise` selects and the hold right after them (device.loop.plan:
    the reference at rest for HOLD_S once the exercise ends), as a boolean mask."""
    from device.loop.pipeline import PHASE_HOLD

    phase = np.asarray(channels["phase"])
    chosen = np.zeros(phase.size, dtype=bool)
    chosen[exercise] = True
    if chosen.any():
        last = int(np.flatnonzero(chosen)[-1])
        after = phase[last + 1:] != PHASE_HOLD
        end = last + 1 + (int(np.argmax(after)) if after.any() else after.size)
        chosen[last + 1:end] = True
    return chosen


def reaching_figures(samples: Mapping[str, np.ndarray],
                     parameters: TrialParameters) -> dict[str, float]:
    """Visually guided reaching (Coderre et al. 2010; core.assessment.reaching): each
    target's reach from its appearance to the centre's, the task's means and counts."""
    from core.assessment.reaching import vgr_figures, vgr_reaches

    t_s, position_m = samples["time"], samples["position"]
    start = float(t_s[0])
    shown = cues(parameters)
    reaches = [Reach(c.time_s + start, c.start_m, c.point_m) for c in shown
               if c.kind == "target"]
    ends = [c.time_s + start for c in shown if c.kind == "home"]
    return vgr_figures(vgr_reaches(t_s, position_m, reaches, ends_s=ends))


def circle_figures(samples: Mapping[str, np.ndarray],
                   parameters: TrialParameters) -> dict[str, float]:
    """Circle drawing, one way round (core.assessment.circle), from the exercise's samples
    and the hold's after them: a trial draws its circle one way, so its figures are that
    way's (`circle_ratio_cw`, …); the task's, the mean of the
    two ways, need both trials (`circle_task`)."""
    from core.assessment.circle import circle_figures as one_circle
    from core.assessment.figures import circle_key
    from device.loop.pipeline import PHASE_EXERCISE

    way = "cw" if parameters.clockwise else "ccw"
    drawn = one_circle(samples["time"], samples["position"], samples["subject_angle"],
                       drawing=np.asarray(samples["phase"]) == PHASE_EXERCISE)
    return {circle_key(base, way): value for base, value in drawn.items()}


def circle_task(cw: Mapping[str, float], ccw: Mapping[str, float]) -> dict[str, float]:
    """The circle task's figures (each way's and their mean) from the clockwise trial's
    metrics and the counter-clockwise trial's (`circle_figures` of each)."""
    from core.assessment.circle import circle_task_figures
    from core.assessment.figures import CIRCLE_BASE_KEYS, circle_key

    return circle_task_figures({b: cw[circle_key(b, "cw")] for b in CIRCLE_BASE_KEYS},
                               {b: ccw[circle_key(b, "ccw")] for b in CIRCLE_BASE_KEYS})


def range_figures(samples: Mapping[str, np.ndarray],
                  parameters: TrialParameters) -> dict[str, float]:
    """Active range (core.assessment.active_range): the area the hand covered over the
    region the robot and this arm both reach from the centre, within the task's box
    (core.assessment.workspace)."""
    from core.assessment.active_range import range_figures as area_figures
    from core.assessment.workspace import common_region, range_box

    region = common_region(parameters, box_m=range_box(parameters))
    return area_figures(samples["position"], region)


TaskFigures = Callable[[Mapping[str, np.ndarray], TrialParameters], Mapping[str, float]]
TASK_FIGURES: dict[str, TaskFigures] = {
    "reaching": reaching_figures,
    "circle": circle_figures,
    "range": range_figures,
    "strength": strength_figures,
    "position": position_figures,
}
"""Each task's figures from its exercise's samples (CHANNELS_NEEDED, those recorded) and
its parameters."""


def _plain(figures: Mapping[str, float]) -> dict[str, float]:
    return {key: float(value) if math.isfinite(value) else math.nan
            for key, value in figures.items()}


def assessment_figures_stored(read, n_ticks: int, names, parameters: TrialParameters
                              ) -> tuple[dict[str, float], tuple[str, ...]]:
    """`assessment_figures` of a trial read from its file (app.trials.analysis.
    analyse_stored): an assessment trial is minutes long at most, so the channels it needs
    are read whole."""
    if not parameters.assessment:
        return {}, ()
    channels = {name: np.asarray(read(name, 0, n_ticks)) for name in CHANNELS_NEEDED
                if name in names}
    return assessment_figures(channels, parameters, exercise_of(channels))


def exercise_of(channels: Mapping[str, np.ndarray]) -> np.ndarray:
    """The exercise phase's samples (device.loop.pipeline.PHASE_EXERCISE)."""
    from device.loop.pipeline import PHASE_EXERCISE

    return np.asarray(channels["phase"]) == PHASE_EXERCISE
