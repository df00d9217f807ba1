"""The assessment battery's protocols: how each task (core.assessment.TASKS) runs.

A task is run as one or more ordinary trials (core.trial.TrialParameters with
`assessment` set to the task's id), so it is recorded, checked, stored and exported as
any trial is. Its protocol fixes everything but the patient's body and where the
exercise sits on the table (the therapist's `centre_m` and the patient's shoulder, both
from the base parameters `Protocol.parameters` starts from): the words for the
therapist and for the patient, how many trials and repetitions, the timing, the robot's
mode and the exercise the robot's reference and the patient's screen follow.

The cues the figures are measured against (a target shown, the signal to push, the
signal to reproduce) are a function of the parameters alone (`cues`): the reference's
segments start on the trial's clock, which the patient's screen follows, so the trial
file's parameters say when each cue was shown; the runner writes them into the file as
timed events (app.assessments).

Where a protocol follows a published instrument it says so; where this console chose
a number, the number's docstring says why. Two differences from Kinarm's visually guided
reaching (Coderre et al. 2010, Neurorehabil Neural Repair 24:528, doi
10.1177/1545968309356091) are deliberate: the targets come in the layout's fixed order
(round the circle, as the centre-out exercise walks them) rather than in a random
order, so a patient can anticipate the next direction; and each reach has a fixed slot
on the clock instead of starting when the hand has held still at the centre: 3 s, so a
hand that overshot the centre on its way back has settled before the next target shows
(a weak virtual patient's, 2-3 cm past it, takes about 1 s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from core.assessment import TASKS
from core.errors import ParameterError
from core.trajectory import Line
from core.trial import ASSIST_MODES, TrialParameters

TRANSPARENT = "transparent"
HOLD_GAINS = "ctpid.integral_limit_rad_s2=20"
"""The computed-torque PID's gains for the robot-led tasks (strength: the robot holds the
handle still; position: it takes the hand to a target and back), which run in the
transparent mode on their own trajectory (core.holdtasks; core.control.hold.HOLD_GAINS
is the same text, checked by tests/core/assessment/test_protocol.py once it exists)."""


@dataclass(frozen=True, slots=True)
class Cue:
    """Something the patient is shown at `time_s` on the exercise's clock (0 = the
    exercise's first sample): `kind` (CUE_KINDS), the target or direction's index in the
    layout, its repetition, and the point it names (m, global frame)."""

    time_s: float
    kind: str
    target: int
    repetition: int
    point_m: tuple[float, float]
    start_m: tuple[float, float]
    """Where the hand is asked to be when the cue is shown (the reach's start)."""


CUE_KINDS = ("target", "home")
"""`target`: a peripheral target (reaching, range, position) or a direction to push
(strength) appears; `home`: the centre target appears again (the way back, or rest)."""


@dataclass(frozen=True, slots=True)
class Protocol:
    """One task's fixed protocol (see the module notes)."""

    task: str
    name: str
    therapist: str
    """What the therapist does and checks, in order."""
    patient: str
    """What the therapist reads to the patient (and the patient's screen says)."""
    robot_mode: str
    """TrialParameters.assist during the task's trials."""
    shape: str
    radius_m: float
    """The layout's size: the targets' distance from the centre, the circle's radius."""
    n_targets: int
    repetitions: int
    """Traversals of the layout per trial (every target this many times); rounds of the
    robot-led tasks."""
    duration_s: float
    """TrialParameters.duration_s: one traversal of the layout (a centre-out layout's
    segments share it evenly, a target's slot then the way back's), one lap of the circle,
    one push (strength) or one match (position; core.holdtasks times those two)."""
    timing: str
    trials: tuple[str, ...]
    """One label per trial of the task ("" when it has one): its trial count."""
    target_hold_s: float
    """How long the hand holds on a target (or the push lasts) before it counts."""
    time_allowed_s: float
    """Time from a cue to the movement's or the push's end that still counts."""
    rest_s: float
    """Rest between the task's trials."""
    reference: str
    """The instrument the task follows, with its doi."""
    controller: str = ""
    """TrialParameters.controller for the task ("" keeps the base's)."""
    gains: str = ""
    """TrialParameters.gains for the task ("" keeps the base's)."""

    @property
    def trial_count(self) -> int:
        return len(self.trials)

    def parameters(self, base: TrialParameters, index: int = 0) -> TrialParameters:
        """Trial `index` (0-based, < trial_count) of this task for the patient and the
        table of `base`: its body, shoulder, side and centre are kept (and its controller
        unless the task names one), the exercise, timing and robot mode are the
        protocol's, with no game, no help and no staircase. Refuses, in one line, an index
        out of range and a robot mode this console does not have."""
        if not (isinstance(index, int) and 0 <= index < self.trial_count):
            raise ParameterError("trial", index, f"0 to {self.trial_count - 1}",
                                 f"the {self.name} has {self.trial_count} trial(s)")
        if self.robot_mode not in ASSIST_MODES:
            raise ParameterError("assist", self.robot_mode, "one of " + ", ".join(ASSIST_MODES),
                                 f"the {self.name} needs the robot's {self.robot_mode!r} mode, "
                                 "which this console does not have")
        changes = {name: value for name, value in (("controller", self.controller),
                                                   ("gains", self.gains)) if value}
        if changes.get("controller", base.controller) != "ctpid":
            changes["learned_model"] = changes["learned_model_sha256"] = ""
        return base.replace(
            **changes, shape=self.shape, radius_m=self.radius_m, n_targets=self.n_targets,
            duration_s=self.duration_s, repetitions=self.repetitions, timing=self.timing,
            clockwise=self.trials[index] != "counter-clockwise", assist=self.robot_mode,
            assistance_level=0.0, game="", staircase="", neglect_side="", assessment=self.task,
        )


CUED_TASKS = ("reaching", "circle", "range")
"""The tasks whose cues are the reference's segments (`cues`); the robot-led tasks'
(strength, position) are their trajectory's own events (core.holdtasks)."""


def cues(parameters: TrialParameters) -> tuple[Cue, ...]:
    """The cues of a task's trial on its exercise's clock: for a centre-out layout
    (shape "targets") each reach's target at its outward segment's start and the centre
    at the way back's; for the circle, nothing (the path is shown throughout). Refuses
    a trial of any other task, or no assessment."""
    if parameters.assessment not in CUED_TASKS:
        raise ParameterError("assessment", parameters.assessment, "one of "
                             + ", ".join(CUED_TASKS), "the tasks cued by the reference's "
                             "segments; the robot-led tasks' cues are their trajectory's events")
    if parameters.shape != "targets":
        return ()
    trajectory = parameters.trajectory()
    segments = trajectory.path.segments
    starts = trajectory.segment_times_s
    out: list[Cue] = []
    for repetition in range(parameters.repetitions):
        offset = repetition * parameters.duration_s
        for k, segment in enumerate(segments):
            assert isinstance(segment, Line)  # a centre-out layout is straight lines
            outward = k % 2 == 0
            out.append(Cue(offset + starts[k], "target" if outward else "home", k // 2,
                           repetition, segment.end, segment.start))
    return tuple(out)


CUE_EVENT = "assessment_cue"
"""The kind of an assessment trial's timed events in its file (`task_events`)."""


def task_events(parameters: TrialParameters, trajectory=None
                ) -> tuple[tuple[float, str, dict], ...]:
    """The timed events of an assessment trial on its exercise's clock, as the live loop
    and a headless run write them (kind CUE_EVENT): (time s, message, values with the
    task). A task cued by the reference's segments has one per cue ('target shown',
    'centre shown', with the cue's target, repetition and points); a robot-led task one per
    phase of its trajectory (`events()`: core.holdtasks; `trajectory` is the trial's when
    already built); an exercise none."""
    task = parameters.assessment
    if task in CUED_TASKS:
        return tuple((cue.time_s, ("target" if cue.kind == "target" else "centre") + " shown",
                      {"task": task, "cue": cue.kind, "target": cue.target,
                       "repetition": cue.repetition, "point_m": list(cue.point_m),
                       "start_m": list(cue.start_m)})
                     for cue in cues(parameters))
    if not task:
        return ()
    phases = getattr(trajectory or parameters.trajectory(), "events", None)
    if phases is None:
        return ()
    return tuple((float(t), str(phase), {"task": task, **dict(values)})
                 for t, phase, values in phases())


def reach_directions_rad(parameters: TrialParameters) -> tuple[float, ...]:
    """The direction (rad, counter-clockwise from +x) of each of the layout's targets
    from the centre, in the layout's order: the directions a strength task's pushes and
    a range task's reaches go."""
    cx, cy = parameters.centre_m
    return tuple(math.atan2(c.point_m[1] - cy, c.point_m[0] - cx)
                 for c in cues(parameters) if c.kind == "target" and c.repetition == 0)


_KINARM = ("Coderre et al. 2010, Neurorehabil Neural Repair 24:528, "
           "doi 10.1177/1545968309356091")
_INMOTION = ("InMotion evaluation, circle drawing (Bioelectronic Medicine 2021, doi "
             "10.1186/s42234-021-00081-9, Table 4)")

PROTOCOLS: dict[str, Protocol] = {
    "reaching": Protocol(
        task="reaching", name="visually guided reaching",
        therapist=(
            "Seat the patient with the arm to be tested on the handle and the trunk against "
            "the chair's back. The robot is transparent: it neither helps nor guides. Start: "
            "the robot brings the hand to the centre. Each of the 8 targets 10 cm around it "
            "appears in turn, twice; the patient reaches it as quickly and accurately as "
            "they can, holds it until the centre target comes back, and returns. Do not "
            "touch or guide the arm. A reach that never starts counts as no reaction, one "
            "that never stops as no movement end."),
        patient=(
            "Hold the handle at the centre circle. When a target lights up, move to it as "
            "quickly and accurately as you can and stay on it. When the centre lights up "
            "again, go back and wait for the next target."),
        robot_mode=TRANSPARENT, shape="targets", radius_m=0.10, n_targets=8, repetitions=2,
        duration_s=48.0, timing="minimum_jerk", trials=("",), target_hold_s=0.5,
        time_allowed_s=3.0, rest_s=0.0, reference=_KINARM),
    "circle": Protocol(
        task="circle", name="circle drawing",
        therapist=(
            "The patient draws the circle shown on the screen, 14 cm across, 5 laps "
            "clockwise in the first trial and 5 counter-clockwise in the second, at the pace "
            "of the moving dot (4 s a lap), and stops when the dot stops (the circle's "
            "smoothness is measured until the hand is at rest). The robot is transparent. "
            "Let the patient rest between the two trials."),
        patient=(
            "Follow the dot round the circle with the handle, as round and as smooth as you "
            "can, and stop when the dot stops. Then the same the other way round."),
        robot_mode=TRANSPARENT, shape="circle", radius_m=0.07, n_targets=8, repetitions=5,
        duration_s=4.0, timing="constant_speed", trials=("clockwise", "counter-clockwise"),
        target_hold_s=0.0, time_allowed_s=4.0, rest_s=30.0, reference=_INMOTION),
    "range": Protocol(
        task="range", name="active range",
        therapist=(
            "The patient moves the handle out as far as they can in each of 8 directions "
            "shown in turn, holds there, and comes back to the centre. The robot is "
            "transparent and every safety limit holds; do not help. The area the hand "
            "covered is compared with the area the robot and this arm could both reach."),
        patient=(
            "When an arrow shows, move the handle as far as you can that way, hold it there, "
            "then come back to the centre."),
        robot_mode=TRANSPARENT, shape="targets", radius_m=0.05, n_targets=8, repetitions=1,
        duration_s=48.0, timing="minimum_jerk", trials=("",), target_hold_s=1.0,
        time_allowed_s=3.0, rest_s=0.0,
        reference="the active range of motion of robot assessments (Kinarm, InMotion); "
                  "its ratio to the workspace the robot and the arm share is this "
                  "console's own"),
    "strength": Protocol(
        task="strength", name="isometric strength",
        therapist=(
            "The robot holds the handle still at the centre. An arrow shows one of 8 "
            "directions; the patient pushes as hard as they can that way, up to the line "
            "on the screen (the robot's limit in that direction), while the arrow shows, "
            "then rests before the next. Watch for pain and stop with the red button if it "
            "comes; the force limit stops the robot on its own."),
        patient=(
            "The handle will not move. When an arrow shows, push the handle that way as "
            "hard as you can, up to the line, until the arrow goes away; then relax."),
        robot_mode=TRANSPARENT, shape="targets", radius_m=0.05, n_targets=8, repetitions=1,
        duration_s=3.0, timing="minimum_jerk", trials=("",), target_hold_s=3.0,
        time_allowed_s=3.0, rest_s=0.0, controller="ctpid", gains=HOLD_GAINS,
        reference="InMotion shoulder strength and isometric hold (Bioelectronic Medicine "
                  "2021, doi 10.1186/s42234-021-00081-9, Table 4)"),
    "position": Protocol(
        task="position", name="position sense",
        therapist=(
            "The patient relaxes the arm and does not look at it (the patient's screen is "
            "blank while the robot moves). The robot takes the hand to a target, holds it "
            "there, and brings it back to the centre; the patient then moves the hand to "
            "where it was and holds still. 4 targets, 3 times each."),
        patient=(
            "Relax your arm and let the robot move it. Feel where it takes your hand. When "
            "it is back and the screen says so, move your hand to that place and hold still."),
        robot_mode=TRANSPARENT, shape="targets", radius_m=0.10, n_targets=4, repetitions=3,
        duration_s=4.0, timing="minimum_jerk", trials=("",), target_hold_s=1.0,
        time_allowed_s=4.0, rest_s=0.0, controller="ctpid", gains=HOLD_GAINS,
        reference="Kinarm's arm position matching (Dukelow et al. 2012, J NeuroEng Rehabil "
                  "9:72, doi 10.1186/1743-0003-9-72) with one arm, against memory"),
}
"""Every task's protocol, keyed by its id (core.assessment.TASKS)."""


def protocol(task: object) -> Protocol:
    """The protocol of `task`, refused in one line when no task has that id."""
    if task not in TASKS:  # a tuple: an unhashable value is refused, not raised on
        raise ParameterError("task", task, "one of " + ", ".join(TASKS),
                             "the assessment battery's tasks")
    return PROTOCOLS[task]  # type: ignore[index]


def without_task(parameters: TrialParameters) -> TrialParameters:
    """`parameters` as an exercise: when they hold an assessment task's trial (the form
    after "Set up this trial"), every field its protocol set (`Protocol.parameters`) goes
    back to an exercise's default, the patient's body, shoulder, side and table centre
    kept. A session plan's round is built on the form (core.plan.Block.parameters): on a
    task's trial it ran the block as the task (the strength task's transparent mode
    refused the block's as-needed one, and the plan ended at its first Build) or with the
    task's holding controller."""
    if not parameters.assessment:
        return parameters
    task = protocol(parameters.assessment)
    exercise = TrialParameters()
    names = ["shape", "radius_m", "n_targets", "duration_s", "repetitions", "timing",
             "clockwise", "assist", "assistance_level", "assessment"]
    if task.controller or task.gains:
        names += ["controller", "gains", "learned_model", "learned_model_sha256"]
    return parameters.replace(**{name: getattr(exercise, name) for name in names})
