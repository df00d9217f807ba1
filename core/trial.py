"""A trial's parameters, validated.

`TrialParameters` refuses any value out of range with the field, the value, the
allowed range and why. The check that the whole path is reachable, by the robot and by
the subject's arm, is core.trial_check. See docs/frames.md for the frames and for why
the thesis's printed shoulder position is refused.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass

from core.arm import (
    BODY_MASS_RANGE_KG,
    FOREARM_RANGE_M,
    UPPER_ARM_RANGE_M,
    ArmModel,
)
from core.errors import ParameterError, as_number, check_range, check_whole
from core.trajectory import (
    NEGLECT_SIDES,
    SHAPES,
    TIMINGS,
    Path,
    Trajectory,
    make_path,
    toward_side,
)

CONTROLLERS = ("smc", "ctpid")
ASSIST_MODES = ("thesis", "as-needed", "transparent")
"""The assistance modes (core.control.guidance, which names them too, imports these)."""
SIDES = ("right", "left")
INCH_M = 0.0254

# Position of any point given to a trial: the robot's table is well inside ±1.5 m.
POSITION_RANGE_M = (-1.5, 1.5)
RADIUS_RANGE_M = (0.02, 0.25)
DURATION_RANGE_S = (1.0, 120.0)
DURATION_DECIMALS = 2
"""The traversal time's resolution, in decimals of a second: what the Parameters form keeps
and what a proposal steps it by (app.trials.progression), so a proposal taken runs as
proposed. Hundredths: the pace's staircase steps down to 2.5 %, 0.04 s of a 1.5 s lap."""
REPETITIONS_RANGE = (1, 100)
TOLERANCE_RANGE_RAD = (math.radians(1.0), math.radians(90.0))
TARGETS_RANGE = (2, 16)
GAMES = ("", "path", "reach")
"""The games a trial may be (core.games): "" none, "path" (steer the hand through a channel
around the path), "reach" (hit the reaching layout's targets in time)."""
REACH_GAME_SHAPES = ("targets", "reach")
"""The shapes whose straight reaches are the reaching game's targets."""
# A target or a channel narrower than a few millimetres is below what a hand holds still
# on the handle; wider than 8 cm it covers the 2-25 cm exercise itself.
TARGET_RADIUS_RANGE_M = (0.005, 0.08)
CHANNEL_HALF_WIDTH_RANGE_M = (0.003, 0.08)
TIME_ALLOWED_RANGE_S = (0.2, 30.0)
DISTRACTORS_RANGE = (0, 8)


@dataclass(frozen=True, slots=True)
class TrialParameters:
    """Everything that defines a trial, in SI units. Defaults are the thesis's
    experiment (section 3.6) with the shoulder as we read it (docs/frames.md)."""

    shape: str = "d"
    centre_m: tuple[float, float] = (-0.30, 0.30)
    radius_m: float = 0.10
    duration_s: float = 4.0
    repetitions: int = 5
    timing: str = "constant_speed"
    clockwise: bool = True
    n_targets: int = 8
    shoulder_m: tuple[float, float] = (-0.12, 0.73)
    body_mass_kg: float = 91.0
    upper_arm_m: float = 12 * INCH_M
    forearm_m: float = 12 * INCH_M
    side: str = "right"
    tolerance_rad: float = math.radians(20.0)
    controller: str = "smc"
    assistance_level: float = 1.0
    assist: str = "thesis"
    """The assistance mode (core.control.guidance.ASSIST_MODES): "thesis", Fig. 3.6 as
    printed (the tracking controller on the clock with the reduce-only cut), or
    "as-needed", the guidance of core.control.guidance, or "transparent", the robot
    compensating its own inertia, friction and stiffness without guidance
    (core.control.transparent; its level is always 0: nothing in it acts on a level).
    Trials recorded before the modes existed read as "thesis", which is what they ran."""
    gains: str = ""
    """Changes to the controller's and the guidance's default gains, one line such as
    "smc.lambda_1_s=25; guidance.delay_s=0.5" (core.control.gains), kept canonical."""
    learned_model: str = ""
    """The learned model (chapter 4) the computed-torque PID runs on in place of the
    analytic M, C and f: a model file's name in the data folder's models/ (app.learning.
    library), "" for the analytic model. Only with controller "ctpid"."""
    learned_model_sha256: str = ""
    """The content hash of that model file as the trial used it (set when the trial is
    built; "" while it is only chosen)."""
    force_estimate: str = ""
    """The EMG-to-torque model (chapter 5, the cHRI aim) whose estimate of the patient's
    force the assistance judges in place of the force sensor's reading: an EMG model
    file's name in the data folder's models/emg/ (app.emg.modelfile; only a model that
    passed its held-out validation is ever saved there), "" for the sensor."""
    force_estimate_sha256: str = ""
    """The content hash of that model file as the trial used it."""
    game: str = ""
    """The game the trial is played as (GAMES, core.games): "" none (older files read so),
    "path" or "reach" (shape "targets" or "reach" only)."""
    target_radius_m: float = 0.02
    """Reaching game: the radius of each target (and distractor) disc, m."""
    channel_half_width_m: float = 0.02
    """Path game: the channel's half-width around the path, m."""
    time_allowed_s: float = 0.5
    """Reaching game: the time from a target's appearance (its reach's start on the clock)
    to hit it, s; at most the time between two targets' appearances."""
    n_distractors: int = 0
    """Reaching game: discs to avoid, placed between the targets (core.games.layout)."""
    staircase: str = ""
    """The state of the staircase that set this round's difficulty (core.games.staircase:
    its ladder, rung, credit, lock and why), canonical JSON; "" when set by hand."""
    neglect_side: str = ""
    """The patient's side with hemispatial neglect a reaching layout (shape "targets" or
    "reach", game or not) is turned toward (core.trajectory.centre_out_angles): "", "left"
    or "right", the patient's (left = +x)."""
    assessment: str = ""
    """The assessment task this trial is a run of (core.assessment.TASKS: "reaching",
    "circle", "range", "strength", "position"; its protocol in core.assessment.protocol),
    "" for an exercise (and in files written before the assessments, which read so)."""

    def __post_init__(self) -> None:
        _choice("shape", self.shape, SHAPES)
        _choice("timing", self.timing, TIMINGS)
        _choice("side", self.side, SIDES)
        _choice("controller", self.controller, CONTROLLERS)
        _choice("assist", self.assist, ASSIST_MODES)
        if self.game not in GAMES:
            raise ParameterError("game", self.game, "'' (no game), 'path' or 'reach'")
        # numbers as numbers: a string or a flag is refused by name, numpy scalars become
        # plain floats and ints (they reach JSON and HDF5 attributes)
        for name in _REAL_FIELDS:
            object.__setattr__(self, name, as_number(name, getattr(self, name)))
        for name, allowed in (("repetitions", REPETITIONS_RANGE),
                              ("n_targets", TARGETS_RANGE),
                              ("n_distractors", DISTRACTORS_RANGE)):
            value = getattr(self, name)
            check_whole(name, value, *allowed)
            object.__setattr__(self, name, int(value))
        object.__setattr__(self, "centre_m", _point("centre_m", self.centre_m))
        object.__setattr__(self, "shoulder_m", _point("shoulder_m", self.shoulder_m))
        check_range("radius_m", self.radius_m, *RADIUS_RANGE_M, "m",
                    "the exercise must fit the robot's table")
        check_range("duration_s", self.duration_s, *DURATION_RANGE_S, "s")
        check_range("body_mass_kg", self.body_mass_kg, *BODY_MASS_RANGE_KG, "kg",
                    "Winter's segment proportions hold for adults and adolescents")
        check_range("upper_arm_m", self.upper_arm_m, *UPPER_ARM_RANGE_M, "m",
                    "shoulder to elbow of an adult")
        check_range("forearm_m", self.forearm_m, *FOREARM_RANGE_M, "m",
                    "elbow to wrist of an adult")
        lo, hi = TOLERANCE_RANGE_RAD
        check_range("tolerance_rad", self.tolerance_rad, lo, hi, "rad",
                    f"{math.degrees(lo):.0f}–{math.degrees(hi):.0f}°; beyond 90° a push "
                    "against the path would count as help")
        check_range("assistance_level", self.assistance_level, 0.0, 1.0, "",
                    "0 = no help for the subject's effort (thesis: no reduction; as-needed: "
                    "the channel alone), 1 = full help")
        object.__setattr__(self, "assistance_level",
                           level_that_runs(self.assist, self.assistance_level))
        if not isinstance(self.clockwise, bool):
            raise ParameterError("clockwise", self.clockwise, "True or False")
        _game_fields(self)
        _assessment(self.assessment, self.game)
        _learned_model(self.controller, self.learned_model, self.learned_model_sha256)
        _model_name("force_estimate", self.force_estimate, "an EMG model file's name")
        _model_hash("force_estimate_sha256", self.force_estimate_sha256, self.force_estimate)
        if not isinstance(self.staircase, str):
            raise ParameterError("staircase", self.staircase, "text: a staircase's JSON or ''")
        if self.staircase != "":
            # imported here: core.games builds on this module
            from core.games.staircase import Staircase

            object.__setattr__(self, "staircase", Staircase.from_json(self.staircase).to_json())
        if self.gains != "":
            # imported here: core.control builds on this module
            from core.control.gains import canonical_gains

            object.__setattr__(self, "gains", canonical_gains(self.gains))

    def replace(self, **changes) -> TrialParameters:
        return dataclasses.replace(self, **changes)

    def arm(self) -> ArmModel:
        return ArmModel.from_subject(
            self.body_mass_kg, self.upper_arm_m, self.forearm_m, self.shoulder_m, side=self.side
        )

    def path(self) -> Path:
        return make_path(
            self.shape, self.centre_m, self.radius_m,
            clockwise=self.clockwise, n_targets=self.n_targets,
            toward=toward_side(self.neglect_side),
        )

    def trajectory(self) -> Trajectory:
        """The reference on the clock: the path walked `repetitions` times, or, for a task
        the robot leads (isometric strength, position sense), the task's timetable
        (core.holdtasks.TaskTrajectory: the layout held, moved and let go by stretches)."""
        if self.assessment in ("strength", "position"):
            # imported here: core.holdtasks builds on core.trajectory and core.control
            from core.holdtasks import task_trajectory

            return task_trajectory(self)
        return Trajectory(self.path(), self.duration_s, self.repetitions, self.timing)

    def to_dict(self) -> dict:
        """Plain values (lists for pairs) for JSON, HDF5 attributes and the registry."""
        return {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, values: dict) -> TrialParameters:
        """Build from `to_dict` output; unknown keys are refused by name."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - names)
        if unknown:
            raise ParameterError("parameters", ", ".join(unknown), ", ".join(sorted(names)),
                                 "unknown trial parameter")
        pairs = {"centre_m", "shoulder_m"}
        return cls(**{k: tuple(v) if k in pairs else v for k, v in values.items()})



MODEL_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,99}")
"""What a learned model's name may be (a trial's `learned_model`, a model file's stem)."""
_SHA256 = re.compile(r"[0-9a-f]{64}")


def _model_name(field: str, name: object, what: str = "a model file's name") -> None:
    if not isinstance(name, str) or (name and not MODEL_NAME.fullmatch(name)):
        raise ParameterError(field, name, what + ": letters, digits, . _ -, at most 100",
                             "the name of a file in the models folder")


def _model_hash(field: str, sha256: object, name: str) -> None:
    if not isinstance(sha256, str) or (sha256 and not _SHA256.fullmatch(sha256)):
        raise ParameterError(field, sha256, "64 lower-case hex digits or empty",
                             "the model file's SHA-256")
    if sha256 and not name:
        raise ParameterError(field, sha256, "empty without its model",
                             "a hash belongs to a model")


def _learned_model(controller: str, name: object, sha256: object) -> None:
    _model_name("learned_model", name)
    if name and controller != "ctpid":
        raise ParameterError("learned_model", name, "empty with controller " + repr(controller),
                             "a learned model stands in for M, C and f of the computed-torque "
                             "PID (controller 'ctpid') only")
    _model_hash("learned_model_sha256", sha256, name)


def _choice(name: str, value: object, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise ParameterError(name, value, "one of " + ", ".join(allowed))


_REAL_FIELDS = ("radius_m", "duration_s", "body_mass_kg", "upper_arm_m", "forearm_m",
                "tolerance_rad", "assistance_level", "target_radius_m",
                "channel_half_width_m", "time_allowed_s")


def level_that_runs(assist: str, assistance_level: float) -> float:
    """The assistance level a trial of mode `assist` runs at: the transparent mode acts on
    no level (core.control.transparent), so its trial, its file, its plan block and the
    registry say 0, the level that ran, never a level the robot did not use."""
    return 0.0 if assist == "transparent" else assistance_level


def target_spacing_s(shape: str, duration_s: float, n_targets: int) -> float:
    """Time between two targets' appearances in the reaching game: the path's reaches
    share one traversal evenly (core.trajectory: each segment's time is proportional to
    its length, and a layout's reaches are equally long)."""
    return duration_s / n_targets if shape == "targets" else duration_s


def _game_fields(p: TrialParameters) -> None:
    """The game's difficulty in SI, each refused in one line; the reaching game's fields
    are checked against its layout only when it is the game."""
    check_range("target_radius_m", p.target_radius_m, *TARGET_RADIUS_RANGE_M, "m",
                "a target the hand can hold still in, smaller than the exercise")
    check_range("channel_half_width_m", p.channel_half_width_m,
                *CHANNEL_HALF_WIDTH_RANGE_M, "m",
                "a channel the hand can stay in, narrower than the exercise")
    check_range("time_allowed_s", p.time_allowed_s, *TIME_ALLOWED_RANGE_S, "s")
    if p.neglect_side not in NEGLECT_SIDES:
        raise ParameterError("neglect_side", p.neglect_side, "'' (none), 'left' or 'right'",
                             "the patient's neglected side")
    if p.neglect_side and p.shape not in REACH_GAME_SHAPES:
        raise ParameterError("neglect_side", p.neglect_side, "'' with shape " + repr(p.shape),
                             "only a reaching layout (shape 'targets' or 'reach') turns "
                             "toward a side")
    if p.game == "reach" and p.shape not in REACH_GAME_SHAPES:
        raise ParameterError("shape", p.shape, "one of " + ", ".join(REACH_GAME_SHAPES)
                             + " with game 'reach'",
                             "the reaching game's targets are the ends of the layout's reaches")
    if p.game != "reach":
        return
    spacing = target_spacing_s(p.shape, p.duration_s, p.n_targets)
    if p.time_allowed_s > spacing + 1e-9:
        raise ParameterError("time_allowed_s", p.time_allowed_s, f"at most {spacing:g} s",
                             "a target must be hit before the next one appears: "
                             "give more time per movement (duration_s) or less time_allowed_s")
    gaps = p.n_targets - bool(p.neglect_side) if p.shape == "targets" else 2
    if p.n_distractors > gaps:
        raise ParameterError("n_distractors", p.n_distractors, f"at most {gaps}",
                             "one distractor between two neighbouring targets"
                             + (" (a half circle toward the neglected side has one gap fewer)"
                                if p.neglect_side and p.shape == "targets" else ""))




def _assessment(task: object, game: str) -> None:
    """"" or one of the assessment tasks, never a game: a task's figures are measured on the
    patient's own movement under its fixed protocol (core.assessment.protocol)."""
    if task == "":
        return
    # imported here: core.assessment builds on this module
    from core.assessment import TASKS

    if task not in TASKS:
        raise ParameterError("assessment", task, "'' (an exercise) or one of " + ", ".join(TASKS),
                             "the assessment task the trial is a run of")
    if game:
        raise ParameterError("game", game, f"'' with assessment {task!r}",
                             "an assessment is measured under its own protocol, not played "
                             "as a game")


def _point(name: str, value) -> tuple[float, float]:
    try:
        x, y = value
    except (TypeError, ValueError):
        raise ParameterError(name, value, "a pair (x, y) in m") from None
    return (
        check_range(f"{name}[x]", x, *POSITION_RANGE_M, "m"),
        check_range(f"{name}[y]", y, *POSITION_RANGE_M, "m"),
    )


def _plain(value):
    if isinstance(value, tuple):
        return [float(v) for v in value]
    return value


THESIS_SUBJECT = TrialParameters()
"""The healthy subject of section 3.6 on the thesis's D, shoulder as we read it."""

THESIS_SMC_GAINS = "smc.k_d_Nms_rad=0.5,0.5; smc.k_robust_Nm=0.05,0.05; smc.lambda_1_s=3,3"
"""The thesis's own SMC (its ref. [19], whose gains it does not give) as identified from
its healthy subject's tracking (section 3.6: RMSE 8.68 / 7.02 mm): about 6x softer than
this console's default SMC (core.control.smc), which holds the hand within 1 mm and so
tracked 10x better and pushed the arm round the D's corners 4-6x harder than the thesis
saw. Calibrated on the two RMSEs only (docs/validation.md, scripts/thesis_gap.py)."""



def thesis_experiment(**changes) -> TrialParameters:
    """Section 3.6 as it ran: THESIS_SUBJECT driven by the thesis's SMC (THESIS_SMC_GAINS),
    with `changes` (a function: the gains are checked by core.control, which imports this
    module)."""
    return THESIS_SUBJECT.replace(gains=THESIS_SMC_GAINS, **changes)


THESIS_AS_PRINTED = TrialParameters(shoulder_m=(0.12, 0.73))
"""Section 3.6 exactly as printed: part of the D is beyond the arm's reach."""
