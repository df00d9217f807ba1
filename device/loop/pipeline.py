"""The per-tick computation of a trial, shared by the real-time loop and headless runs.

One tick, in the order of the thesis's scheme (Fig. 3.6):

    sensors → rate estimate → reference → controller → performance-based assistance
            → [safety supervisor, motors: the caller] → subject model → record

`control()` runs everything up to the commanded torque, so the caller can pass it
through the supervisor and write it to the motors with the least delay; `record()`
then does the rest (the subject's joint angles, rates and torques, eq. 3.27–3.38)
and returns the tick's record as plain numbers in `device.recording.record.flat_names()` order,
ready for `RecordRing.push` or `RecordLog.append`.

`control` is a kernel (core.kernels; device.loop.control_kernel) on precomputed tables and
flat vectors: Python tuples and lists interpreted, float arrays compiled; `record` works on
plain floats. numpy computes only when a trial is built (`TrialPlan`, device.loop.plan),
when it starts (`begin`, which
plans the approach from wherever the handle is to the path's start point and, in the live
loop, computes every reference row) and, in a headless run, between blocks of ticks
(`load_rows`: the next rows of the reference, so that a long trial's is never held whole).
"""

from __future__ import annotations

import math

import numpy as np

from core.control.assistance import (
    A_EST_FX,
    A_EST_FY,
    A_EST_TICK,
    A_LEVEL,
    PerformanceAssistance,
)
from core.control.base import make_controller
from core.control.ctpid import (
    ComputedTorquePID,
)
from core.control.gains import built
from core.control.guidance import (
    GC_DELAY_ROWS,
    GS_KEPT,
    GS_U,
    OFF,
    GuidanceGains,
    state_size,
)
from core.control.hold import HS_SIZE, OFF as NOT_HELD, hold_constants
from core.control.transparent import OFF as NOT_TRANSPARENT
from core.errors import ParameterError
from core.holdtasks import TaskTrajectory
from core.interaction import (
    SubjectState,
    sensor_to_global,
    subject_motion,
)
from core.kernels import interpreted
from core.robot import RobotModel
from core.signal import RateEstimator
from core.trial import TrialParameters
from device.backend import SensorReading
from device.loop.control_kernel import (
    C_ACTIVE,
    C_ANGLE,
    C_DX,
    C_DY,
    C_FX,
    C_FY,
    C_LEVEL,
    C_OUT1,
    C_OUT2,
    C_PHASE,
    C_QD1,
    C_QD2,
    C_QDD1,
    C_QDD2,
    C_R1,
    C_R2,
    C_RD1,
    C_RD2,
    C_RDD1,
    C_RDD2,
    C_SIZE,
    C_TAU1,
    C_TAU2,
    C_VXD,
    C_VYD,
    C_XD,
    C_YD,
    GENERIC,
    LEARNED,
    Z_SIZE,
    Vectors,
    _arrays,
    _controller_kind,
    _python,
    _replacements,
    control,
    has_compiled_form,
    rows_needed,
)
from device.loop.plan import (
    HOLD_S,
    PERIOD_S,
    PHASE_APPROACH,
    PHASE_EXERCISE,
    PHASE_HOLD,
    PHASE_IDLE,
    RATE_CUTOFF_HZ,
    TrialPlan,
)

__all__ = [
    "PERIOD_S", "PHASE_APPROACH", "PHASE_EXERCISE", "PHASE_HOLD", "PHASE_IDLE", "TickPipeline",
    "TrialPlan", "assistance_group", "has_compiled_form", "idle_record", "learned_controller",
    "learned_model_refusal", "record_values",
]
"""What the rest of the console takes from here; the plan's constants and the phases live in
device.loop.plan, the tick's kernel in device.loop.control_kernel."""


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
