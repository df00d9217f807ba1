"""A replayed trial at one moment, in the words and units a therapist reads: the rows of
the Replay tab's "At this moment" box, and the line that names a trial in its list."""

from __future__ import annotations

import math

import numpy as np

from app.records.registry import Trial
from app.reports.progress import exercise_of
from app.units import CM_PER_M
from device.loop.pipeline import PHASE_APPROACH, PHASE_EXERCISE, PHASE_HOLD, PHASE_IDLE
from device.safety.faults import Fault
from ui.views.numbers import format_number
from ui.views.trialview import TrialView

MOMENT_ROWS = (("phase", "Part of the trial"), ("position", "Hand position"),
               ("force", "Push on the handle"), ("angles", "Shoulder, elbow angle (ISB)"),
               ("torques", "Shoulder, elbow torque"), ("fault", "Safety"))
"""(key, label) of each row `moment` fills, in the order shown."""
PHASE_WORDS = {PHASE_IDLE: "robot not controlling", PHASE_APPROACH: "moving to the start",
               PHASE_EXERCISE: "exercise", PHASE_HOLD: "holding at the end"}
STATUS_WORDS = {"complete": "complete", "stopped_early": "stopped early",
                "faulted": "safety stop", "recording_lost": "recording lost",
                "recording": "not closed"}


def moment(view: TrialView, i: int) -> dict[str, str]:
    """What the recording says at sample i, in the units a therapist reads."""
    phase = int(view.column("phase")[0, i])
    x, y = view.column("position")[:, i] * CM_PER_M
    fx, fy = view.column("force")[:, i]
    magnitude = math.hypot(fx, fy)
    if phase != PHASE_EXERCISE:
        aim = ""
    elif view.within[i]:
        aim = f", within {math.degrees(view.tolerance_rad):.0f}° of the path's direction"
    else:
        aim = ", not along the path" if math.isfinite(view.column("force_angle")[0, i]) \
            else ", too light to tell its direction"
    shoulder, elbow = np.degrees(view.column("subject_angle_isb")[:, i])
    ts, te = view.column("subject_torque")[:, i]
    code = int(view.column("fault")[0, i])
    try:
        fault = "no fault" if code == 0 else Fault(code).text.cause.split("{")[0].rstrip(" (:")
    except ValueError:
        fault = f"fault code {code}"
    return {
        "phase": PHASE_WORDS.get(phase, f"phase {phase}"),
        "position": f"x {format_number(x)} cm, y {format_number(y)} cm",
        "force": f"{format_number(magnitude, 2)} N{aim}",
        "angles": f"{format_number(shoulder)}°, {format_number(elbow)}°",
        "torques": f"{format_number(ts, 2)} N·m, {format_number(te, 2)} N·m",
        "fault": fault,
    }


def describe_trial(trial: Trial, station: str | None = None) -> str:
    """Two lines for the list of a patient's trials: numbers, local start time, status,
    and the station that recorded it when not this one (`station`: a patient seen at
    several stations of a shared registry); then what it was, named as the Progress tab
    names its series (an assessment task's or a game's name first:
    app.reports.progress.Exercise.label), so a game or an assessment is told from the
    exercise of its shape."""
    started = trial.started_at.astimezone().strftime("%d %b %Y %H:%M")
    status = STATUS_WORDS.get(trial.status, trial.status)
    line = f"Session {trial.session_number}, trial {trial.number} — {started} — {status}"
    if trial.station is not None and trial.station != station:
        line += f" — at {trial.station}"
    if not trial.parameters.get("shape"):  # no exercise stored to name (not "?")
        return line
    return f"{line}\n{exercise_of(trial.assist, trial.parameters).label()}"
