"""An assessment trial's cues as the trial file's timed events: what the patient was shown
and when, on the trial's clock (docs/data-format.md, Events).

A task cued by the reference's segments (core.assessment.protocol.cues) gets one
`assessment_cue` event per cue; a robot-led task whose trajectory tells its own phases
(an `events()` method: core.holdtasks) gets one per phase. Only cues within the ticks the
trial ran are events: a trial stopped early never showed the rest.
"""

from __future__ import annotations

from core.assessment.protocol import CUED_TASKS, cues
from core.trial import TrialParameters

CUE_EVENT = "assessment_cue"


def cue_events(parameters: TrialParameters, exercise_tick: int, period_s: float,
               n_ticks: int) -> list[dict]:
    """The events of the trial's cues, the exercise starting at tick `exercise_tick`, for
    the `n_ticks` the trial ran ([] for an exercise)."""
    shown: list[tuple[float, str, dict]] = []
    if parameters.assessment in CUED_TASKS:
        for cue in cues(parameters):
            what = "target" if cue.kind == "target" else "centre"
            shown.append((cue.time_s, f"{what} shown", {
                "cue": cue.kind, "target": cue.target, "repetition": cue.repetition,
                "point_m": list(cue.point_m), "start_m": list(cue.start_m)}))
    elif parameters.assessment:
        trajectory = parameters.trajectory()
        phases = getattr(trajectory, "events", None)
        if phases is not None:
            for time_s, phase, values in phases():
                shown.append((float(time_s), str(phase), dict(values)))
    out = []
    for time_s, message, values in shown:
        tick = exercise_tick + round(time_s / period_s)
        if tick >= n_ticks:
            break
        out.append({"time_s": tick * period_s, "tick": tick, "kind": CUE_EVENT,
                     "message": message, "values": {"task": parameters.assessment, **values}})
    return out
