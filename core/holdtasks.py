"""The timetables of the two assessment tasks the robot leads, isometric strength and
position sense, as trajectories the loop, the virtual patients and the files share.

A task's trial is a `targets` layout (core.trajectory.centre_out: the centre and n
directions or targets round it, first straight ahead, counter-clockwise), and its
`trajectory()` is a `TaskTrajectory`: a chain of stretches, each the robot holding a point
(`still`), moving the hand on the clock from one point to another by minimum jerk
(`move`), or letting the patient move freely (`free`, the transparent mode's law). The
robot leads the still and move stretches (core.control.hold); every stretch's start is a
timed event of the trial file (`events`), so the figures find each phase by its event.

Isometric strength (per direction k, round after round; `duration_s` is the push)
    ready   STRENGTH_READY_S, held still at the centre: the direction is shown
    push    duration_s, held still: push toward it as hard as you can, up to the line
            (the reference's direction is the push's, so the record's cone angle is the
            push's error of direction)
    rest    STRENGTH_REST_S, held still: let go
Directions in the order of the layout, one push each per round (`repetitions` rounds).

Position sense (per target k, round after round; `duration_s` is the reproduction)
    centre  POSITION_PAUSE_S, held at the centre (the patient's screen is blank from here)
    out     POSITION_MOVE_S, the robot moves the relaxed hand to the target
    there   POSITION_AT_TARGET_S, held at the target
    back    POSITION_MOVE_S, moved back to the centre
    settle  POSITION_PAUSE_S, held at the centre
    match   duration_s, free: move the hand to where it was and hold it there (the
            reference rests at the target, so the record's reference is what the hand
            should find)
    home    POSITION_HOME_S, free: bring the hand back to the centre
The screen stays blank until the round's last `home` (blank in the events' values).
Holding the hand at the target for a second before bringing it back is the passive
ipsilateral matching of position-sense testing (the robot leads, the patient matches with
the same arm; Dukelow et al. 2010, Neurorehabil Neural Repair 24:178, doi
10.1177/1545968309345267, match with the other arm, which this one-handle robot cannot).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.arrays import groups, joint_motion
from core.control.hold import LINE_FRACTION, hold_capacity_N
from core.errors import ParameterError
from core.robot import RobotModel
from core.trajectory import Path, TrajectorySample, centre_out, centre_out_angles

ROBOT_TASKS = ("strength", "position")
"""The assessment tasks (core.assessment.TASKS) whose trajectory is a TaskTrajectory."""
STRENGTH_READY_S = 1.0
STRENGTH_REST_S = 2.0
POSITION_PAUSE_S = 0.5
POSITION_MOVE_S = 1.5
"""A 10 cm passive move in 1.5 s: a peak speed of 0.125 m/s, slow enough that the
patient feels it without the move itself startling a stretch reflex."""
POSITION_AT_TARGET_S = 1.0
POSITION_HOME_S = 2.0
STILL, MOVE, FREE = "still", "move", "free"


@dataclass(frozen=True, slots=True)
class Stretch:
    """One stretch of a task's timetable, from `start_s` to `stop_s` on the exercise's
    clock: the robot holding `end` (still), moving from `start` to `end` (move) or letting
    go with the reference resting at `end` (free). `push` is the unit direction the
    patient is asked to push in (strength), else (0, 0); `phase` names it (the event)."""

    start_s: float
    stop_s: float
    kind: str
    start: tuple[float, float]
    end: tuple[float, float]
    phase: str
    push: tuple[float, float] = (0.0, 0.0)
    values: tuple = ()

    @property
    def duration_s(self) -> float:
        return self.stop_s - self.start_s


class TaskTrajectory:
    """A task's timetable with the interface of core.trajectory.Trajectory (`sample`, `at`,
    `joint_reference`, `duration_s`, `repetitions`, `total_duration_s`, `path`): one
    traversal holding every round, so that each round's stretch is its own."""

    timing = "minimum_jerk"
    repetitions = 1

    def __init__(self, task: str, path: Path, stretches: tuple[Stretch, ...]) -> None:
        if task not in ROBOT_TASKS:
            raise ParameterError("assessment", task, "one of " + ", ".join(ROBOT_TASKS))
        self.task = task
        self.path = path
        self.stretches = stretches
        self.duration_s = stretches[-1].stop_s
        self.segment_times_s = tuple([s.start_s for s in stretches] + [self.duration_s])
        self._starts = np.array([s.start_s for s in stretches])

    @property
    def total_duration_s(self) -> float:
        return self.duration_s

    @property
    def mean_speed_m_s(self) -> float:
        return self.path.length / self.duration_s

    @property
    def peak_speed_m_s(self) -> float:
        """The fastest move's peak speed (15/8 of its mean under minimum jerk), 0 when the
        robot never moves the hand."""
        peaks = [1.875 * math.dist(s.start, s.end) / s.duration_s
                 for s in self.stretches if s.kind == MOVE]
        return max(peaks, default=0.0)

    def held_windows_s(self) -> tuple[tuple[float, float], ...]:
        """The stretches the robot leads, joined where they touch: ((start, stop), ...)."""
        out: list[list[float]] = []
        for s in self.stretches:
            if s.kind == FREE:
                continue
            if out and out[-1][1] == s.start_s:
                out[-1][1] = s.stop_s
            else:
                out.append([s.start_s, s.stop_s])
        return tuple((a, b) for a, b in out)

    def events(self) -> tuple[tuple[float, str, dict], ...]:
        """(exercise time s, phase, values) at every stretch's start."""
        return tuple((s.start_s, s.phase, dict(s.values)) for s in self.stretches)

    def sample(self, t_s) -> TrajectorySample:
        """The reference at the times `t_s` (any shape, flattened): held points, minimum-
        jerk moves, the free stretches' point; at rest at the start outside the task."""
        t = np.asarray(t_s, dtype=float).ravel()
        inside = (t >= 0.0) & (t < self.duration_s)
        idx = np.clip(np.searchsorted(self._starts, t, side="right") - 1, 0,
                      len(self.stretches) - 1)
        pos = np.zeros((t.size, 2))
        vel = np.zeros((t.size, 2))
        acc = np.zeros((t.size, 2))
        direction = np.zeros((t.size, 2))
        # each stretch's samples, in order (core.arrays.groups)
        for k, sel in enumerate(groups(np.where(inside, idx, -1), len(self.stretches))):
            if not sel.size:
                continue
            s = self.stretches[k]
            end = np.asarray(s.end)
            if s.kind != MOVE:
                pos[sel] = end
                direction[sel] = s.push
                continue
            start = np.asarray(s.start)
            span = s.duration_s
            u = (t[sel] - s.start_s) / span
            shape = u**3 * (10.0 - 15.0 * u + 6.0 * u * u)
            rate = 30.0 * u * u * (1.0 - u) ** 2 / span
            accel = 60.0 * u * (1.0 - 3.0 * u + 2.0 * u * u) / span**2
            delta = end - start
            pos[sel] = start + shape[:, None] * delta
            vel[sel] = rate[:, None] * delta
            acc[sel] = accel[:, None] * delta
            length = float(np.linalg.norm(delta))
            direction[sel] = delta / length if length > 0.0 else 0.0
        pos[~inside] = self.stretches[0].start
        return TrajectorySample(t, pos, vel, acc, direction, idx, np.where(inside, 0, 1))

    def at(self, t: float):
        """(x, y, vx, vy, ax, ay, direction_x, direction_y) at one time, floats."""
        s = self.sample(np.array([t]))
        return (*map(float, s.position_m[0]), *map(float, s.velocity_m_s[0]),
                *map(float, s.acceleration_m_s2[0]), *map(float, s.direction[0]))

    def joint_reference(self, robot: RobotModel, t_s):
        """The robot's joint angles, rates and accelerations at `t_s` (eq. 3.1, 3.4, 3.5)."""
        sample = self.sample(t_s)
        return joint_motion(robot, sample.position_m, sample.velocity_m_s,
                            sample.acceleration_m_s2)

    def replaced(self, stretches: tuple[Stretch, ...]) -> TaskTrajectory:
        """The same task and path with other stretches (a virtual patient's own plan)."""
        return TaskTrajectory(self.task, self.path, stretches)


def direction_deg(angle_rad: float) -> int:
    """A layout direction in whole degrees 0-359, counter-clockwise from +x (the key of
    the strength figures)."""
    return round(math.degrees(angle_rad)) % 360


def strength_trajectory(centre, arrow_m: float, n_directions: int, push_s: float,
                        rounds: int, robot: RobotModel | None = None) -> TaskTrajectory:
    """The isometric strength task's timetable (module notes) at `centre`, its directions
    drawn as arrows of `arrow_m` (the layout's radius), each push's line at LINE_FRACTION
    of what `robot`'s drives can hold there (core.control.hold)."""
    robot = robot or RobotModel()
    centre = (float(centre[0]), float(centre[1]))
    q1, q2 = robot.ik_terms(*centre)
    stretches: list[Stretch] = []
    t = 0.0
    for r in range(rounds):
        for k, angle in enumerate(centre_out_angles(n_directions)):
            line = LINE_FRACTION * hold_capacity_N(robot, q1, q2, angle)
            values = (("direction_deg", direction_deg(angle)), ("direction_rad", angle),
                      ("line_N", line), ("index", k), ("round", r))
            push = (math.cos(angle), math.sin(angle))
            for phase, span, pushing in (("ready", STRENGTH_READY_S, False),
                                         ("push", push_s, True),
                                         ("rest", STRENGTH_REST_S, False)):
                stretches.append(Stretch(t, t + span, STILL, centre, centre, phase,
                                         push if pushing else (0.0, 0.0), values))
                t += span
    return TaskTrajectory("strength", centre_out(centre, arrow_m, n_directions),
                          tuple(stretches))


def position_trajectory(centre, distance_m: float, n_targets: int, match_s: float,
                        rounds: int) -> TaskTrajectory:
    """The position-sense task's timetable (module notes): targets `distance_m` from
    `centre` in the layout's directions, matched for `match_s` each."""
    centre = (float(centre[0]), float(centre[1]))
    stretches: list[Stretch] = []
    t = 0.0
    for r in range(rounds):
        for k, angle in enumerate(centre_out_angles(n_targets)):
            target = (centre[0] + distance_m * math.cos(angle),
                      centre[1] + distance_m * math.sin(angle))
            last = r == rounds - 1 and k == n_targets - 1
            values = (("target_m", target), ("index", k), ("round", r))
            plan = ((STILL, centre, centre, "centre", POSITION_PAUSE_S),
                    (MOVE, centre, target, "out", POSITION_MOVE_S),
                    (STILL, target, target, "there", POSITION_AT_TARGET_S),
                    (MOVE, target, centre, "back", POSITION_MOVE_S),
                    (STILL, centre, centre, "settle", POSITION_PAUSE_S),
                    (FREE, centre, target, "match", match_s),
                    (FREE, target, centre, "home", POSITION_HOME_S))
            for kind, start, end, phase, span in plan:
                blank = not (last and phase == "home")
                stretches.append(Stretch(t, t + span, kind, start, end, phase, (0.0, 0.0),
                                         (*values, ("blank", blank))))
                t += span
    return TaskTrajectory("position", centre_out(centre, distance_m, n_targets),
                          tuple(stretches))


def task_trajectory(parameters) -> TaskTrajectory:
    """The timetable of a trial of a task the robot leads (its `assessment` one of
    ROBOT_TASKS): the layout's centre, radius and count, `duration_s` the push or the
    match, `repetitions` the rounds. Refuses a match too short to move and hold."""
    task = parameters.assessment
    p = parameters
    if task == "strength":
        return strength_trajectory(p.centre_m, p.radius_m, p.n_targets, p.duration_s,
                                   p.repetitions)
    if task == "position":
        shortest = POSITION_MOVE_S + 1.0
        if p.duration_s < shortest:
            raise ParameterError("duration_s", p.duration_s, f"at least {shortest:g} s",
                                 "the match must leave time to move to the point and hold "
                                 "it there")
        return position_trajectory(p.centre_m, p.radius_m, p.n_targets, p.duration_s,
                                   p.repetitions)
    raise ParameterError("assessment", task, "one of " + ", ".join(ROBOT_TASKS),
                         "only these tasks have a timetable the robot leads")
