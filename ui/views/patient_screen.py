"""What the patient's screen shows at a moment of a trial, without Qt: the path or the
targets, the hand's cursor, the start cue, the repetition and the time left.

The screen is the patient's, not the therapist's: large words and shapes, no clinical
figures unless the therapist chose to show them (`PatientOptions.show_numbers`). Its
content comes from the same `TrialView` the therapist's tabs draw (filled live by the
window's 16 ms timer, or from a trial file), at the view's current sample, and from the
trial's parameters; everything is in the robot's frame (m), and
`ui.views.patient_geometry` turns it to the patient's view.

The moments a patient is told (the Act.Sens and Kinarm practice: a concurrent cursor,
a start signal, knowledge of results after each movement):

* before the exercise (the robot brings the hand to the path's start): "Get ready";
* the exercise phase's first sample: "Go!", for `GO_SHOWN_S` (the tone, if on, once);
* during the exercise: the lap (k of n) and the time left on the trial's clock;
* at its end: "Well done!" with the last lap's result (a game: with its score), or
  "Finished." when the hand did not follow the last lap (a game: scored nothing); a
  fault or a stop: "Stopped" and nothing else (the therapist explains).

The words mean one thing each, as the Plan tab and the therapist's status line use them: a
*lap* is one time through the exercise (a trial's repetition: round the D, out to every
target and back), a *round* one of a plan block's trials, a *block* one of the plan's
blocks (ui.views.patient_plan). A task the robot leads counts its pushes or its targets
("Push 3 of 16"), not laps.

After each lap of a plain exercise the result comes first ("Done!" while the next lap runs,
"Lap 3 done!" at the end), then the lap's quality in words (how close the hand kept to the
path), the order clinicians use (knowledge of results, then of performance); words, not
millimetres, as the screen shows no clinical figure the therapist has not chosen. A hand
that did not follow the path (less than the path game's share of its length) is told to,
not praised for staying on it at the start (ui.views.patient_laps judges a lap).

The repetition and the time left follow the trial's clock (`duration_s` per
repetition from the exercise's first sample), the same clock that ends the trial. In
the as-needed mode the reference can fall behind the clock by the guidance's delay (at
most 0.5 s by default), so near a lap's end the count can step up before the
hand gets round; the time left stays what ends the trial.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from core.games import GameLayout, game_layout
from core.holdtasks import ROBOT_TASKS, TaskTrajectory
from core.trial import TrialParameters
from device.loop.pipeline import PHASE_APPROACH, PHASE_EXERCISE, PHASE_HOLD
from ui.views.patient_game import RESULT_SHOWN_S, GameFeed, GameFrame
from ui.views.patient_laps import lap_judged, lap_words
from ui.views.trialview import TrialView

GO_SHOWN_S = 1.5  # long enough to read at a glance, short enough not to linger
PATH_SPACING_M = 0.004
TARGET_RADIUS_M = 0.015  # a reach target's drawn radius when no game sets one
PREVIOUS_PATH_POINTS = 400
CUE_WAIT = "Please wait"
CUE_READY = "Get ready"
CUE_GO = "Go!"
CUE_DONE = "Well done!"
CUE_OVER = "Finished."
"""The end of a trial whose last lap the hand did not follow, or of a game without a
point: said plainly, not praised ("Well done! Score 0" for a hand that missed every
target)."""
CUE_STOPPED = "Stopped"
TASK_WORDS = {
    "ready": "Get ready to push", "push": "Push! Up to the line", "rest": "Relax",
    "centre": "Relax your arm: the robot moves your hand",
    "out": "Relax your arm: the robot moves your hand",
    "there": "Relax your arm: the robot moves your hand",
    "back": "Relax your arm: the robot moves your hand",
    "settle": "Relax your arm: the robot moves your hand",
    "match": "Move your hand to where it was, then hold still",
    "home": "Bring your hand back to the middle",
}
"""What the patient's screen says in each phase of a task the robot leads (core.holdtasks;
the protocol's words for the patient, core.assessment.protocol)."""
TASK_COUNTED = {"strength": ("Push", "push"), "position": ("Target", "match")}
"""What a task's count says ("Push 3 of 16") and the timetable's phase it counts, one a
direction or target a round (a task's round is every direction or target once)."""


@dataclass(frozen=True, slots=True)
class PatientOptions:
    """The therapist's choices for the patient's screen.

    mirror, rotation_deg: the patient's view of the table turned to the screen as it
        stands (ui.views.patient_geometry.screen_axes).
    show_numbers: clinical figures on the patient's screen (off: never shown).
    previous_path: the hand's path of the last repetition, faint, during the next one
        (knowledge of performance).
    sound: a tone with the start cue.

    The hemispatial neglect cue is not an option here: it follows the trial's
    `neglect_side` (TrialParameters), which also turns the targets toward that side, so
    the trial file records both.
    """

    mirror: bool = False
    rotation_deg: int = 0
    show_numbers: bool = False
    previous_path: bool = True
    sound: bool = False

    def __post_init__(self) -> None:
        for name in ("mirror", "show_numbers", "previous_path", "sound"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"patient screen option {name} = {getattr(self, name)!r}: "
                                 "give true or false")
        if self.rotation_deg not in (0, 90, 180, 270):
            raise ValueError(f"patient screen rotation {self.rotation_deg!r}: give 0, 90, 180 "
                             "or 270 (degrees)")

    def to_dict(self) -> dict:
        return {name: getattr(self, name) for name in self.__slots__}

    @classmethod
    def from_dict(cls, values: dict) -> PatientOptions:
        """Refuses unknown keys and bad values in one line (ValueError)."""
        if not isinstance(values, dict):
            raise ValueError(f"patient screen options {values!r}: give an object")
        unknown = sorted(set(values) - set(cls.__slots__))
        if unknown:
            raise ValueError(f"unknown patient screen option {', '.join(unknown)}: give "
                             + ", ".join(cls.__slots__))
        return cls(**values)

    def replace(self, **changes) -> PatientOptions:
        return PatientOptions(**{**self.to_dict(), **changes})

    def words(self) -> str:
        """The options as the trial file's event says them."""
        turned = ("as the patient sees the table" if self.rotation_deg == 0
                  else f"turned {self.rotation_deg}° anticlockwise")
        return ", ".join((
            turned + (", mirrored left-right" if self.mirror else ""),
            "the last repetition's path " + ("shown" if self.previous_path else "hidden"),
            "figures " + ("shown" if self.show_numbers else "hidden"),
            "a tone at Go" if self.sound else "no tone"))


@dataclass(frozen=True, slots=True)
class Scene:
    """What does not move during a trial: the path (N, 2) m, the reach targets (M, 2) m
    with their radius, the start point, and the extent the screen must show."""

    parameters: TrialParameters
    path_m: np.ndarray
    targets_m: np.ndarray
    target_radius_m: float
    start_m: tuple[float, float]
    extent_m: tuple[float, float, float, float]
    game: GameLayout | None = None
    """The game's layout (core.games.game_layout) when the trial is a game."""
    task: TaskTrajectory | None = None
    """The timetable of a task the robot leads (core.holdtasks), else None."""

    @classmethod
    def of(cls, parameters: TrialParameters) -> Scene:
        from ui.views.patient_geometry import padded_extent

        path = parameters.path()
        points = path.points(PATH_SPACING_M)
        if parameters.shape == "targets":
            # centre-out: home → target k → home; the targets are the outward lines' ends
            targets = np.array([seg.end for seg in path.segments[0::2]], dtype=float)
        else:
            targets = np.zeros((0, 2))
        radius = TARGET_RADIUS_M
        game = game_layout(parameters) if parameters.game else None
        shown, pad = points, 2.0 * radius
        if game is not None:
            discs = [(t.centre_m, t.radius_m) for t in game.targets]
            discs += [(d.centre_m, d.radius_m) for d in game.distractors]
            if discs:
                shown = np.vstack((points, [c for c, _ in discs]))
                pad = max(pad, 1.5 * max(r for _, r in discs))
            pad = max(pad, 1.5 * game.channel_half_width_m)
            if game.game == "reach":
                radius = parameters.target_radius_m
        task = parameters.trajectory() if parameters.assessment in ROBOT_TASKS else None
        return cls(parameters, points, targets, radius, (float(points[0, 0]),
                   float(points[0, 1])), padded_extent(shown, pad), game, task)


@dataclass(frozen=True, slots=True)
class PatientFrame:
    """The screen's content at one moment (positions in the robot's frame, m)."""

    cue: str
    go: bool
    """True from the exercise's first sample for GO_SHOWN_S: the start signal."""
    cursor_m: tuple[float, float] | None
    target_m: tuple[float, float] | None
    """The moving target: where the robot's reference is (position_desired)."""
    active_target: int
    """The reach target being reached (index into Scene.targets_m), -1 if none."""
    repetition: int
    repetitions: int
    time_left_s: float | None
    previous_path_m: np.ndarray | None = None
    numbers: tuple[str, ...] = ()
    sample: int = -1
    """The view's sample this frame shows (-1: none)."""
    result: str = ""
    """Knowledge of results: what the last lap or target came to, while shown."""
    success: bool = False
    """The result is a success (a hit, a clean lap, a lap done): said in green."""
    game: GameFrame | None = None
    exercise_started_s: float = field(default=math.nan)
    """The time (trial clock, s) of the exercise's first sample, NaN before it."""
    blank: bool = False
    """A task the robot leads: the table shows nothing of the layout, the hand or the
    reference (position sense with the screen blank; strength, which shows the push)."""
    push: tuple[float, float, float] | None = None
    """Strength: (the push's direction, rad; the line, N; the force along it now, N)."""
    counted: str = "Lap"
    """What `repetition` counts, in the patient's word: laps, or a task's pushes or
    targets (TASK_COUNTED)."""
    result_lap: int = 0
    """The lap the result names by its number (the end's "Lap 3 done!"), 0 if none."""
    result_quality: str | None = ""
    """That lap's quality in words, as `lap_words` takes it."""

    def counted_on(self, laps_before: int) -> PatientFrame:
        """The frame counting its laps on from `laps_before` run earlier (a plan's round
        resumed after a pause): the band's lap and the end's "Lap 60 done!" alike (only
        the band was, and the end said "Lap 58 done!" under "Lap 60 of 60")."""
        if laps_before <= 0 or self.repetition <= 0:
            return self
        result, lap = self.result, self.result_lap
        if lap > 0:
            lap += laps_before
            result = lap_words(lap, self.result_quality, last=True)
        return dataclasses.replace(self, repetition=self.repetition + laps_before,
                                   repetitions=self.repetitions + laps_before,
                                   result=result, result_lap=lap)

    @property
    def message(self) -> str:
        """The bottom line: the cue first, else the last result."""
        return self.cue or self.result

    @property
    def repetition_text(self) -> str:
        if self.repetitions <= 0 or self.repetition <= 0:
            return ""
        game = self.game
        if game is not None and self.repetitions == 1 and game.targets_shown > 0:
            # a reaching game of one lap counts its targets (16 at most: the band keeps the
            # letter size): a plan's round of one lap round 8 said "Lap 1 of 1" from its
            # first target to its last. More laps (a round resumed after a pause too) are
            # counted as laps
            return f"Target {game.targets_shown} of {game.targets}"
        return f"{self.counted} {self.repetition} of {self.repetitions}"

    @property
    def time_left_text(self) -> str:
        if self.time_left_s is None:
            return ""
        return f"{clock(self.time_left_s)} left"


def clock(seconds: float) -> str:
    """m:ss, rounded up: '0:00' only when nothing is left."""
    whole = max(0, math.ceil(seconds - 1e-9))
    return f"{whole // 60}:{whole % 60:02d}"


def waiting_frame(scene: Scene | None) -> PatientFrame:
    """Before a trial: the exercise's path, nothing moving."""
    reps = scene.parameters.repetitions if scene is not None else 0
    planned = (scene.parameters.duration_s * reps) if scene is not None else None
    return PatientFrame(CUE_WAIT, False, None, None, -1, 0, reps, planned)


def frame_at(view: TrialView, scene: Scene, options: PatientOptions,
             game: GameFeed | None = None, exercise_start_s: float | None = None
             ) -> PatientFrame:
    """The screen at the view's current sample (its newest live, its cursor in replay);
    `game` the scene's game fed from this view (ui.views.patient_game), if it is one.

    `exercise_start_s`: the exercise's first tick's time when the loop said it (live: the
    approach's length at the trial's start, device.loop.pipeline: the exercise starts at
    tick `approach`), so that a live view that missed the trial's first records (taken
    before the window saw it running) still counts from the exercise's true start; None:
    the view's first exercise sample (a trial file holds every sample)."""
    i = view.current_index
    p = scene.parameters
    planned = p.duration_s * p.repetitions
    if scene.task is not None:
        planned = scene.task.total_duration_s
    if i < 0:
        return waiting_frame(scene)
    phase = int(view.column("phase")[0, i])
    fault = int(view.column("fault")[0, i])
    position = view.column("position")[:, i]
    cursor = (float(position[0]), float(position[1])) if np.isfinite(position).all() else None
    desired = view.column("position_desired")[:, i]
    target = (float(desired[0]), float(desired[1])) if np.isfinite(desired).all() else None
    t = float(view.time[i])
    if exercise_start_s is not None:
        started = phase != PHASE_APPROACH and t >= exercise_start_s - 1e-9
        t0 = float(exercise_start_s) if started else math.nan
    else:
        started = view.has_exercise and view.exercise.start <= i
        t0 = float(view.time[view.exercise.start]) if started else math.nan
    elapsed = t - t0 if started else 0.0
    if fault:
        cue = CUE_STOPPED
    elif phase == PHASE_APPROACH or (phase == PHASE_EXERCISE and not started):
        cue = CUE_READY
    elif phase == PHASE_EXERCISE:
        cue = CUE_GO if elapsed < GO_SHOWN_S else ""
    elif phase == PHASE_HOLD or (view.finished and i == view.n - 1):
        cue = CUE_DONE
    else:
        cue = CUE_WAIT
    if phase == PHASE_HOLD:
        repetition, left = p.repetitions, 0.0
    elif started:
        repetition = min(p.repetitions, int(elapsed // p.duration_s) + 1)
        left = max(0.0, planned - elapsed)
    else:
        repetition, left = 0, planned
    active = _active_target(scene, target, view.column("direction_desired")[:, i]) \
        if started and phase == PHASE_EXERCISE else -1
    previous = None
    if options.previous_path and started and repetition >= 2 and phase == PHASE_EXERCISE:
        previous = _repetition_path(view, t0 + (repetition - 2) * p.duration_s,
                                    t0 + (repetition - 1) * p.duration_s)
    numbers = _numbers(view) if options.show_numbers and started else ()
    result, success = "", False
    result_lap, quality = 0, ""
    played = game.at(view, exercise_start_s) if game is not None else None
    if played is not None:
        result, success = played.result, played.success
        if played.state.game == "reach":
            target = None  # the reaching game shows its own targets, not the reference
        # the path game keeps the reference's ring, the lap's clock on the path: nothing
        # else says which way round the channel goes, nor how fast (in the transparent
        # mode, where the game is played, the handle goes wherever it is pushed)
        if cue == CUE_DONE and played.state.started:
            # praise for points scored; a game with none ends in plain words
            cue = f"{CUE_DONE if played.state.score > 0 else CUE_OVER} {played.score_text}"
    elif started and phase == PHASE_EXERCISE and repetition >= 2:
        into = elapsed - (repetition - 1) * p.duration_s
        # at most half a lap: the lap under way is what matters
        if into < min(RESULT_SHOWN_S, 0.5 * p.duration_s):
            quality = lap_judged(view, p, t0, repetition - 1)
            result, success = lap_words(repetition - 1, quality, False), quality is not None
    elif started and cue == CUE_DONE and scene.task is None:
        # the last lap's result, which no next lap shows, with the end; a hand that
        # did not follow the path is not praised for it
        quality = lap_judged(view, p, t0, repetition)
        result, success = lap_words(repetition, quality, True), quality is not None
        result_lap = repetition
        if not success:
            cue = CUE_OVER
    if scene.task is not None:
        return _task_frame(view, scene, i, cue, cursor, started, phase, elapsed, left, t0)
    return PatientFrame(cue, cue == CUE_GO, cursor, target, active, repetition,
                        p.repetitions, left, previous_path_m=previous, numbers=numbers,
                        sample=i, result=result, success=success, game=played,
                        exercise_started_s=t0, result_lap=result_lap,
                        result_quality=quality)


def _task_frame(view: TrialView, scene: Scene, i: int, cue: str, cursor, started: bool,
                phase: int, elapsed: float, left: float, t0: float) -> PatientFrame:
    """The screen in a task the robot leads (core.holdtasks), from the stretch of its
    timetable the exercise's clock is in: its words (TASK_WORDS), which push or target of
    all the task's it is (TASK_COUNTED: the rounds times the layout's), and either
    nothing on the table (position sense while the screen is blank) or the push's arrow
    with its line and the force along it (strength). Before and after the exercise, and on
    a fault, the usual cues."""
    task = scene.task
    counted, item = TASK_COUNTED[task.task]
    per_round = sum(s.phase == item for s in task.stretches) // max(
        1, scene.parameters.repetitions)
    total = per_round * scene.parameters.repetitions
    if not (started and phase == PHASE_EXERCISE) or cue == CUE_STOPPED:
        hidden = task.task == "strength" or (started and phase == PHASE_EXERCISE)
        return PatientFrame(cue, False, None if hidden else cursor, None, -1,
                            total if phase == PHASE_HOLD else 0, total, left, sample=i,
                            exercise_started_s=t0, blank=hidden, counted=counted)
    starts = [s.start_s for s in task.stretches]
    k = max(0, min(len(starts) - 1, int(np.searchsorted(starts, elapsed, side="right")) - 1))
    stretch = task.stretches[k]
    values = dict(stretch.values)
    push = None
    if task.task == "strength":
        blank = True
        if stretch.phase in ("ready", "push"):
            force = view.column("force")[:, i]
            u = np.asarray(stretch.push if stretch.phase == "push" else (
                math.cos(values["direction_rad"]), math.sin(values["direction_rad"])))
            along = float(force @ u) if np.isfinite(force).all() else 0.0
            push = (float(values["direction_rad"]), float(values["line_N"]),
                    along if stretch.phase == "push" else 0.0)
    else:
        blank = bool(values.get("blank", False))
    number = int(values.get("round", 0)) * per_round + int(values.get("index", 0)) + 1
    return PatientFrame(TASK_WORDS.get(stretch.phase, ""), False, None if blank else cursor,
                        None, -1, number, total, left, sample=i, exercise_started_s=t0,
                        blank=blank, push=push, counted=counted)


def _active_target(scene: Scene, target, direction) -> int:
    """The reach target the reference moves towards: of the targets and home, the
    nearest straight ahead of the reference along the path's direction; -1 when that is
    home (on the way back) or none is."""
    if not len(scene.targets_m) or target is None or not np.isfinite(direction).all():
        return -1
    ends = np.vstack((scene.targets_m, scene.parameters.centre_m))
    towards = ends - np.asarray(target)
    distance = np.hypot(towards[:, 0], towards[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        aim = (towards @ np.asarray(direction, dtype=float)) / distance
    ahead = (aim > 0.99) & (distance > 1e-4)  # the one just reached is not ahead
    if not ahead.any():
        return -1
    best = int(np.flatnonzero(ahead)[np.argmin(distance[ahead])])
    return best if best < len(scene.targets_m) else -1


def _repetition_path(view: TrialView, start_s: float, end_s: float) -> np.ndarray | None:
    time = view.time
    a, b = np.searchsorted(time, [start_s, end_s])
    if b - a < 2:
        return None
    step = max(1, (b - a) // PREVIOUS_PATH_POINTS)
    return view.column("position")[:, a:b:step].T.copy()


def _numbers(view: TrialView) -> tuple[str, ...]:
    """The two figures a therapist may choose to show: the thesis's directional
    performance and the position error, over the exercise so far."""
    out = []
    pct = view.directional_percent
    if math.isfinite(pct):
        out.append(f"Right direction {pct:.0f} %")
    rx, ry = view.rmse_xy_m
    if math.isfinite(rx):
        out.append(f"Off the path {1000.0 * math.hypot(rx, ry):.0f} mm")
    return tuple(out)
