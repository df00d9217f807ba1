"""Plain words for a trial's figures: the lines a patient reads on the report.

Every sentence is built from the numbers it speaks of; none is stored whole. The
words avoid the jargon of the therapist's table (no RMSE, ROM, ISB) and say what
the number means for the person who did the exercise. Numbers are rounded to
what a person can use: whole %, whole mm, whole degrees.

Inputs are SI (m, rad, N, s) like everything inside; the units people read are
made here, at the display. A figure that is NaN (its channel was missing, or it
does not apply to the exercise) gives no sentence rather than a wrong one.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from app.assessments.words import TURN_WORDS
from app.trials.assistance_timeline import AssistanceInEffect
from app.units import CM_PER_M, MM_PER_M
from core.holdtasks import ROBOT_TASKS

STANDARD_GRAVITY_M_S2 = 9.80665

SHAPE_NOUNS = {
    "d": "D",
    "circle": "circle",
    "reach": "reach",
    "targets": "target layout",
    "figure8": "figure eight",
}
SHAPE_NAMES = {
    "d": "D shape",
    "circle": "circle",
    "reach": "straight reach",
    "targets": "point-to-point targets",
    "figure8": "figure eight",
}

@dataclass(frozen=True, slots=True)
class PlainLine:
    """One line of the patient's part: `text` in big type, `detail` below it.

    key: the figure it speaks of — a core.metrics.TrialMetrics field, 'rmse' (the
    x and y errors combined) or 'peak_force_N' — so a view can place or test it.
    """

    key: str
    text: str
    detail: str


def whole(value: float) -> str:
    """A number as a person reads it on the report: rounded to a whole number."""
    return f"{round(value):d}"


def position_error_m(rmse_x_m: float, rmse_y_m: float) -> float:
    """The hand's root-mean-square distance from the moving target, m: the two axes'
    RMSE combined, since a patient thinks of one distance, not two axes."""
    return math.hypot(rmse_x_m, rmse_y_m)


def seconds_text(seconds: float) -> str:
    """Whole seconds, or tenths below 10 s, where a whole number could say 0."""
    if seconds >= 10.0:
        return f"{seconds:.0f}"
    return f"{seconds:.1f}".removesuffix(".0")


def distance_mm_shown(distance_m: float) -> int:
    """A distance in whole mm, at least 1: "within 1 mm" is still true of 0.3 mm, and
    "within 0 mm" would not be."""
    return max(1, round(distance_m * MM_PER_M))


def distance_text(distance_m: float) -> str:
    return f"{distance_mm_shown(distance_m)} mm"


def force_text(force_N: float) -> str:
    """A force in N as a person reads it: whole newtons, tenths below 10 N, where a whole
    number could say 0 (a passive hand's 0.21 N read "0 N")."""
    return f"{force_N:.1f}" if abs(force_N) < 9.95 else whole(force_N)


def mass_text(force_N: float) -> str:
    """A force as the weight a person would hold up to feel it: easier to picture than N."""
    kg = force_N / STANDARD_GRAVITY_M_S2
    if kg < 0.025:
        # below the first 50 g step: rounded up to 50 g it said "50 g" for 0.21 N (21 g)
        return "less than 50 g"
    if kg < 0.95:
        # Rounded to 50 g: a finer weight means nothing to someone holding a bag.
        grams = max(50, 50 * round(kg * 1000.0 / 50.0))
        return f"{grams} g"
    return f"{kg:.1f} kg"


def direction_line(percent: float, tolerance_rad: float) -> PlainLine:
    """The thesis mode's success figure (section 3.6.1): the patient's own push."""
    return PlainLine(
        "directional_performance_pct",
        f"You pushed in the right direction {whole(percent)} % of the time.",
        f"Within {whole(math.degrees(tolerance_rad))}° of the way the path goes. The more of "
        "the time, the more the robot gave way to your own push.",
    )


def led_line(percent: float) -> PlainLine:
    """The as-needed mode's success figure (core.control.guidance): the share of the
    exercise the patient kept up with the path without the robot's help along it."""
    return PlainLine(
        "led_pct",
        f"You led the movement {whole(percent)} % of the time.",
        "For that time you kept up with the path by yourself; the rest of the time the "
        "robot helped you along it.",
    )


POSITION_DETAIL = {
    "as-needed": "The robot holds the handle near the path while you move along it, so this "
                 "number is mostly the robot's doing.",
    "thesis": "In this mode the robot moves the handle along the path on a clock, so this "
              "number is mostly the robot's doing.",
    "transparent": "In this mode the robot did not hold your hand on the path, so this "
                   "number is yours.",
}


def position_line(rmse_x_m: float, rmse_y_m: float, mode: str = "thesis") -> PlainLine:
    """The distance from the moving ring the patient's screen shows (the point the robot
    leads to, whose RMS distance the figure is), credited to whom it belongs: in the
    as-needed and thesis modes the robot keeps the hand near it (a compliant channel, or a
    stiff tracker on a clock); in the transparent mode nothing does but the patient. Not
    "from the path": a hand that lags along the path is far from the ring and on the path
    (a passive hand at the start read "within 132 mm of the path" 0.01 mm from it)."""
    distance = distance_text(position_error_m(rmse_x_m, rmse_y_m))
    sentence = (f"Your hand kept on average {distance} from the moving ring."
                if mode == "transparent" else
                f"The robot kept your hand on average {distance} from the moving ring.")
    return PlainLine(
        "rmse",
        sentence,
        POSITION_DETAIL.get(mode, POSITION_DETAIL["thesis"]),
    )


def work_line(robot_share: float) -> PlainLine:
    """Who moved the handle: the patient's share of the positive net work of moving it,
    the robot's help's the rest (core.work.MechanicalWork.robot_share: the motors' work
    on the robot's own friction and mass is not counted)."""
    yours = 100.0 - 100.0 * robot_share
    return PlainLine(
        "robot_work_share",
        f"You did {whole(yours)} % of the work of moving the handle; the robot did "
        f"{whole(100.0 * robot_share)} %.",
        "Counted over the whole exercise, from your push and the robot's pull on your hand "
        "(not what its motors spent on its own weight and friction).",
    )


def own_work_line() -> PlainLine:
    """Who moved the handle when the robot only made itself lighter (`robot_only_lightened`)
    and the hand did work on the handle: the patient, all of it. The motors' net work
    (robot_work_J) went into the robot's own friction and inertia (its law is a function of
    its own state alone, core.control.transparent), so counting it as a share of moving
    the handle said "the robot did 51 %" under "Robot's help 0 %" (healthy virtual
    patient, the reaching task: motors 1.41 J, hand 1.37 J)."""
    return PlainLine(
        "robot_work_share",
        "You did all of the work of moving the handle.",
        "The robot's motors only made up for its own weight and friction; they did not "
        "push your hand.",
    )


def robot_only_lightened(parameters) -> bool:
    """The motors ran the transparent law all through the exercise: a transparent exercise
    or game, or an assessment task the patient leads (reaching, circle, range), not one the
    robot leads (core.holdtasks.ROBOT_TASKS: it holds the hand, or moves it)."""
    return (getattr(parameters, "assist", "") == "transparent"
            and (getattr(parameters, "assessment", "") or "") not in ROBOT_TASKS)


def own_pace_task(parameters) -> bool:
    """An assessment task the patient leads at their own pace (reaching, circle, range; not
    one the robot leads, core.holdtasks.ROBOT_TASKS): its reference runs on the task's
    clock, not the patient's, so the distance from it and the push's direction along it
    measure nothing of the patient (the healthy virtual patient's reaching task: 33 / 31 mm
    "error" for reaches whose own figures are all normal). Its own figures are the task's
    (core.assessment)."""
    task = getattr(parameters, "assessment", "") or ""
    return bool(task) and task not in ROBOT_TASKS


def shoulder_line(rom_rad: float) -> PlainLine:
    return PlainLine(
        "shoulder_rom_rad",
        f"Your shoulder moved through {whole(math.degrees(rom_rad))}°.",
        "How far your upper arm turned at the shoulder during the exercise.",
    )


def elbow_line(rom_rad: float) -> PlainLine:
    return PlainLine(
        "elbow_rom_rad",
        f"Your elbow moved through {whole(math.degrees(rom_rad))}°.",
        "How far your elbow bent and straightened during the exercise.",
    )


def force_line(peak_force_N: float) -> PlainLine:
    return PlainLine(
        "peak_force_N",
        f"Your firmest push on the handle was {force_text(peak_force_N)} N.",
        f"About the effort of holding up {mass_text(peak_force_N)}.",
    )


SUCCESS_KEYS = {"as-needed": "led_pct", "thesis": "directional_performance_pct",
                "transparent": "rmse"}
"""Each assistance mode's own success figure (app.trials.progression.success aims the
next trial at it): the report's headline. In the transparent mode the headline is the
patient's own distance from the path ("rmse", the two axes' RMSE combined, as the
therapist's table shows it): nothing but the patient keeps the hand there, and the push's
direction is only what moving the robot takes (app.trials.progression proposes nothing in
this mode)."""


def success_key(mode: str) -> str:
    return SUCCESS_KEYS.get(mode, SUCCESS_KEYS["thesis"])


def patient_mode(parameters) -> str:
    """Which of the patient's figures a trial has (plain_lines, compare.PATIENT_FIGURES):
    its assistance mode's, or "task" for an assessment trial, whose patient moves at their
    own pace (device.sim.tasks; core.assessment.protocol): the distance from the task's
    moving reference (the circle's dot, the targets' schedule) is then no distance from
    the path (a weak patient's circle read "within 96 mm of the path" on a 7 cm circle),
    and the task's own figures are on the therapist's task page."""
    return "task" if getattr(parameters, "assessment", "") else parameters.assist


def plain_lines(metrics: Mapping[str, float], *, mode: str = "thesis",
                peak_force_N: float = math.nan,
                only_lightened: bool = False) -> tuple[PlainLine, ...]:
    """The patient's lines for a trial's figures (TrialMetrics.to_dict() names, SI), the
    mode's success figure first (the headline). A figure that is missing or NaN is left
    out. In the as-needed mode the direction of the push is not the patient's figure:
    the robot is nearly transparent along the path, so the force on the handle is only
    what moving it takes (app.trials.progression); nor in the transparent mode, where
    the distance from the path, the patient's own, comes first. `only_lightened`
    (`robot_only_lightened`): the motors' work was the robot's own, not a share of moving
    the handle (`own_work_line`)."""

    def value(key: str) -> float:
        return float(metrics.get(key, math.nan))

    lines = []
    rmse_x, rmse_y = value("rmse_x_m"), value("rmse_y_m")
    position_known = math.isfinite(rmse_x) and math.isfinite(rmse_y)
    if mode == "transparent":
        # the patient's own distance from the path is the headline (SUCCESS_KEYS)
        if position_known:
            lines.append(position_line(rmse_x, rmse_y, mode))
    elif mode == "as-needed":
        if math.isfinite(value("led_pct")):
            lines.append(led_line(value("led_pct")))
    elif mode == "task":
        position_known = False  # the reference moves at the task's pace, not the patient's
    else:
        percent, tolerance = value("directional_performance_pct"), value("tolerance_rad")
        if math.isfinite(percent) and math.isfinite(tolerance):
            lines.append(direction_line(percent, tolerance))
    share = value("robot_work_share")
    if only_lightened:
        if value("patient_work_J") > 0.0:
            lines.append(own_work_line())
    elif math.isfinite(share):
        lines.append(work_line(min(max(share, 0.0), 1.0)))
    if math.isfinite(value("shoulder_rom_rad")):
        lines.append(shoulder_line(value("shoulder_rom_rad")))
    if math.isfinite(value("elbow_rom_rad")):
        lines.append(elbow_line(value("elbow_rom_rad")))
    if math.isfinite(peak_force_N):
        lines.append(force_line(peak_force_N))
    if position_known and mode != "transparent":
        lines.append(position_line(rmse_x, rmse_y, mode))
    return tuple(lines)


# -- how the trial ended ---------------------------------------------------------------

def status_sentence(status: str, exercised_s: float, planned_s: float, *,
                    emergency_stop: bool = False) -> str:
    """What the patient is told about how the trial ended; '' for a complete trial.
    Plain words only: what to do about a fault is the therapist's page's."""
    done = f"after {seconds_text(exercised_s)} of {seconds_text(planned_s)} seconds"
    if status == "complete":
        return ""
    if status == "faulted" and emergency_stop:
        return (f"The exercise was stopped with the emergency stop {done}, so these figures "
                "cover only part of it.")
    if status == "stopped_early":
        return (f"The exercise was stopped early, {done}, so these figures cover only "
                "part of it.")
    if status == "faulted":
        return (f"The robot stopped the exercise for safety {done}, so these figures cover "
                "only part of it.")
    if status == "recording_lost":
        return (f"The recording failed {done}, so part of this trial is missing from "
                "these figures.")
    if status == "recording":
        return ("This trial's recording was not finished, so these figures cover only what "
                "was saved.")
    return f"This trial ended with the status “{status}”; check the figures with your therapist."


MODE_MEANING = {
    "as-needed": "you lead, the robot helps when you fall behind",
    "thesis": "the robot guides the handle along the path on a clock",
    "transparent": "you move the handle on your own, the robot only makes itself lighter",
}
"""The assistance modes (core.trial.ASSIST_MODES) in the patient's words."""

HELP_MEANING = {
    "as-needed": "help along the path when you fall behind",
    "thesis": "how far the robot gives way to your push",
    "transparent": "no help: the robot only makes itself lighter",
}
"""What the assistance level means in each mode, for the patient (core.control.guidance,
core.control.assistance)."""


def help_text(mode: str, levels: AssistanceInEffect) -> str:
    """'100 % → 60 % at 5.8 s (help along the path when you fall behind)': the levels the
    trial ran at (app.trials.assistance_timeline), and what they mean in its mode."""
    return f"{levels.summary()} ({HELP_MEANING.get(mode, HELP_MEANING['thesis'])})"


def same_help(before: AssistanceInEffect, after: AssistanceInEffect) -> bool:
    """Whether two trials ran with the same help: one level each, the same, held through
    the exercise (a level changed mid-trial compares with nothing: its figures mix two
    settings). Levels are set in whole percent (the form's unit)."""
    return (not before.changed and not after.changed
            and round(before.at_start * 100.0) == round(after.at_start * 100.0))


# -- change since an earlier trial -----------------------------------------------------

VERDICT_WORDS = {
    "better": "better",
    "worse": "worse",
    "same": "the same",
    "more": "more",
    "less": "less",
}


def change_sentence(name: str, before_text: str, after_text: str, verdict: str) -> str:
    """'Push in the right direction: 72 % → 78 %, better'."""
    return f"{name}: {before_text} → {after_text}, {VERDICT_WORDS[verdict]}"


def _cm(radius_m: float) -> str:
    return f"{radius_m * CM_PER_M:.3g} cm"


def parameter_cautions(before: Mapping, after: Mapping) -> tuple[str, ...]:
    """Why this trial's figures may differ from an earlier one's for reasons other than
    the patient: one sentence per exercise setting that changed (TrialParameters
    field names and SI values; a setting missing on either side is not compared). The
    assistance level is not among them: what counts is the levels the trials ran at
    (`help_caution`), not the ones they were built with."""
    sentences = []

    def changed(key: str) -> bool:
        a, b = before.get(key), after.get(key)
        if a is None or b is None:
            return False
        if isinstance(a, float | int) and isinstance(b, float | int):
            return not math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12)
        return a != b

    shape = after.get("shape")
    if changed("assist"):
        now, then = (MODE_MEANING.get(v, v) for v in (after["assist"], before["assist"]))
        sentences.append(f"This trial used another kind of help from the robot ({now}; "
                         f"before, {then}), so the figures do not compare directly.")
    if changed("shape"):
        sentences.append(
            f"This trial was a different exercise ({SHAPE_NAMES.get(shape, shape)}; before, "
            f"{SHAPE_NAMES.get(before['shape'], before['shape'])}), so the figures do not "
            "compare directly."
        )
        # Size and speed of another shape say nothing more.
        return tuple(sentences)
    noun = SHAPE_NOUNS.get(shape, "exercise")
    if changed("clockwise"):
        # the other way round uses the joints in another order: the circle task's two ways
        # differ by design (core.assessment.circle: each way's figures apart)
        now, then = (TURN_WORDS[bool(v)] for v in (after["clockwise"], before["clockwise"]))
        sentences.append(f"This trial went round the {noun} the other way ({now}; before, "
                         f"{then}), so the figures do not compare directly.")
    if changed("radius_m"):
        r, r0 = after["radius_m"], before["radius_m"]
        if r > r0:
            sentences.append(f"This trial used a larger {noun} (radius {_cm(r)}; before, "
                             f"{_cm(r0)}) — a higher error is expected.")
        else:
            sentences.append(f"This trial used a smaller {noun} (radius {_cm(r)}; before, "
                             f"{_cm(r0)}) — less movement at the shoulder and elbow is "
                             "expected.")
    if changed("duration_s"):
        d, d0 = after["duration_s"], before["duration_s"]
        if d < d0:
            sentences.append(f"This trial went faster ({d:g} s per lap; before, {d0:g} s) — "
                             "a higher error is expected.")
        else:
            sentences.append(f"This trial went slower ({d:g} s per lap; before, {d0:g} s) — "
                             "a lower error is expected.")
    if changed("tolerance_rad"):
        t, t0 = (whole(math.degrees(v)) for v in (after["tolerance_rad"],
                                                  before["tolerance_rad"]))
        if after["tolerance_rad"] > before["tolerance_rad"]:
            sentences.append(f"This trial counted a push as the right direction within a wider "
                             f"angle (±{t}°; before, ±{t0}°) — a higher direction score is "
                             "expected.")
        else:
            sentences.append(f"This trial counted a push as the right direction within a "
                             f"narrower angle (±{t}°; before, ±{t0}°) — a lower direction "
                             "score is expected.")
    if changed("controller"):
        sentences.append(f"The robot was driven by a different controller "
                         f"({after['controller'].upper()}; before, "
                         f"{before['controller'].upper()}) — the figures may differ for that "
                         "reason.")
    return tuple(sentences)


def help_caution(before: AssistanceInEffect, after: AssistanceInEffect) -> str:
    """Why the figures may differ: the robot's help differed between the trials (the
    levels they ran at, changes during them included); '' when it was the same."""
    if same_help(before, after):
        return ""
    return (f"The robot's help was different ({after.summary()}; before, "
            f"{before.summary()}), so the figures do not compare directly.")
