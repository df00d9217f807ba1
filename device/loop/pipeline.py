"""The per-tick computation of a trial, shared by the real-time loop and headless runs.

One tick, in the order of the thesis's scheme (Fig. 3.6):

    sensors → rate estimate → reference → controller → performance-based assistance
            → [safety supervisor, motors: the caller] → subject model → record

`control()` runs everything up to the commanded torque, so the caller can pass it
through the supervisor and write it to the motors with the least delay; `record()`
then does the rest (the subject's joint angles, rates and torques, eq. 3.27–3.38)
and returns the tick's record as plain numbers in `device.recording.record.flat_names()` order,
ready for `RecordRing.push` or `RecordLog.append`.

`control` is a kernel (core.kernels) on precomputed tables and flat vectors: Python
tuples and lists interpreted, float arrays compiled; `record` works on plain floats.
numpy computes only when a trial is built (`TrialPlan`), when it starts (`begin`, which
plans the approach from wherever the handle is to the path's start point and, in the live
loop, computes every reference row) and, in a headless run, between blocks of ticks
(`load_rows`: the next rows of the reference, so that a long trial's is never held whole).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from core.arrays import joint_motion
from core.assessment.protocol import CUE_EVENT, task_events
from core.control.assistance import (
    A_EST_FX,
    A_EST_FY,
    A_EST_TICK,
    A_LEVEL,
    PerformanceAssistance,
    assisted_torques,
    cone_test,
    judged_force,
)
from core.control.base import make_controller
from core.control.ctpid import (
    I_SIZE,
    ComputedTorquePID,
    ctpid_acceleration,
    ctpid_limit,
    ctpid_torques,
)
from core.control.gains import built
from core.control.guidance import (
    GC_DELAY_ROWS,
    GC_ON,
    GS_KEPT,
    GS_U,
    OFF,
    GuidanceGains,
    guidance_command,
    guidance_rows,
    state_size,
)
from core.control.hold import HC_ON, HS_SIZE, OFF as NOT_HELD, held_at, hold_constants, taken_over
from core.control.smc import SlidingModeController, smc_torques
from core.control.transparent import OFF as NOT_TRANSPARENT, TC_ON, transparent_torques
from core.errors import ParameterError
from core.holdtasks import TaskTrajectory
from core.interaction import (
    SubjectState,
    rotated_to_global,
    sensor_to_global,
    subject_motion,
)
from core.kernels import interpreted, kernel
from core.learning.kernel import learned_torques
from core.robot import RobotModel
from core.robot_terms import R_SIZE
from core.signal import RateEstimator, track
from core.trajectory import Trajectory
from core.trial import TrialParameters, check_trial
from device.backend import SensorReading

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


class TickPipeline:
    """The state one trial's ticks share: rate trackers, controller, assistance, reference.

    The tick itself is the kernel `control` below, run interpreted on this object's
    vectors (Python tuples and lists) or, with `compiled=True`, compiled on float
    arrays, which is what the loop's tick engine and the headless run use
    (device.loop.engine). A controller the kernel does not know (a computed-torque PID
    on a learned model, say) runs interpreted, through its own `step`.
    """

    def __init__(
        self,
        plan: TrialPlan,
        *,
        sensor_offset_rad: float = 0.0,
        rate_cutoff_hz: float = RATE_CUTOFF_HZ,
        controller=None,
        min_force_N: float | None = None,
        guidance: GuidanceGains | None = None,
        compiled: bool = False,
    ) -> None:
        self.plan = plan
        params = plan.parameters
        self.robot = plan.robot
        self.arm = params.arm()
        self.period_s = plan.period_s
        self.sensor_offset_rad = sensor_offset_rad
        self.controller = controller or make_controller(
            params.controller, self.robot, gains=built(params.controller, params.gains))
        options = {} if min_force_N is None else {"min_force_N": min_force_N}
        self.assistance = PerformanceAssistance(
            self.robot, tolerance_rad=params.tolerance_rad, level=params.assistance_level,
            **options,
        )
        if params.force_estimate:
            # the assistance judges an estimate of the patient's force (from EMG), which the
            # console gives between ticks (set_force_estimate)
            self.assistance.judge_estimate(plan.period_s)
        self.rate_estimator = RateEstimator(plan.period_s, rate_cutoff_hz)
        self.guidance = None
        """The as-needed mode's gains (core.control.guidance), None in the thesis mode."""
        guide, guided = OFF, [0.0] * state_size(1, 0)
        if params.assist == "as-needed":
            self.guidance = guidance if guidance is not None else built("guidance",
                                                                        params.gains)
            if not isinstance(self.guidance, GuidanceGains):
                raise ParameterError("guidance", type(guidance).__name__, "a GuidanceGains")
            guide = self.guidance.constants(period_s=plan.period_s,
                                            repetition_s=params.duration_s)
            guided = [0.0] * state_size(self.guidance.bins, params.repetitions)
        self.transparent = None
        """The transparent mode's gains (core.control.transparent), None in the others."""
        clear = NOT_TRANSPARENT
        if params.assist == "transparent":
            self.transparent = built("transparent", params.gains)
            clear = self.transparent.constants()
        held = NOT_HELD
        if isinstance(plan.trajectory, TaskTrajectory):
            # a task the robot leads (core.holdtasks): its held stretches in exercise ticks
            if params.assist != "transparent":
                raise ParameterError("assist", params.assist, "transparent",
                                     f"the {plan.trajectory.task} task lets the patient "
                                     "move only in the transparent mode's law")
            held = hold_constants([(round(a / plan.period_s), round(b / plan.period_s))
                                   for a, b in plan.trajectory.held_windows_s()])
        # the exercise's law: the guidance's constants (GC_*), then the transparent mode's
        # (TC_*), then the hold's windows (core.control.hold HC_*); all zero in the thesis
        # mode
        guide = [*guide, *clear, *held]
        self.kind = _controller_kind(self.controller, compiled)
        if compiled and self.kind == GENERIC:
            raise ParameterError(
                "compiled", compiled, "False for this controller",
                f"a {type(self.controller).__name__} on a {type(self.controller.model).__name__}"
                " has no compiled form; it runs interpreted through its own step",
            )
        self.compiled = compiled
        self._make = _arrays if compiled else _python
        self.vectors = Vectors(
            robot=self._make(self.robot.constants),
            arm=self._make(self.arm.constants),
            model=self._make(self.controller.model.kernel_weights if self.kind == LEARNED
                             else getattr(self.controller.model, "constants", ())),
            tracker=self._make(self.rate_estimator.coefficients),
            gains=self._make(getattr(self.controller, "constants", ())),
            assist=self._make(self.assistance.constants),
            guide=self._make(guide),
            rates=self._make([0.0] * Z_SIZE),
            integral=self._make([0.0] * HS_SIZE),
            guided=self._make(guided),
            last=self._make([0.0] * C_SIZE),
            rows=self._table(np.empty((0, 12))),
        )
        self._approach = np.empty((0, 12))
        self._approach_ticks = 0
        self.rows_from = 0
        """The first row (tick) of the approach and exercise the loaded rows hold."""
        self.n_rows = 0
        """How many rows the trial's approach and exercise have (`begin`)."""
        self._ticked = False
        self.replacements = _replacements(self.controller, self.kind)
        """What an interpreted `control` replaces (a controller's own step), for the
        kernels that call it (device.loop.engine)."""
        if compiled:
            from device.compiled.jit import compiled as compile_kernel  # numba only here

            self._control = compile_kernel(control)
            self._subject = compile_kernel(subject_motion)
        else:
            self._control = interpreted(control, self.replacements)
            self._subject = subject_motion

    def _table(self, table: np.ndarray):
        if self.compiled:
            return np.ascontiguousarray(table, dtype=float) if len(table) else np.zeros((1, 12))
        return tuple(map(tuple, table.tolist()))

    # ------------------------------------------------------------------ trial
    def begin(self, q1: float, q2: float, *, load: bool = True, still_s: float = 0.0) -> None:
        """Start a trial from the handle's current pose: plan the approach, reset state.

        `still_s`: the approach lasts at least this long, holding a handle already at the
        start there. The live loop passes its supervisor's restart ramp (docs/safety.md
        H3): an exercise begun at once ran its first half second on a fraction of the
        drives' torque, and the tracker sat at the clamp for a second catching up, which a
        lasting clamp's fault (H2) must not take for a patient resisting.

        With `load` every row of the approach and the exercise is loaded at once (the
        live loop: no tick waits for rows); a headless run passes False and loads the
        rows a stretch of ticks needs before it (`load_rows`, `rows_needed`), so that its
        memory does not grow with the trial's length."""
        self._approach = self.plan.approach_table(q1, q2, still_s)
        self._approach_ticks = len(self._approach)
        self.n_rows = self._approach_ticks + self.plan.exercise_ticks
        self.load_rows(0, self.n_rows if load else 1)
        self.controller.reset()
        v = self.vectors
        v.rates[:] = self._make([q1, 0.0, 0.0, q2, 0.0, 0.0])
        v.integral[:] = self._make([0.0] * HS_SIZE)
        v.guided[:] = self._make([0.0] * len(v.guided))
        # no estimate of the patient's force carries over from a trial before
        self.set_force_estimate(math.nan, math.nan, -math.inf)
        self._ticked = False

    def task_events(self) -> tuple[tuple[int, str, str, dict], ...]:
        """The task's timed events (TrialPlan.task_events) on the trial's ticks, the
        approach `begin` planned before them: (tick, kind, message, values)."""
        return tuple((self._approach_ticks + k, kind, message, values)
                     for k, kind, message, values in self.plan.task_events())

    def rows(self, first: int, stop: int) -> np.ndarray:
        """Rows first…stop−1 of the trial's reference, the approach `begin` planned then
        the exercise (TrialPlan.reference), as one (N, 12) array."""
        approach = self._approach[max(0, first):max(0, min(stop, self._approach_ticks))]
        if stop <= self._approach_ticks:
            return approach
        exercise = self.plan.reference(max(first, self._approach_ticks) - self._approach_ticks,
                                       stop - self._approach_ticks)
        return np.vstack((approach, exercise)) if len(approach) else exercise

    def load_rows(self, first: int, stop: int) -> None:
        """Make rows first…stop−1 of the reference (clipped to the trial's, and at least
        one: the hold reads the last) the ones the tick reads."""
        first = max(0, min(first, self.n_rows - 1))
        stop = max(first + 1, min(stop, self.n_rows))
        self.vectors.rows = self._table(self.rows(first, stop))
        self.rows_from = first

    def rows_needed(self, tick: int) -> tuple[int, int]:
        """The lowest and highest row tick `tick` may read (the kernel `rows_needed`)."""
        v = self.vectors
        return rows_needed(v.guide, v.guided, self._approach_ticks, tick, self.n_rows)

    @property
    def reference_rows(self) -> np.ndarray:
        """The reference rows loaded, from row `rows_from` (after `begin` in the live loop,
        every row of the approach and the exercise): (x_d, y_d, ẋ_d, ẏ_d, direction x, y,
        θ_d1, θ_d2, θ̇_d1, θ̇_d2, θ̈_d1, θ̈_d2)."""
        return np.asarray(self.vectors.rows, dtype=float)

    @property
    def loaded_rows(self) -> int:
        """How many rows of the reference are held now."""
        return len(self.vectors.rows)

    @property
    def total_ticks(self) -> int:
        """Approach + exercise + hold: when the trial is complete. In the as-needed mode
        the exercise may run up to the guidance's delay past the clock."""
        return (self.n_rows + round(HOLD_S / self.period_s)
                + int(self.vectors.guide[GC_DELAY_ROWS]))

    @property
    def feedforward_history(self) -> np.ndarray:
        """The as-needed mode's learned feedforward (N along the path) in each bin at the
        end of each repetition, (repetitions, bins); empty in the thesis mode. A
        repetition the trial did not finish is NaN."""
        if self.guidance is None:
            return np.empty((0, 0))
        bins, reps = self.guidance.bins, self.plan.parameters.repetitions
        state = np.asarray(self.vectors.guided, dtype=float)
        history = state[GS_U + bins:GS_U + bins * (reps + 1)].reshape(reps, bins).copy()
        done = int(state[GS_KEPT])
        if done < reps:
            history[done:] = math.nan
        return history

    @property
    def approach_ticks(self) -> int:
        return self._approach_ticks

    @property
    def rates(self) -> tuple[float, float]:
        """The joint-rate estimate of the last `control` call (rad/s)."""
        last = self.vectors.last
        return (float(last[C_QD1]), float(last[C_QD2]))

    @property
    def last_tick(self) -> tuple | None:
        """What the last `control` computed, as `record` reads it (None before the first)."""
        if not self._ticked:
            return None
        values = [float(v) for v in self.vectors.last]
        values[C_PHASE] = int(values[C_PHASE])
        values[C_ACTIVE] = bool(values[C_ACTIVE])
        return tuple(values)

    def ticked(self) -> None:
        """`control` ran outside `control` (the tick engine ran the kernel itself)."""
        self._ticked = True

    def set_assistance_level(self, level: float) -> None:
        self.assistance.set_level(level)
        self.vectors.assist[A_LEVEL] = self.assistance.level

    def set_force_estimate(self, fx: float, fy: float, tick: int) -> None:
        """The latest estimate of the patient's force on the handle (global frame, N; NaN
        when lost) for tick `tick`, which the assistance judges in place of the sensor's
        when the trial names a force estimate (TrialParameters.force_estimate)."""
        self.assistance.set_estimate(fx, fy, tick)
        for index in (A_EST_FX, A_EST_FY, A_EST_TICK):
            self.vectors.assist[index] = self.assistance.constants[index]

    def reset_controller(self) -> None:
        """Forget the controller's integral (after a fault held the torque at zero)."""
        self.controller.reset()
        self.vectors.integral[:] = self._make([0.0] * HS_SIZE)

    # ------------------------------------------------------------------ per tick
    def control(self, k: int, reading: SensorReading) -> tuple[float, float]:
        """Commanded joint torques for tick k of the trial (before the supervisor)."""
        v = self.vectors
        self._control(self.kind, v.robot, v.model, v.tracker, v.gains, v.assist, v.guide,
                      v.rates, v.integral, v.guided, k, v.rows, self.rows_from, self.n_rows,
                      self._approach_ticks, self.period_s, self.sensor_offset_rad,
                      reading.q1_rad, reading.q2_rad, reading.force_x_N, reading.force_y_N,
                      v.last)
        self._ticked = True
        return (float(v.last[C_OUT1]), float(v.last[C_OUT2]))

    def record(
        self, k: int, reading: SensorReading, wall_s: float, lateness_s: float,
        compute_s: float, applied: tuple[float, float], state: int, fault: int,
    ) -> tuple:
        """The tick's record (flat_names order), with the subject model run on it."""
        last = self.last_tick
        q1, q2 = reading.q1_rad, reading.q2_rad
        v = self.vectors
        s = SubjectState(*self._subject(
            v.robot, v.arm, q1, q2, last[C_QD1], last[C_QD2], last[C_QDD1], last[C_QDD2],
            reading.force_x_N, reading.force_y_N, self.sensor_offset_rad,
        ))
        return record_values(k, k * self.period_s, wall_s, lateness_s, compute_s, reading,
                             last, applied, self.robot.position(q1, q2), s, state, fault)


def assistance_group(parameters: TrialParameters, guidance: GuidanceGains | None,
                     feedforward_N: np.ndarray) -> dict:
    """The trial file's /assistance group (docs/data-format.md): the mode, the level the
    trial started with and, in the as-needed mode, the guidance's gains and its learned
    feedforward per repetition and bin (TickPipeline.feedforward_history), in the
    transparent mode its shares (core.control.transparent)."""
    out: dict = {"mode": parameters.assist, "level": parameters.assistance_level}
    if parameters.assist == "transparent":
        out.update(built("transparent", parameters.gains).to_dict())
    if guidance is not None:
        out.update(guidance.to_dict())
        out["feedforward_N"] = np.asarray(feedforward_N, dtype=float)
    return out


def record_values(tick, time_s, wall_s, lateness_s, compute_s, reading, last, applied,
                  position, subject, state, fault) -> tuple:
    """A record's values in `flat_names` order, from a tick's SensorReading, what
    `control` left (C_*), the torques applied, the handle's position and the subject
    model's SubjectState: plain numbers for one tick, or arrays for many (a SensorReading
    and a SubjectState of arrays, `last` indexed by C_* first)."""
    r, c, s = reading, last, subject
    return (
        tick, time_s, wall_s, c[C_PHASE], lateness_s, compute_s,
        r.q1_rad, r.q2_rad, c[C_QD1], c[C_QD2], c[C_QDD1], c[C_QDD2],
        c[C_R1], c[C_R2], c[C_RD1], c[C_RD2], c[C_RDD1], c[C_RDD2],
        c[C_TAU1], c[C_TAU2], c[C_OUT1], c[C_OUT2], applied[0], applied[1],
        position[0], position[1], c[C_XD], c[C_YD], c[C_VXD], c[C_VYD], c[C_DX], c[C_DY],
        r.force_x_N, r.force_y_N, r.force_z_N, c[C_FX], c[C_FY], c[C_ANGLE], c[C_ACTIVE],
        c[C_LEVEL], s.shoulder_rad, s.elbow_rad, s.shoulder_rate_rad_s, s.elbow_rate_rad_s,
        s.shoulder_acc_rad_s2, s.elbow_acc_rad_s2, s.shoulder_torque_Nm, s.elbow_torque_Nm,
        s.isb_shoulder_rad, s.isb_elbow_rad, s.damped, state, fault,
    )


@dataclass(slots=True)
class Vectors:
    """What the `control` kernel works on: the robot's constants, the arm's (for the
    subject's state in the record), the controller's model's (core.robot_terms), the rate
    tracker's, the controller's gains, the assistance's constants, the guidance's
    (core.control.guidance GC_*, all zero in the thesis mode); the trackers' state (angle,
    rate, acceleration of each joint, Z_*), the controller's integral (core.control.ctpid
    I_*), the guidance's state (GS_*), the last tick's values (C_*), and the reference
    rows loaded (TickPipeline.load_rows: all of them in the live loop, a block's worth in a
    headless run)."""

    robot: object
    arm: object
    model: object
    tracker: object
    gains: object
    assist: object
    guide: object
    rates: object
    integral: object
    guided: object
    last: object
    rows: object


# The trackers' state in `rates`.
Z_ANGLE1, Z_RATE1, Z_ACC1, Z_ANGLE2, Z_RATE2, Z_ACC2, Z_SIZE = range(7)
# What `control` leaves in `last`, the record's view of the tick (TickPipeline.last_tick);
# C_LEVEL is the assistance level the tick ran with (the record's `assistance_level`).
(C_PHASE, C_QD1, C_QD2, C_QDD1, C_QDD2, C_R1, C_R2, C_RD1, C_RD2, C_RDD1, C_RDD2, C_TAU1,
 C_TAU2, C_OUT1, C_OUT2, C_XD, C_YD, C_VXD, C_VYD, C_DX, C_DY, C_FX, C_FY, C_ANGLE, C_ACTIVE,
 C_LEVEL, C_SIZE) = range(27)
# Which law `controller_torques` runs.
SMC, CTPID, GENERIC, LEARNED = 0, 1, 2, 3


def _controller_kind(controller, compiled: bool) -> int:
    on_a_robot_model = len(getattr(controller.model, "constants", ())) == R_SIZE
    if type(controller) is SlidingModeController and on_a_robot_model:
        return SMC
    if type(controller) is ComputedTorquePID and on_a_robot_model:
        return CTPID
    if (compiled and type(controller) is ComputedTorquePID
            and has_compiled_form(controller.model)):
        # interpreted, the numpy tick (its own step) is the faster of the two
        return LEARNED
    return GENERIC


def has_compiled_form(model) -> bool:
    """Whether `model` (a controller's) is a learned model the kernels compute
    (core.learning.kernel: an FNN or a DeLaN of the robot)."""
    return getattr(model, "kernel_weights", None) is not None


def learned_controller(model, plan: TrialPlan) -> ComputedTorquePID:
    """The computed-torque PID (eq. 4.8) of a trial that names a learned model: `model`
    (core.learning.tick.LearnedInverseDynamics) in place of M, C and f, the trial's ctpid
    gains, the robot's drive limits."""
    return ComputedTorquePID(model, built("ctpid", plan.parameters.gains),
                             torque_limit_Nm=plan.robot.max_joint_torque_Nm)


def learned_model_refusal(parameters: TrialParameters, model) -> str:
    """Why a learned model given with a trial does not fit its parameters ("" when it
    does): the parameters name a model (`learned_model`, `learned_model_sha256`) and the
    very one, checked (app.learning.library), comes with them, or neither."""
    name, sha = parameters.learned_model, parameters.learned_model_sha256
    if model is None:
        return (f"the trial names the learned model '{name}' but none was given with it; "
                "build the trial again") if name else ""
    if not name:
        return "a learned model was given for a trial that names none; build the trial again"
    if getattr(model, "name", None) != name or getattr(model, "content_sha256", None) != sha:
        return (f"the learned model given is not '{name}' with hash {sha[:12] or '(none)'}; "
                "build the trial again")
    if not callable(getattr(model, "inverse_dynamics_terms", None)):
        return "the learned model given has no inverse dynamics; build the trial again"
    return ""


def _python(values):
    return list(values)


def _arrays(values):
    return np.asarray(values, dtype=float).copy()


def _replacements(controller, kind: int) -> dict:
    """What the interpreted `control` replaces for a controller the kernels do not know:
    its own `step` in place of `controller_torques`."""
    if kind != GENERIC:
        return {}
    step = controller.step

    def own_law(kind, model, gains, integral, dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2,
                rdd1, rdd2):
        return step(dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2)

    return {"controller_torques": own_law}


@kernel
def controller_torques(kind, model, gains, integral, dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2,
                       rdd1, rdd2):
    """The trial's controller: the sliding-mode law or the computed-torque PID
    (core.control), on its model's constants."""
    if kind == SMC:
        return smc_torques(model, gains, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2)
    if kind == LEARNED:
        # eq. 4.8 with the learned model's inverse dynamics (core.learning.kernel)
        a1, a2 = ctpid_acceleration(gains, integral, dt_s, q1, q2, qd1, qd2, r1, r2, rd1,
                                    rd2, rdd1, rdd2)
        tau1, tau2 = learned_torques(model, q1, q2, qd1, qd2, a1, a2)
        return ctpid_limit(gains, integral, tau1, tau2)
    return ctpid_torques(model, gains, integral, dt_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2,
                         rdd1, rdd2)


@kernel
def rows_needed(guide, guided, approach_ticks, tick, n_rows):
    """The lowest and highest reference row `control` reads at `tick`, from the state
    before it: the tick's own row (the last one in the hold) and, while the as-needed
    mode guides, the rows the guidance may search or lead to
    (core.control.guidance.guidance_rows)."""
    own = tick if tick < n_rows else n_rows - 1
    lo = own
    hi = own
    if guide[GC_ON] != 0.0 and approach_ticks <= tick < n_rows + guide[GC_DELAY_ROWS]:
        low, high = guidance_rows(guide, guided, approach_ticks, n_rows - 1, tick)
        lo = low if low < lo else lo
        hi = high if high > hi else hi
    return lo, hi


@kernel
def control(kind, robot, model, tracker, gains, assist, guide, rates, integral, guided, tick,
            rows, rows_from, n_rows, approach_ticks, period_s, sensor_offset_rad, q1, q2,
            force_x, force_y, last):
    """One tick up to the commanded torque, in the order of Fig. 3.6: rate estimate →
    reference → controller → performance-based assistance. Writes `last` (C_*); the
    command is last[C_OUT1], last[C_OUT2]. `rows` holds rows rows_from… of the trial's
    n_rows reference rows (approach then exercise), at least those `rows_needed` names."""
    for joint in range(2):
        # the tracker's offset a loop variable, not a literal: numba would compile `track`
        # once for each literal offset
        track(tracker, rates, (Z_ANGLE2 - Z_ANGLE1) * joint, q1 if joint == 0 else q2)
    qd1 = rates[Z_RATE1]
    qdd1 = rates[Z_ACC1]
    qd2 = rates[Z_RATE2]
    qdd2 = rates[Z_ACC2]
    n = n_rows
    if tick < n:
        row = rows[tick - rows_from]
        phase = PHASE_APPROACH if tick < approach_ticks else PHASE_EXERCISE
        xd, yd, vxd, vyd, dx, dy = row[0], row[1], row[2], row[3], row[4], row[5]
        r1, r2, rd1, rd2, rdd1, rdd2 = row[6], row[7], row[8], row[9], row[10], row[11]
    else:
        # the hold: at rest at the last reference point
        row = rows[n - 1 - rows_from]
        phase = PHASE_HOLD
        xd, yd, vxd, vyd, dx, dy = row[0], row[1], 0.0, 0.0, row[4], row[5]
        r1, r2, rd1, rd2, rdd1, rdd2 = row[6], row[7], 0.0, 0.0, 0.0, 0.0
    fx, fy = rotated_to_global(force_x, force_y, q1, sensor_offset_rad)
    # the force the assistance judges: the sensor's, or an estimate from EMG (chapter 5)
    px, py = judged_force(assist, tick, fx, fy)
    held = False
    first = False
    if guide[HC_ON] != 0.0 and phase == PHASE_EXERCISE:
        held, first = held_at(guide, tick - approach_ticks)
        if first:
            # what the hold's integral held in its last stretch is no push of this one
            for i in range(I_SIZE):
                integral[i] = 0.0
    if held:
        # from where the patient left the hand (core.control.hold.taken_over; the
        # record's desired joint angles are the ones the controller tracked)
        r1, r2, rd1, rd2, rdd1, rdd2 = taken_over(integral, first, tick - approach_ticks,
                                                  period_s, q1, q2, r1, r2, rd1, rd2, rdd1,
                                                  rdd2)
        # A task the robot leads (core.control.hold): the trial's controller holds the
        # hand on the task's reference with nothing taken off its torque; the cone test
        # says whether the push points the way asked.
        tau1, tau2 = controller_torques(kind, model, gains, integral, period_s, q1, q2, qd1,
                                        qd2, r1, r2, rd1, rd2, rdd1, rdd2)
        out1, out2 = tau1, tau2
        active, angle = cone_test(assist, px, py, dx, dy)
    elif guide[TC_ON] != 0.0 and phase != PHASE_APPROACH:
        # Transparent (core.control.transparent), the exercise and the hold after it: the
        # robot's own inertia, friction and stiffness as far as its model allows, no
        # guidance, and no pull to the path's end once the clock has run out; the cone test
        # only says whether the push pointed along the path (the directional performance),
        # and only in the exercise.
        tau1, tau2 = transparent_torques(robot, guide, q1, q2, qd1, qd2, qdd1, qdd2)
        out1, out2 = tau1, tau2
        active, angle = cone_test(assist, px, py, dx, dy)
        active = active and phase == PHASE_EXERCISE
    elif guide[GC_ON] != 0.0 and approach_ticks <= tick < n + guide[GC_DELAY_ROWS]:
        # As needed (core.control.guidance): the reference is where the patient is, or
        # the clock's row less the delay, whichever is further on.
        phase = PHASE_EXERCISE
        sigma, here, tau1, tau2, out1, out2, active, angle = guidance_command(
            robot, guide, assist, guided, rows, rows_from, n, approach_ticks, tick, q1, q2, qd1,
            qd2, px, py)
        row = rows[sigma - rows_from]
        xd, yd, vxd, vyd = row[0], row[1], row[2], row[3]
        r1, r2, rd1, rd2, rdd1, rdd2 = row[6], row[7], row[8], row[9], row[10], row[11]
        # the desired direction where the hand is, the one its cone test used
        dx, dy = rows[here - rows_from][4], rows[here - rows_from][5]
    else:
        tau1, tau2 = controller_torques(kind, model, gains, integral, period_s, q1, q2, qd1,
                                        qd2, r1, r2, rd1, rd2, rdd1, rdd2)
        out1, out2, active, angle = assisted_torques(robot, assist, q1, q2, tau1, tau2, px,
                                                     py, dx, dy)
        if phase != PHASE_EXERCISE:
            # The subject's effort counts only on the exercise, not on the way to it.
            out1, out2, active = tau1, tau2, False
    last[C_PHASE] = phase
    last[C_QD1] = qd1
    last[C_QD2] = qd2
    last[C_QDD1] = qdd1
    last[C_QDD2] = qdd2
    last[C_R1] = r1
    last[C_R2] = r2
    last[C_RD1] = rd1
    last[C_RD2] = rd2
    last[C_RDD1] = rdd1
    last[C_RDD2] = rdd2
    last[C_TAU1] = tau1
    last[C_TAU2] = tau2
    last[C_OUT1] = out1
    last[C_OUT2] = out2
    last[C_XD] = xd
    last[C_YD] = yd
    last[C_VXD] = vxd
    last[C_VYD] = vyd
    last[C_DX] = dx
    last[C_DY] = dy
    last[C_FX] = fx
    last[C_FY] = fy
    last[C_ANGLE] = angle
    last[C_ACTIVE] = 1.0 if active else 0.0
    last[C_LEVEL] = assist[A_LEVEL]


def idle_record(
    robot: RobotModel, arm, k: int, reading: SensorReading, wall_s: float, lateness_s: float,
    compute_s: float, state: int, fault: int, period_s: float = PERIOD_S,
    sensor_offset_rad: float = 0.0, assistance_level: float = math.nan,
) -> tuple:
    """A record while connected without control (zero torque): sensors and the subject's
    posture for the live view; rates, references and torques are NaN or zero. The
    assistance level is the trial's in effect when a running tick failed to read its
    sensors, NaN while no trial runs."""
    q1, q2 = reading.q1_rad, reading.q2_rad
    fx, fy = sensor_to_global(reading.force_x_N, reading.force_y_N, q1, sensor_offset_rad)
    x, y = robot.position(q1, q2)
    ts, te = arm.ik_terms(x, y)
    isb_s, isb_e = arm.isb_terms(ts, te)
    nan = math.nan
    return (
        k, k * period_s, wall_s, PHASE_IDLE, lateness_s, compute_s,
        q1, q2, nan, nan, nan, nan,
        nan, nan, nan, nan, nan, nan,
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        x, y, nan, nan, nan, nan, nan, nan,
        reading.force_x_N, reading.force_y_N, reading.force_z_N, fx, fy,
        nan, False, assistance_level,
        ts, te, nan, nan, nan, nan, nan, nan, isb_s, isb_e, False, state, fault,
    )
