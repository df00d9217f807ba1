"""The assessment battery's tasks and the catalogue of their figures.

One `FigureSpec` per figure key. The key is what a trial's metrics (the trial
file's and the registry's `metrics` JSON) store the figure under; it is globally
unique and ends in its SI unit (`_m`, `_s`, `_rad`, `_m_s`, `_m2`, `_n`; none
for a ratio, a count or a smoothness score). Reports, the normative models and
Progress read a figure's label, unit and better direction from here and nowhere
else. docs/assessments.md gives each definition at length with its reference.

Tasks (ids fixed for the whole console): "reaching" (visually guided reaching,
Coderre et al. 2010), "circle" (circle drawing both ways, InMotion evaluation),
"range" (active range), "strength" (isometric strength in 8 directions),
"position" (position sense).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from core.errors import ParameterError

TASKS: tuple[str, ...] = ("reaching", "circle", "range", "strength", "position")
"""The assessment tasks' ids, in the battery's order."""

TASK_TITLES: dict[str, str] = {
    "reaching": "Visually guided reaching",
    "circle": "Circle drawing",
    "range": "Active range",
    "strength": "Isometric strength",
    "position": "Position sense",
}

BETTER = ("lower", "higher", "none")

STRENGTH_DIRECTIONS_DEG: tuple[int, ...] = (0, 45, 90, 135, 180, 225, 270, 315)
"""Directions of the isometric pushes, degrees counter-clockwise from the robot
frame's +x axis (degrees only in the keys; the functions take radians)."""

CIRCLE_WAYS: tuple[str, ...] = ("cw", "ccw")
CIRCLE_BASE_KEYS: tuple[str, ...] = ("circle_ratio", "circle_joint_independence",
                                     "circle_sparc", "circle_ldlj", "circle_mean_speed_m_s")
"""The circle's figures as the mean of both ways; `circle_key` names each way's."""

# References, written once.
CODERRE_2010 = ("Coderre AM et al., Assessment of upper-limb sensorimotor function of subacute "
                "stroke patients using visually guided reaching, Neurorehabil Neural Repair "
                "24(6):528-541, 2010, doi:10.1177/1545968309356091; definitions as in Little CE "
                "et al., J NeuroEng Rehabil 12:78, 2015, Table 1, doi:10.1186/s12984-015-0070-0")
BALASUBRAMANIAN_2015 = ("Balasubramanian S et al., On the analysis of movement smoothness, "
                        "J NeuroEng Rehabil 12:112, 2015, doi:10.1186/s12984-015-0090-9")
INMOTION_2021 = ("InMotion shoulder-elbow evaluation (circle drawing), Bioelectronic Medicine "
                 "7:20, 2021, Table 4, doi:10.1186/s42234-021-00081-9; Krebs HI et al., Stroke "
                 "45(1):200-204, 2014, doi:10.1161/STROKEAHA.113.002296")
DIPIETRO_2007 = ("Dipietro L et al., Changing motor synergies in chronic stroke, "
                 "J Neurophysiol 98(2):757-768, 2007, doi:10.1152/jn.01295.2006")
SUKAL_2007 = ("Sukal TM, Ellis MD, Dewald JPA, Shoulder abduction-induced reductions in reaching "
              "work area following hemiparetic stroke, Exp Brain Res 183(2):215-223, 2007, "
              "doi:10.1007/s00221-007-1029-6")
STRENGTH_REF = ("InMotion evaluation, shoulder strength (isometric force with the robot "
                "holding still), Bioelectronic Medicine 7:20, 2021, Table 4, "
                "doi:10.1186/s42234-021-00081-9")
SCHUTZ_ROY_1973 = ("Schutz RW, Roy EA, Absolute error: the devil in disguise, J Mot Behav "
                   "5(3):141-153, 1973, doi:10.1080/00222895.1973.10734959")


@dataclass(frozen=True, slots=True)
class FigureSpec:
    """One figure of one task.

    key: the metrics key (globally unique, SI unit suffix).
    task: one of TASKS.
    unit: the SI unit as printed ("1" for a ratio or a score, "count").
    label: a short label for a report's table.
    better: "lower", "higher" or "none" (no direction is better).
    definition: one sentence.
    reference: the publication it follows, with its doi.
    bounded_by: the key of the count that, above 0 in a trial, makes this figure a lower
      bound there (strength: the robot's hold reached its force limit; "" for none).
    """

    key: str
    task: str
    unit: str
    label: str
    better: str
    definition: str
    reference: str
    bounded_by: str = ""

    def __post_init__(self) -> None:
        if self.task not in TASKS:
            raise ParameterError("task", self.task, f"one of {', '.join(TASKS)}")
        if self.better not in BETTER:
            raise ParameterError("better", self.better, "lower, higher or none")
        for name in ("key", "unit", "label", "definition", "reference"):
            if not getattr(self, name).strip():
                raise ParameterError(name, getattr(self, name), "a non-empty text")


def _vgr() -> list[FigureSpec]:
    mean = "the mean over the task's reaches with a value"
    rows = [
        ("vgr_posture_speed_m_s", "m/s", "Posture speed", "lower",
         f"Mean hand speed over the 500 ms before each target appears, {mean}."),
        ("vgr_reaction_time_s", "s", "Reaction time", "lower",
         f"Target appearance to movement onset, {mean}."),
        ("vgr_initial_direction_error_rad", "rad", "Initial direction error", "lower",
         "Absolute angle between the line from the hand at movement onset to the target and "
         f"the hand's displacement over the initial phase (onset to first speed minimum), {mean}."),
        ("vgr_initial_distance_ratio", "1", "Initial distance ratio", "higher",
         "Path length of the initial phase over the path length from movement onset to offset "
         f"(to the reach's end when the hand never stopped on the target), {mean}."),
        ("vgr_initial_speed_ratio", "1", "Initial speed ratio", "higher",
         f"Peak speed of the initial phase over the reach's peak speed, {mean}."),
        ("vgr_speed_maxima_count", "count", "Speed maxima count", "lower",
         f"Number of local maxima of hand speed between movement onset and offset, {mean}."),
        ("vgr_min_max_speed_difference_m_s", "m/s", "Min-max speed difference", "lower",
         "Mean difference between each speed maximum after the first and the speed minimum "
         f"before it, between movement onset and offset (0 for a single peak), {mean}."),
        ("vgr_movement_time_s", "s", "Movement time", "lower",
         f"Movement onset to movement offset, {mean}."),
        ("vgr_path_length_ratio", "1", "Path length ratio", "lower",
         "Path length from movement onset to offset over the straight distance from the start "
         f"to the target, {mean}."),
        ("vgr_max_speed_m_s", "m/s", "Max speed", "higher",
         f"Highest hand speed of the reach, {mean}."),
        ("vgr_no_reaction_count", "count", "No reaction", "lower",
         "Number of reaches in which no movement onset was found."),
        ("vgr_no_movement_end_count", "count", "No movement end", "lower",
         "Number of reaches in which the hand did not come to rest on the target."),
    ]
    specs = [FigureSpec(key, "reaching", unit, label, better, text, CODERRE_2010)
             for key, unit, label, better, text in rows]
    specs += [
        FigureSpec("vgr_sparc", "reaching", "1", "SPARC", "higher",
                   "Spectral arc length of the hand speed from movement onset to offset "
                   f"(closer to 0 is smoother), {mean}.", BALASUBRAMANIAN_2015),
        FigureSpec("vgr_ldlj", "reaching", "1", "LDLJ", "higher",
                   "Log dimensionless jerk of the hand velocity from movement onset to offset "
                   f"(closer to 0 is smoother), {mean}.", BALASUBRAMANIAN_2015),
    ]
    return specs


def _circle() -> list[FigureSpec]:
    rows = [
        ("circle_ratio", "1", "Circle ratio", "higher",
         "Minor over major axis of the drawn path: the major axis its longest chord, the "
         "minor axis its extent perpendicular to that chord.",
         INMOTION_2021),
        ("circle_joint_independence", "1", "Joint independence", "higher",
         "One minus the absolute correlation of the shoulder and elbow angles over the circle "
         "(1: the joints move independently, 0: locked in one synergy).", DIPIETRO_2007),
        ("circle_sparc", "1", "SPARC", "higher",
         "Spectral arc length of the hand speed over the circle (closer to 0 is smoother).",
         BALASUBRAMANIAN_2015),
        ("circle_ldlj", "1", "LDLJ", "higher",
         "Log dimensionless jerk of the hand velocity over the circle (closer to 0 is smoother).",
         BALASUBRAMANIAN_2015),
        ("circle_mean_speed_m_s", "m/s", "Mean speed", "higher",
         "Path length over the time taken to draw the circle.", INMOTION_2021),
    ]
    ways = {"": "mean of the clockwise and counter-clockwise circles",
            "cw": "clockwise circle", "ccw": "counter-clockwise circle"}
    specs = []
    for way, words in ways.items():
        for key, unit, label, better, text, ref in rows:
            specs.append(FigureSpec(circle_key(key, way) if way else key, "circle", unit,
                                    f"{label} ({way})" if way else label, better,
                                    f"{text[:-1]}; {words}.", ref))
    return specs


def circle_key(base: str, way: str) -> str:
    """The key of a circle figure of one way round: circle_key("circle_ratio", "cw") ==
    "circle_ratio_cw", circle_key("circle_mean_speed_m_s", "ccw") ==
    "circle_mean_speed_ccw_m_s" (the unit stays last)."""
    if base not in CIRCLE_BASE_KEYS:
        raise ParameterError("base", base, f"one of {', '.join(CIRCLE_BASE_KEYS)}")
    if way not in CIRCLE_WAYS:
        raise ParameterError("way", way, "cw or ccw")
    if base.endswith("_m_s"):
        return f"{base.removesuffix('_m_s')}_{way}_m_s"
    return f"{base}_{way}"


def _range() -> list[FigureSpec]:
    return [
        FigureSpec("range_area_m2", "range", "m²", "Area reached", "higher",
                   "Area of the convex hull of the hand's path while the patient reached "
                   "outwards alone.", SUKAL_2007),
        FigureSpec("range_area_ratio", "range", "1", "Area ratio", "higher",
                   "Area reached alone (within the region both the robot and the arm can reach) "
                   "over the area of that region.", SUKAL_2007),
    ]


def strength_key(kind: str, direction_deg: int) -> str:
    """The key of the peak ("peak") or mean ("mean") force of one push direction,
    e.g. strength_key("peak", 45) == "strength_peak_force_n_045"."""
    if kind not in ("peak", "mean"):
        raise ParameterError("kind", kind, "peak or mean")
    if direction_deg not in STRENGTH_DIRECTIONS_DEG:
        raise ParameterError("direction_deg", direction_deg,
                             f"one of {', '.join(map(str, STRENGTH_DIRECTIONS_DEG))}")
    return f"strength_{kind}_force_n_{direction_deg:03d}"


AT_LIMIT = "strength_at_limit_count"
"""A strength trial's count of directions whose push reached the robot's force limit: its
peaks are then the line the patient was shown, not their strength. (The mean over the push
is not capped the same way: with the line reached it says how soon and how steadily, which
still tells people apart; docs/assessments.md.)"""


def _strength() -> list[FigureSpec]:
    specs = []
    for deg in STRENGTH_DIRECTIONS_DEG:
        specs.append(FigureSpec(
            strength_key("peak", deg), "strength", "N", f"Peak force {deg}°", "higher",
            f"Highest component of the hand force along the push direction {deg}° over its hold "
            "windows (the best try).", STRENGTH_REF, AT_LIMIT))
        specs.append(FigureSpec(
            strength_key("mean", deg), "strength", "N", f"Mean force {deg}°", "higher",
            f"Mean component of the hand force along the push direction {deg}° over its hold "
            "windows.", STRENGTH_REF))
    specs.append(FigureSpec(
        "strength_peak_force_n", "strength", "N", "Peak force (mean of directions)", "higher",
        "Mean over the 8 push directions of the peak force along each.", STRENGTH_REF,
        AT_LIMIT))
    specs.append(FigureSpec(
        "strength_mean_force_n", "strength", "N", "Mean force (mean of directions)", "higher",
        "Mean over the 8 push directions of the mean force along each.", STRENGTH_REF))
    specs.append(FigureSpec(
        "strength_at_limit_count", "strength", "count", "Directions at the robot's limit",
        "none", "Number of push directions in which the push reached the force the robot can "
        "hold, so that their figures are lower bounds.", STRENGTH_REF))
    return specs


def _position() -> list[FigureSpec]:
    return [
        FigureSpec("position_absolute_error_m", "position", "m", "Absolute error", "lower",
                   "Mean distance between each reproduced position and its target.",
                   SCHUTZ_ROY_1973),
        FigureSpec("position_variable_error_m", "position", "m", "Variable error", "lower",
                   "Spread of the reproductions about their own mean: the root of the squared "
                   "distances of each reproduction from its target's mean reproduction, summed "
                   "over targets, over the sum of (reproductions - 1) per target.",
                   SCHUTZ_ROY_1973),
        FigureSpec("position_constant_error_m", "position", "m", "Constant error", "lower",
                   "Distance from each target to the mean of its reproductions, averaged over "
                   "targets.", SCHUTZ_ROY_1973),
        FigureSpec("position_not_reproduced_count", "position", "count",
                   "Targets not matched", "none",
                   "Number of matches in which the hand never left the centre (beyond a "
                   "quarter of the target's distance): left out of the errors.",
                   SCHUTZ_ROY_1973),
    ]


FIGURES: dict[str, FigureSpec] = {
    spec.key: spec
    for spec in (*_vgr(), *_circle(), *_range(), *_strength(), *_position())
}
"""Every figure of every task, by key, in the battery's order."""


_NON_NEGATIVE = (0.0, math.inf)
_SHARE = (0.0, 1.0)
_DOMAINS = {
    # magnitudes: speeds, durations, lengths, areas, distances, counts (of which the
    # speed maxima's is a mean over reaches, so not whole)
    **dict.fromkeys(("vgr_posture_speed_m_s", "vgr_min_max_speed_difference_m_s",
                     "vgr_movement_time_s", "vgr_path_length_ratio", "vgr_max_speed_m_s",
                     "vgr_speed_maxima_count", "vgr_no_reaction_count",
                     "vgr_no_movement_end_count", "circle_mean_speed_m_s", "range_area_m2",
                     "position_absolute_error_m", "position_variable_error_m",
                     "position_constant_error_m", "position_not_reproduced_count",
                     "strength_at_limit_count"), _NON_NEGATIVE),
    "vgr_initial_direction_error_rad": (0.0, math.pi),  # an absolute angle
    # a part over its whole: the initial phase's path or peak over the reach's; the minor
    # over the major axis (no extent exceeds the longest chord); one minus a correlation's
    # size; the area reached within the region over the region's
    **dict.fromkeys(("vgr_initial_distance_ratio", "vgr_initial_speed_ratio", "circle_ratio",
                     "circle_joint_independence", "range_area_ratio"), _SHARE),
}


def domain(key: str) -> tuple[float, float]:
    """The values figure `key` can take by its definition, (low, high): a value outside is
    not a measurement (a sign lost, a unit or a column mixed up). Unbounded where the
    definition allows any value: SPARC and LDLJ, the reaction time, the strength's force
    components (a push the wrong way is negative)."""
    spec = figure(key)
    base = next((b for b in CIRCLE_BASE_KEYS if spec.task == "circle"
                 and key in (b, *(circle_key(b, w) for w in ("cw", "ccw")))), key)
    return _DOMAINS.get(base, (-math.inf, math.inf))


def figure(key: str) -> FigureSpec:
    """The catalogue's entry for `key`; refuses a key it does not know."""
    try:
        return FIGURES[key]
    except KeyError:
        raise ParameterError("figure", key, "a key of core.assessment.FIGURES",
                             "see docs/assessments.md for the list") from None


def task_figures(task: str) -> tuple[FigureSpec, ...]:
    """The figures of one task, in the catalogue's order."""
    if task not in TASKS:
        raise ParameterError("task", task, f"one of {', '.join(TASKS)}")
    return tuple(spec for spec in FIGURES.values() if spec.task == task)
