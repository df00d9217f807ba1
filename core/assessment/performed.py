"""Whether a patient performed an assessment task at all, from the task's figures.

A patient who makes no movement in any reach, never moves round the circle or reproduces
no position has no reaction time, no circle ratio, no matching error: the task's figures
are undefined, and a task score made of them would be undefined too. Clinically that is
the worst result, not a missing one: Kinarm's reports, like the clinical scales (a
Fugl-Meyer item scored 0, "cannot perform"), record a task the patient could not do as
such. So a task the patient did not perform is named with the reason, and reports rank it
below every task score (app.norms.model.TaskNotPerformed).

The rules (each from the task's own counts of attempts, so a trial cut short or a figure
left undefined for another reason is not mistaken for one):

* reaching: every reach of the protocol (targets × repetitions) had no reaction
  (Coderre et al. 2010: no speed rise above the reaction threshold in the time allowed);
* circle: in both directions (each the trial holds) the hand's mean speed stayed under
  the speed of a movement (core.reaches.DEFAULT_MIN_PEAK_SPEED_M_S, the circle's own
  threshold for its smoothness: below it the speed is rounding and encoder noise);
* position: no target reproduced in any of the protocol's matches.

Active range and isometric strength have figures that stay defined at no movement (an
area of 0, a force of 0) and score as such.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from core.assessment.figures import CIRCLE_WAYS, circle_key
from core.assessment.protocol import protocol
from core.reaches import DEFAULT_MIN_PEAK_SPEED_M_S


def not_performed(task: str, metrics: Mapping[str, object]) -> str:
    """Why the patient did not perform `task` in a trial with these figures, or "" when
    they did (or the figures cannot tell: a count or speed missing or not a number)."""
    spec = protocol(task)
    attempts = spec.n_targets * spec.repetitions
    if task == "reaching":
        count = _number(metrics.get("vgr_no_reaction_count"))
        if count is not None and count >= attempts:
            return f"no reaction in any of the {attempts} reaches"
    elif task == "circle":
        # Each way's speed when the trial holds it (a trial of one way holds one), else
        # the task's mean of both.
        keys = [circle_key("circle_mean_speed_m_s", way) for way in CIRCLE_WAYS]
        keys = [k for k in keys if k in metrics] or ["circle_mean_speed_m_s"]
        speeds = [_number(metrics.get(key)) for key in keys]
        if all(s is not None and s < DEFAULT_MIN_PEAK_SPEED_M_S for s in speeds):
            return (f"the hand moved round the circle at under "
                    f"{DEFAULT_MIN_PEAK_SPEED_M_S * 100:g} cm/s on average"
                    + (" both ways" if len(keys) == 2 else ""))
    elif task == "position":
        count = _number(metrics.get("position_not_reproduced_count"))
        if count is not None and count >= attempts:
            return f"no position reproduced in any of the {attempts} matches"
    return ""


def _number(value: object) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None
