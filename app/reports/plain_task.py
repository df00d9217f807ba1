"""Plain words for an assessment task's own figures: the lines a patient reads on the
report of a task trial (core.assessment.FIGURES, docs/assessments.md).

A task trial has no path the patient follows at the robot's pace: the patient moves at
their own (device.sim.tasks; core.assessment.protocol), so the exercise's distance from
the path says nothing of them (app.reports.plain_language.patient_mode). What they did is
in the task's figures; the therapist's task page lists them all with their definitions,
norms and scores. The patient reads the few that mean something without the table, each
in words built from its number, in the units of app.units (mm and mm/s, cm² for an area,
whole per cent), a figure that is missing or NaN giving no line, as plain_language does.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from app.reports.plain_language import PlainLine, distance_text, force_text, mass_text, whole
from app.units import CM_PER_M, MM_S_PER_M_S
from core.assessment.figures import AT_LIMIT, CIRCLE_WAYS, STRENGTH_DIRECTIONS_DEG, circle_key


def task_lines(task: str, figures: Mapping[str, float]) -> tuple[PlainLine, ...]:
    """The patient's lines for one trial of `task` (core.assessment.TASKS) from its
    figures (keys of core.assessment.FIGURES, SI): the task's headline first; () for a
    task this console does not speak of or with no figure."""
    speak = _TASKS.get(task)
    if speak is None:
        return ()

    def value(key: str) -> float:
        try:
            number = float(figures.get(key, math.nan))
        except (TypeError, ValueError):
            return math.nan
        return number if math.isfinite(number) else math.nan

    return tuple(line for line in speak(value) if line is not None)


def _known(*numbers: float) -> bool:
    return all(math.isfinite(n) for n in numbers)


def _count(n: float, one: str, many: str) -> str:
    k = round(n)
    return f"{k} {one if k == 1 else many}"


def _reaching(value) -> list[PlainLine | None]:
    """Visually guided reaching (Coderre et al. 2010): time, straightness, how many pieces
    a reach took, the start, and the reaches that never came to rest."""
    movement, ratio = value("vgr_movement_time_s"), value("vgr_path_length_ratio")
    maxima, reaction = value("vgr_speed_maxima_count"), value("vgr_reaction_time_s")
    unfinished = value("vgr_no_movement_end_count")
    return [
        PlainLine("vgr_movement_time_s",
                  f"A reach took you {movement:.1f} seconds on average.",
                  "From when your hand started to move until it came to rest on the target.")
        if _known(movement) else None,
        PlainLine("vgr_path_length_ratio",
                  f"Your hand's path was {whole(100.0 * (ratio - 1.0))} % longer than the "
                  "straight line.",
                  "0 % would be perfectly straight from where you started to the target.")
        if _known(ratio) else None,
        PlainLine("vgr_speed_maxima_count",
                  f"Your hand sped up {maxima:.1f} times in a reach on average.",
                  "A smooth reach speeds up once and slows down once; more times means the "
                  "reach was made of several smaller movements.")
        if _known(maxima) else None,
        PlainLine("vgr_reaction_time_s",
                  f"You started to move {reaction:.1f} seconds after a target appeared.",
                  "On average, from the target showing on your screen to your hand moving.")
        if _known(reaction) else None,
        PlainLine("vgr_no_movement_end_count",
                  f"Your hand did not come to rest on {_count(unfinished, 'target', 'targets')}.",
                  "It was still moving, or had not arrived, when the next target came.")
        if _known(unfinished) and unfinished >= 1 else None,
    ]


def _circle_value(value, base: str) -> float:
    """A circle trial holds one way round (circle_ratio_cw …); a pair's figures the mean
    too (circle_ratio): the trial's own way first."""
    for way in CIRCLE_WAYS:
        number = value(circle_key(base, way))
        if math.isfinite(number):
            return number
    return value(base)


def _circle(value) -> list[PlainLine | None]:
    """Circle drawing (InMotion evaluation; Dipietro et al. 2007): roundness, the joints
    moving apart, the pace."""
    ratio = _circle_value(value, "circle_ratio")
    joints = _circle_value(value, "circle_joint_independence")
    speed = _circle_value(value, "circle_mean_speed_m_s")
    return [
        PlainLine("circle_ratio",
                  f"Your circle was {whole(100.0 * ratio)} % as wide one way as the other.",
                  "100 % is perfectly round: its narrowest width over its widest.")
        if _known(ratio) else None,
        PlainLine("circle_joint_independence",
                  f"Your shoulder and elbow moved independently: {whole(100.0 * joints)} %.",
                  "100 % means each joint moved on its own, as a circle needs; after a stroke "
                  "the two often move together.")
        if _known(joints) else None,
        PlainLine("circle_mean_speed_m_s",
                  f"You drew at {whole(speed * MM_S_PER_M_S)} mm per second on average.",
                  "Your own pace around the circle.")
        if _known(speed) else None,
    ]


def _range(value) -> list[PlainLine | None]:
    """Active range (Sukal et al. 2007): the share of the reachable table, and its area."""
    ratio, area = value("range_area_ratio"), value("range_area_m2")
    return [
        PlainLine("range_area_ratio",
                  f"You reached {whole(100.0 * ratio)} % of the table the robot and your arm "
                  "allow.",
                  f"Your hand covered {whole(area * CM_PER_M ** 2)} cm² on its own."
                  if _known(area) else "The area your hand covered on its own.")
        if _known(ratio) else None,
    ]


def _strength(value) -> list[PlainLine | None]:
    """Isometric strength in 8 directions (InMotion evaluation): the firmest push, and
    whether the robot's hold was the limit rather than the patient."""
    peak, at_limit = value("strength_peak_force_n"), value(AT_LIMIT)
    directions = len(STRENGTH_DIRECTIONS_DEG)
    limit = None
    if _known(at_limit) and at_limit >= 1:
        where = ("every direction" if round(at_limit) >= directions else
                 f"{_count(at_limit, 'direction', 'directions')} of {directions}")
        limit = PlainLine(AT_LIMIT, f"In {where} you pushed as hard as the robot can hold.",
                          "You may be stronger still there: the robot cannot measure more.")
    return [
        PlainLine("strength_peak_force_n",
                  f"Your firmest pushes were {force_text(peak)} N on average over {directions} "
                  "directions.",
                  f"About the effort of holding up {mass_text(peak)}.")
        if _known(peak) else None,
        limit,
    ]


def _position(value) -> list[PlainLine | None]:
    """Position sense (Schutz & Roy 1973): how near and how alike the reproductions."""
    absolute, spread = value("position_absolute_error_m"), value("position_variable_error_m")
    missed = value("position_not_reproduced_count")
    return [
        PlainLine("position_absolute_error_m",
                  f"You found the remembered spot within {distance_text(absolute)} on average.",
                  "The distance between where the robot took your hand and where you put it "
                  "back on your own.")
        if _known(absolute) else None,
        PlainLine("position_variable_error_m",
                  f"Your tries at one spot were {distance_text(spread)} apart on average.",
                  "How alike your tries were, wherever they landed.")
        if _known(spread) else None,
        PlainLine("position_not_reproduced_count",
                  f"Your hand did not leave the centre in {_count(missed, 'try', 'tries')}.",
                  "Those tries are not in the figures above.")
        if _known(missed) and missed >= 1 else None,
    ]


_TASKS = {"reaching": _reaching, "circle": _circle, "range": _range,
          "strength": _strength, "position": _position}
