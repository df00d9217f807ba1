"""What a virtual patient does in the assessment tasks the robot leads (core.holdtasks):
push as hard as it can toward a direction, or find again a point the robot took the hand to.

The patient of device.sim.patients follows a desired motion with its impedance and
feed-forward and pushes along it (its `drive`); in a task that motion and that push are
the patient's own plan, a core.holdtasks.TaskTrajectory of its own (`TaskBehaviour`):

* **Isometric strength.** The desired motion is the held centre; during each push the
  patient pushes toward the direction shown as hard as it can, up to the line the
  screen shows (core.control.hold: the robot's limit there), its force rising toward its
  strength with the time constant STRENGTH_RISE_S (the protocol asks for a push built up
  over a couple of seconds; the time to develop an isometric torque is itself a few
  tenths of a second, longer after stroke: McCrea, Eng & Hodgson 2003, Muscle Nerve
  28:46, doi 10.1002/mus.10397) and falling within STRENGTH_RELEASE_S when it lets go
  (TaskBehaviour.with_pushes). Its strength
  is `strength_N` times its effort: a healthy adult pushes tens of newtons at the hand in
  the horizontal plane (STRENGTH_N; maximal isometric hand forces in 8 horizontal
  directions were measured by Nijhof & Gabriel 2006, J Biomech 39:708-716, largest along
  the shoulder-hand line: the magnitude here is an order of magnitude recalled, not a
  figure taken from that paper, and the same in every direction; check before citing),
  the weak patient 40 % of it (its effort), the passive one nothing. On the thesis's
  robot both the healthy and the weak patient reach the line in every direction: their
  peaks are the robot's limit, and the stronger one gets there sooner (a higher mean
  force over the push).
* **Position sense.** The patient goes along while the robot moves the hand (its desired
  motion is the robot's reference; no push of its own), then, in the match, moves the hand
  by minimum jerk over core.holdtasks.POSITION_MOVE_S to where it remembers the target and
  holds it there, and goes home the same way. The remembered point is the target plus the
  patient's constant shift (one per trial) plus a fresh error at each visit, both normal
  with the standard deviation `proprioception_sd_m` per axis, the shift at half of it
  (a point so drawn beyond the arm's reach is matched at its reach, `within_reach`):
  healthy about 1 cm (controls' matching variability in the horizontal plane is of the
  order of 1-2 cm, Dukelow et al. 2010, Neurorehabil Neural Repair 24:178, doi
  10.1177/1545968309345267, as recalled, not checked here), the weak patient 3 cm (about
  half of the stroke subjects there fall outside the controls' range). The robot is
  transparent while the patient matches: what its inertia and friction take from a weak
  arm's impedance adds to the error. The passive patient does not match at all: its hand
  stays where the robot left it.

The draws come from a stream of the trial's seed of their own (spawn key 17), so the
other draws of a seed (tremor, wrong-way episodes, effort) stay what they were.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError, check_range
from core.holdtasks import FREE, MOVE, POSITION_MOVE_S, STILL, Stretch, TaskTrajectory

STRENGTH_N = 40.0
"""A healthy virtual patient's strongest push at the hand (module notes)."""
STRENGTH_RANGE_N = (0.0, 200.0)
STRENGTH_RISE_S = 1.0
"""The time constant of the push's rise (module notes): the protocol asks for a push built
up over a couple of seconds, as maximal isometric tests do, which also spares the hold a
step of force."""
STRENGTH_RELEASE_S = 0.1
"""The time constant of the push's fall when the patient lets go (relaxation is quick)."""
PROPRIOCEPTION_SD_M = {"weak": 0.03}
"""Each kind's matching error (module notes); every other kind's is HEALTHY_SD_M."""
HEALTHY_SD_M = 0.01
PROPRIOCEPTION_RANGE_M = (0.0, 0.2)
TASK_OPTIONS = ("strength_N", "proprioception_sd_m")
"""The make_patient options of the tasks, for every kind."""
_STREAM = 17


@dataclass(frozen=True, slots=True)
class TaskBehaviour:
    """A patient's own plan in a task: the desired motion and push it follows
    (`trajectory`), the push's size (`drive_N`, times the direction's length in the plan)
    and its lag, and, in position sense, the points it matched (`remembered_m`)."""

    trajectory: TaskTrajectory
    drive_N: float
    lag_s: float
    remembered_m: tuple[tuple[float, float], ...] = ()
    pushes: tuple[tuple[float, float, float, float, float], ...] = ()
    """Each push of the plan: (from s, to s, direction x, y, the largest push, N: the line
    over the effort)."""

    def with_pushes(self, table: np.ndarray, step_s: float) -> np.ndarray:
        """The desired-motion table (device.sim.desired_motion.desired_motion_table: the push
        in columns 6-7, its increment to the next row in 14-15, one row every `step_s`)
        with the plan's pushes in place of its push: from each push's start the force
        rises as drive_N (1 − exp(−t / lag_s)) toward the direction, no larger than the
        push's largest, and from its end falls as exp(−t / STRENGTH_RELEASE_S)."""
        if not self.pushes:
            return table
        out = table.copy()
        t = np.arange(len(out) + 1) * step_s
        size = np.zeros_like(t)
        ux = np.zeros_like(t)
        uy = np.zeros_like(t)
        for start, stop, dx, dy, largest in self.pushes:
            rising = (t >= start) & (t < stop)
            size[rising] = np.minimum(
                self.drive_N * -np.expm1(-(t[rising] - start) / self.lag_s), largest)
            end = min(self.drive_N * -np.expm1(-(stop - start) / self.lag_s), largest)
            falling = t >= stop
            size[falling] = end * np.exp(-(t[falling] - stop) / STRENGTH_RELEASE_S)
            ux[t >= start] = dx
            uy[t >= start] = dy
        push = np.column_stack((size * ux, size * uy))
        out[:, 6:8] = push[:-1]
        out[:, 14:16] = np.diff(push, axis=0)
        return out


def task_options(kind: str, options: dict) -> tuple[float, float]:
    """(strength_N, proprioception_sd_m) of a patient of `kind` from make_patient's options,
    each checked by name."""
    strength = check_range("strength_N", options.get("strength_N", STRENGTH_N),
                           *STRENGTH_RANGE_N, "N", "a hand's strongest push")
    sd = check_range("proprioception_sd_m",
                     options.get("proprioception_sd_m",
                                 PROPRIOCEPTION_SD_M.get(kind, HEALTHY_SD_M)),
                     *PROPRIOCEPTION_RANGE_M, "m", "the error of finding a point again")
    return strength, sd


def behaviour(trajectory: TaskTrajectory, effort: float, strength_N: float,
              proprioception_sd_m: float, seed, arm=None) -> TaskBehaviour:
    """The patient's own plan in the task `trajectory` (module notes), for its effort this
    trial (the fraction of a healthy subject's), its strength and matching error, the
    draws by `seed` (an int or a numpy SeedSequence); with the patient's `arm`
    (core.arm.ArmModel) a point remembered beyond its reach is matched at its reach
    (`within_reach`)."""
    if not isinstance(trajectory, TaskTrajectory):
        raise ParameterError("trajectory", type(trajectory).__name__, "a TaskTrajectory")
    if trajectory.task == "strength":
        return _pushing(trajectory, effort, strength_N)
    return _matching(trajectory, proprioception_sd_m, seed, arm)


REACH_MARGIN_M = 0.001
"""How far inside its reach a patient matches a point remembered beyond it (`within_reach`):
off the straight arm's singularity, where the arm's angles have no rate to reach it with."""


def within_reach(point: tuple[float, float], arm) -> tuple[float, float]:
    """A remembered point as the patient can match it: the point itself when the arm
    reaches it, else the point REACH_MARGIN_M inside the arm's reach (its outer edge, or
    the inner one for a point too near the shoulder) on the line from the shoulder. A
    person who remembers a target farther than they can reach goes as far as they can;
    before 2026-12-05 such a draw (a 3 cm error near the edge of a short arm's reach)
    stopped the whole trial as a path out of reach."""
    if arm is None:
        return point
    sx, sy = arm.shoulder_x_m, arm.shoulder_y_m
    dx, dy = point[0] - sx, point[1] - sy
    distance = float(np.hypot(dx, dy))
    if distance > arm.reach_max_m:
        wanted = arm.reach_max_m - REACH_MARGIN_M
    elif distance < arm.reach_min_m:
        wanted = arm.reach_min_m + REACH_MARGIN_M
    else:
        return point
    if distance == 0.0:
        return (sx + wanted, sy)
    return (sx + dx * wanted / distance, sy + dy * wanted / distance)


def _pushing(trajectory: TaskTrajectory, effort: float, strength_N: float) -> TaskBehaviour:
    """Push toward each direction as hard as the patient can, rising at its own rate, and
    no harder than the line (`TaskBehaviour.with_pushes`; the kernel multiplies the push
    by the effort, so the plan's largest push is the line over the effort)."""
    pushes = tuple((s.start_s, s.stop_s, *s.push,
                    dict(s.values)["line_N"] / effort if effort > 0.0 else 0.0)
                   for s in trajectory.stretches if s.push != (0.0, 0.0))
    return TaskBehaviour(trajectory, strength_N, STRENGTH_RISE_S, pushes=pushes)


def _matching(trajectory: TaskTrajectory, sd_m: float, seed, arm=None) -> TaskBehaviour:
    """Go along with the robot, then move to the remembered point (within the arm's reach,
    `within_reach`), hold, and go home."""
    matches = [s for s in trajectory.stretches if s.phase == "match"]
    draws = _stream(seed).normal(0.0, 1.0, (len(matches) + 1, 2))
    shift = 0.5 * sd_m * draws[0]
    remembered = [within_reach((s.end[0] + shift[0] + sd_m * d[0],
                                s.end[1] + shift[1] + sd_m * d[1]), arm)
                  for s, d in zip(matches, draws[1:], strict=True)]
    own: list[Stretch] = []
    found = iter(remembered)
    for s in trajectory.stretches:
        if s.kind != FREE:
            # going along with the robot's move, pushing nowhere
            own.append(Stretch(s.start_s, s.stop_s, s.kind, s.start, s.end, s.phase))
            continue
        start = own[-1].end if own else s.start
        goal = next(found) if s.phase == "match" else s.end
        arrive = min(s.start_s + POSITION_MOVE_S, s.stop_s)
        own.append(Stretch(s.start_s, arrive, MOVE, start, goal, s.phase))
        if arrive < s.stop_s:
            own.append(Stretch(arrive, s.stop_s, STILL, goal, goal, s.phase))
    return TaskBehaviour(trajectory.replaced(tuple(own)), 0.0, STRENGTH_RISE_S,
                         tuple(remembered))


def _stream(seed) -> np.random.Generator:
    if isinstance(seed, np.random.SeedSequence):
        sequence = np.random.SeedSequence(seed.entropy, spawn_key=(*seed.spawn_key, _STREAM))
    else:
        sequence = np.random.SeedSequence(int(seed), spawn_key=(_STREAM,))
    return np.random.default_rng(sequence)
