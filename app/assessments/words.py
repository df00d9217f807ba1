"""A task the robot leads (isometric strength, position sense: core.holdtasks) in words,
once for every place that says what it is: the Assessments tab's protocol, the Parameters
tab's summary, `rehab assess tasks` and the report's Exercise line; and a task the patient
paces, its rounds or laps (`laps_words`), for the protocol and the report alike.

Said as an exercise is ("1 × 3 s, robot transparent", "Path 80 cm per traversal, fastest
0 mm/s") a 48 s strength trial read as 3 s, with the robot said not to hold the hand it
holds: `duration_s` is one push or one match there, and the hand follows no path.
"""

from __future__ import annotations

from app.units import CM_PER_M
from core.holdtasks import ROBOT_TASKS
from core.trial import TrialParameters


def planned_exercise_s(p: TrialParameters) -> float:
    """The exercise's length on its clock: the path's laps, or, for a task the robot
    leads, its whole timetable (a strength trial stopped at 9.6 s read "stopped early
    after 9.6 of 3 s")."""
    if p.assessment in ROBOT_TASKS:
        return p.trajectory().total_duration_s
    return p.duration_s * p.repetitions


def laps_words(p: TrialParameters) -> str:
    """'2 rounds of 48 s' or '5 laps of 4 s': a task the patient paces, its repetitions as
    the Assessments tab's protocol and the report's Exercise line both say them. A round
    visits every target once, a lap goes once round the path ("1 trial, 2 × 48 s each"
    read as two trials; the report said "2 repetitions of 48 s" of the trial the tab
    called "2 rounds of 48 s")."""
    unit = "round" if p.shape == "targets" else "lap"
    return f"{p.repetitions} {unit}{'s' if p.repetitions != 1 else ''} of {p.duration_s:g} s"


TURN_WORDS = {True: "clockwise", False: "counter-clockwise"}
"""A path's direction (TrialParameters.clockwise) in words, as the circle task's protocol
names its two trials (core.assessment.protocol); the report said "anticlockwise"."""


ROBOT_ROLE = {"strength": "robot holds the handle still",
              "position": "robot takes the hand to each target"}
"""A task the robot leads, in a few words where a series or a trial is named in a list
(the Progress tab, Replay): named as an exercise ("Transparent · point-to-point targets,
r 5.0 cm") the strength task read as a transparent reaching exercise."""


def robot_task_words(p: TrialParameters, *, past: bool = False) -> str:
    """'8 directions, a push of 3 s each; 1 round, 48 s; the robot holds the handle
    still' (`past`: as the report tells a trial run, 'held')."""
    rounds = "1 round" if p.repetitions == 1 else f"{p.repetitions} rounds"
    total = f"{round(planned_exercise_s(p), 1):g}"
    if p.assessment == "strength":
        what = f"{p.n_targets} directions, a push of {p.duration_s:g} s each"
    else:
        what = (f"{p.n_targets} targets {p.radius_m * CM_PER_M:.3g} cm from the centre, "
                f"{p.duration_s:g} s to find each")
    return f"{what}; {rounds}, {total} s; {robot_doing(p, past=past)}"


def robot_doing(p: TrialParameters, *, past: bool = False) -> str:
    """What the robot does in a task it leads: 'the robot holds the handle still' (`past`:
    'held'); the report's help line says it too (it said the transparent mode's "the robot
    only makes itself lighter" under "the robot held the handle still")."""
    if p.assessment == "strength":
        return "the robot held the handle still" if past else "the robot holds the handle still"
    return ("the robot took the hand to each target and back" if past else
            "the robot takes the relaxed hand to each target and back, then lets go")
