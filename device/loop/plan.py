"""A trial as the loop runs it: its reference at the loop's rate, computed a stretch of
ticks at a time, and the approach from wherever the handle is to the path's start
(`TrialPlan`); the loop's period and the phases a record's `phase` names.

The reference is the thesis's path (eq. 3.1, 3.4, 3.5) sampled at each tick; the approach a
minimum-jerk straight line. Built once (the Build button), before anything moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from core.arrays import joint_motion
from core.assessment.protocol import CUE_EVENT, task_events
from core.robot import RobotModel
from core.trajectory import Trajectory
from core.trial import TrialParameters
from core.trial_check import check_trial

PERIOD_S = 0.002
RATE_CUTOFF_HZ = 20.0
"""Bandwidth of the encoder rate tracker: above human movement (< 5 Hz) and tremor
(4–6 Hz), with an acceleration delay of about 24 ms (core.signal.RateEstimator)."""
APPROACH_SPEED_M_S = 0.05
"""Mean speed of the approach from the handle's position to the path's start."""
APPROACH_MIN_S = 1.0
APPROACH_SKIP_M = 0.002
"""Closer than this to the start point, the handle is at the start: no approach, or only
the still one a trial that starts with a torque ramp asks for (TickPipeline.begin)."""
HOLD_S = 0.5
"""Time the reference rests at the start point after the last repetition."""

PHASE_IDLE, PHASE_APPROACH, PHASE_EXERCISE, PHASE_HOLD = 0, 1, 2, 3


@dataclass(frozen=True, slots=True)
class TrialPlan:
    """A validated trial whose reference is computed at the loop rate, a stretch of ticks
    at a time (`reference`).

    Built once (the Build button): refuses unreachable or absurd parameters with
    the reason before anything moves. `tabulated` computes the whole reference then (the
    live loop: Build is a command at zero torque, and Start then only plans the approach);
    otherwise it holds no per-tick table, since a 100 × 120 s trial's reference is
    6 million rows (576 MB): a headless run asks for the rows it is about to use
    (TickPipeline.load_rows).
    """

    parameters: TrialParameters
    robot: RobotModel
    period_s: float
    trajectory: Trajectory = field(compare=False, repr=False)
    table: np.ndarray | None = field(default=None, compare=False, repr=False)
    """The whole reference (`reference`'s rows), when built `tabulated`."""
    first_row: np.ndarray | None = field(default=None, compare=False, repr=False)
    """The exercise's first row (`reference(0, 1)`), kept by `build`: the start point, an
    approach that stays there and a headless run's first load each asked for it again, a
    sample of the path and its inverse kinematics for one row (a third of a ms each)."""

    @classmethod
    def build(
        cls, parameters: TrialParameters, robot: RobotModel | None = None,
        period_s: float = PERIOD_S, *, tabulated: bool = False,
    ) -> TrialPlan:
        robot = robot or RobotModel()
        check_trial(parameters, robot).require_ok()
        plan = cls(parameters, robot, period_s, parameters.trajectory())
        plan = replace(plan, first_row=plan.reference(0, 1))
        if tabulated:
            plan = replace(plan, table=plan.reference(0, plan.exercise_ticks))
        return plan

    def reference(self, first: int, stop: int) -> np.ndarray:
        """The exercise's reference at ticks first…stop−1 as one (N, 12) array: (xd, yd,
        vxd, vyd, dx, dy, r1, r2, rd1, rd2, rdd1, rdd2) (eq. 3.1, 3.4, 3.5). Each row is a
        function of its tick alone (t = tick × period), so any stretch has the rows the
        whole table would have, bit for bit."""
        first, stop = max(0, first), min(stop, self.exercise_ticks)
        if self.table is not None:
            return self.table[first:max(first, stop)]
        if first == 0 and stop == 1 and self.first_row is not None:
            return self.first_row.copy()
        t = np.arange(first, max(first, stop)) * self.period_s
        # the joint columns from the same sample (the trajectory's joint_reference is this
        # sample through joint_motion: calling it sampled the path a second time)
        sample = self.trajectory.sample(t)
        q, qd, qdd = joint_motion(self.robot, sample.position_m, sample.velocity_m_s,
                                  sample.acceleration_m_s2)
        return np.column_stack(
            (sample.position_m, sample.velocity_m_s, sample.direction, q, qd, qdd)
        )

    @property
    def exercise_ticks(self) -> int:
        return round(self.trajectory.total_duration_s / self.period_s)

    def task_events(self) -> tuple[tuple[int, str, str, dict], ...]:
        """The timed events of an assessment trial (core.assessment.protocol.task_events:
        a cued task's cues, a robot-led task's phases) as (exercise tick, kind, message,
        values), the same as app.assessments.events writes after a headless run; none for
        an exercise."""
        return tuple((round(t / self.period_s), TASK_EVENT, message, values)
                     for t, message, values in task_events(self.parameters, self.trajectory))

    @property
    def start_point_m(self) -> tuple[float, float]:
        row = self.reference(0, 1)[0]
        return (float(row[0]), float(row[1]))

    def approach_rows(self, q1: float, q2: float, still_s: float = 0.0) -> tuple:
        """Reference rows from the handle's pose to the path's start: a minimum-jerk
        straight line at about APPROACH_SPEED_M_S, at least APPROACH_MIN_S long."""
        return tuple(map(tuple, self.approach_table(q1, q2, still_s).tolist()))

    def approach_table(self, q1: float, q2: float, still_s: float = 0.0) -> np.ndarray:
        """`approach_rows` as one (N, 12) array. A handle already at the start has none, or
        `still_s` of rows holding it there; an approach lasts at least `still_s` too."""
        robot = self.robot
        x0, y0 = robot.position(q1, q2)
        x1, y1 = self.start_point_m
        distance = math.hypot(x1 - x0, y1 - y0)
        if distance < APPROACH_SKIP_M:
            n = math.ceil(still_s / self.period_s)
            still = np.zeros(12)  # at the start, at rest: no velocity, no acceleration
            start = self.reference(0, 1)[0]
            still[[0, 1, 4, 5, 6, 7]] = start[[0, 1, 4, 5, 6, 7]]  # place, path direction, angles
            return np.tile(still, (n, 1))
        duration = max(APPROACH_MIN_S, still_s, distance / APPROACH_SPEED_M_S)
        n = math.ceil(duration / self.period_s)
        u = np.arange(n) * self.period_s / duration
        s = u**3 * (10 - 15 * u + 6 * u**2)
        sd = 30 * u**2 * (1 - u) ** 2 / duration
        sdd = 60 * u * (1 - 3 * u + 2 * u**2) / duration**2
        ux, uy = (x1 - x0) / distance, (y1 - y0) / distance
        pos = np.column_stack((x0 + ux * distance * s, y0 + uy * distance * s))
        vel = np.column_stack((ux * distance * sd, uy * distance * sd))
        acc = np.column_stack((ux * distance * sdd, uy * distance * sdd))
        q, qd, qdd = joint_motion(robot, pos, vel, acc)
        direction = np.tile([ux, uy], (n, 1))
        return np.column_stack((pos, vel, direction, q, qd, qdd))


TASK_EVENT = CUE_EVENT
"""The kind of an assessment's cue events in the trial file (app.assessments.events)."""
