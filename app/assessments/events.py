"""An assessment trial's cues as the trial file's timed events: what the patient was shown
and when, on the trial's clock (docs/data-format.md, Events).

A task cued by the reference's segments (core.assessment.protocol.cues) gets one
`assessment_cue` event per cue; a robot-led task whose trajectory tells its own phases
(an `events()` method: core.holdtasks) gets one per phase; the live loop writes the same
events on their ticks (device.loop.pipeline). Only cues within the ticks the trial ran are
events: a trial stopped early never showed the rest.
"""

from __future__ import annotations

from core.assessment.protocol import CUE_EVENT, task_events
from core.trial import TrialParameters


def cue_events(parameters: TrialParameters, exercise_tick: int, period_s: float,
               n_ticks: int) -> list[dict]:
    """The events of the trial's cues (core.assessment.protocol.task_events, as the live
    loop writes them: device.loop.pipeline), the exercise starting at tick `exercise_tick`,
    for the `n_ticks` the trial ran ([] for an exercise)."""
    out = []
    for time_s, message, values in task_events(parameters):
        tick = exercise_tick + round(time_s / period_s)
        if tick >= n_ticks:
            break
        out.append({"time_s": tick * period_s, "tick": tick, "kind": CUE_EVENT,
                    "message": message, "values": values})
    return out
