"""The per-tick computation of a trial, shared by the real-time loop and headless runs.

One tick, in the order of the thesis's scheme (Fig. 3.6):

    sensors → rate estimate → reference → controller → performance-based assistance
            → [safety supervisor, motors: the caller] → subject model → record

`control()` runs everything up to the commanded torque, so the caller can pass it
through the supervisor and write it to the motors with the least delay; `record()`
then does the rest (the subject's joint angles, rates and torques, eq. 3.27–3.38)
and returns the tick's record as plain numbers in `device.recording.record.flat_names()` order,
ready for `RecordRing.push` or `RecordLog.append`.

Everything per tick is plain floats on precomputed tables; numpy is used only when a
trial is built (`TrialPlan`) and when it starts (`begin`, which plans the approach
from wherever the handle is to the path's start point).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from core.control.assistance import PerformanceAssistance
from core.control.base import make_controller
from core.interaction import SubjectState, sensor_to_global, subject_state
from core.robot import RobotModel
from core.signal import RateEstimator
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
"""Closer than this to the start point, the exercise begins at once."""
HOLD_S = 0.5
"""Time the reference rests at the start point after the last repetition."""

PHASE_IDLE, PHASE_APPROACH, PHASE_EXERCISE, PHASE_HOLD = 0, 1, 2, 3


@dataclass(frozen=True, slots=True)
class TrialPlan:
    """A validated trial with its reference precomputed at the loop rate.

    Built once (the Build button): refuses unreachable or absurd parameters with
    the reason before anything moves.
    """

    parameters: TrialParameters
    robot: RobotModel
    period_s: float
    exercise_rows: tuple  # per tick: (xd, yd, vxd, vyd, dx, dy, r1, r2, rd1, rd2, rdd1, rdd2)
    exercise_table: np.ndarray = field(compare=False, repr=False)
    """The same rows as one (N, 12) array, for the compiled engine."""

    @classmethod
    def build(
        cls, parameters: TrialParameters, robot: RobotModel | None = None,
        period_s: float = PERIOD_S,
    ) -> TrialPlan:
        robot = robot or RobotModel()
        check_trial(parameters, robot).require_ok()
        trajectory = parameters.trajectory()
        n = round(trajectory.total_duration_s / period_s)
        t = np.arange(n) * period_s
        sample = trajectory.sample(t)
        q, qd, qdd = trajectory.joint_reference(robot, t)
        table = np.column_stack(
            (sample.position_m, sample.velocity_m_s, sample.direction, q, qd, qdd)
        )
        return cls(parameters, robot, period_s, tuple(map(tuple, table.tolist())), table)

    @property
    def exercise_ticks(self) -> int:
        return len(self.exercise_rows)

    @property
    def start_point_m(self) -> tuple[float, float]:
        return (self.exercise_rows[0][0], self.exercise_rows[0][1])

    def approach_rows(self, q1: float, q2: float) -> tuple:
        """Reference rows from the handle's pose to the path's start: a minimum-jerk
        straight line at about APPROACH_SPEED_M_S, at least APPROACH_MIN_S long."""
        return tuple(map(tuple, self.approach_table(q1, q2).tolist()))

    def approach_table(self, q1: float, q2: float) -> np.ndarray:
        """`approach_rows` as one (N, 12) array (N = 0 when the handle is at the start)."""
        robot = self.robot
        x0, y0 = robot.position(q1, q2)
        x1, y1 = self.start_point_m
        distance = math.hypot(x1 - x0, y1 - y0)
        if distance < APPROACH_SKIP_M:
            return np.empty((0, 12))
        duration = max(APPROACH_MIN_S, distance / APPROACH_SPEED_M_S)
        n = math.ceil(duration / self.period_s)
        u = np.arange(n) * self.period_s / duration
        s = u**3 * (10 - 15 * u + 6 * u**2)
        sd = 30 * u**2 * (1 - u) ** 2 / duration
        sdd = 60 * u * (1 - 3 * u + 2 * u**2) / duration**2
        ux, uy = (x1 - x0) / distance, (y1 - y0) / distance
        pos = np.column_stack((x0 + ux * distance * s, y0 + uy * distance * s))
        vel = np.column_stack((ux * distance * sd, uy * distance * sd))
        acc = np.column_stack((ux * distance * sdd, uy * distance * sdd))
        q = robot.ik(pos)
        jac = robot.jacobian(q)
        qd = np.linalg.solve(jac, vel[..., None])[..., 0]
        rhs = acc - np.einsum("nij,nj->ni", robot.jacobian_dot(q, qd), qd)
        qdd = np.linalg.solve(jac, rhs[..., None])[..., 0]
        direction = np.tile([ux, uy], (n, 1))
        return np.column_stack((pos, vel, direction, q, qd, qdd))


class TickPipeline:
    """The state one trial's ticks share: estimators, controller, assistance, reference."""

    def __init__(
        self,
        plan: TrialPlan,
        *,
        sensor_offset_rad: float = 0.0,
        rate_cutoff_hz: float = RATE_CUTOFF_HZ,
        controller=None,
        min_force_N: float | None = None,
    ) -> None:
        self.plan = plan
        params = plan.parameters
        self.robot = plan.robot
        self.arm = params.arm()
        self.period_s = plan.period_s
        self.sensor_offset_rad = sensor_offset_rad
        self.controller = controller or make_controller(params.controller, self.robot)
        options = {} if min_force_N is None else {"min_force_N": min_force_N}
        self.assistance = PerformanceAssistance(
            self.robot, tolerance_rad=params.tolerance_rad, level=params.assistance_level,
            **options,
        )
        self._est1 = RateEstimator(plan.period_s, rate_cutoff_hz)
        self._est2 = RateEstimator(plan.period_s, rate_cutoff_hz)
        self._rows: tuple = plan.exercise_rows
        self._approach_ticks = 0
        self._table = plan.exercise_table
        self._last = None

    # ------------------------------------------------------------------ trial
    def begin(self, q1: float, q2: float) -> None:
        """Start a trial from the handle's current pose: plan the approach, reset state."""
        approach = self.plan.approach_table(q1, q2)
        self._approach_ticks = len(approach)
        self._rows = tuple(map(tuple, approach.tolist())) + self.plan.exercise_rows
        self._table = np.vstack((approach, self.plan.exercise_table))
        self.controller.reset()
        self._est1.reset(q1)
        self._est2.reset(q2)

    @property
    def total_ticks(self) -> int:
        """Approach + exercise + hold: when the trial is complete."""
        return len(self._rows) + round(HOLD_S / self.period_s)

    @property
    def reference_rows(self) -> np.ndarray:
        """The reference of the trial `begin` planned, one row per tick of approach and
        exercise: (x_d, y_d, ẋ_d, ẏ_d, direction x, y, θ_d1, θ_d2, θ̇_d1, θ̇_d2, θ̈_d1, θ̈_d2)."""
        return self._table

    @property
    def rate_estimators(self) -> tuple[RateEstimator, RateEstimator]:
        """The joint-rate trackers of joints 1 and 2."""
        return (self._est1, self._est2)

    @property
    def approach_ticks(self) -> int:
        return self._approach_ticks

    @property
    def rates(self) -> tuple[float, float]:
        """The joint-rate estimate of the last `control` call (rad/s)."""
        return (self._last[1], self._last[2])

    @property
    def last_tick(self) -> tuple | None:
        """What the last `control` computed, as `record` reads it (None before the first)."""
        return self._last

    def set_last_tick(self, values: tuple) -> None:
        """Set what `record` and `rates` read, as a compiled `control` computed it (the
        25 values of `last_tick`, plain floats)."""
        self._last = values

    def set_assistance_level(self, level: float) -> None:
        self.assistance.set_level(level)

    # ------------------------------------------------------------------ per tick
    def control(self, k: int, reading: SensorReading) -> tuple[float, float]:
        """Commanded joint torques for tick k of the trial (before the supervisor)."""
        q1, q2 = reading.q1_rad, reading.q2_rad
        qd1, qdd1 = self._est1.update(q1)
        qd2, qdd2 = self._est2.update(q2)
        rows = self._rows
        if k < len(rows):
            row = rows[k]
            phase = PHASE_APPROACH if k < self._approach_ticks else PHASE_EXERCISE
        else:
            row = rows[-1]
            row = (row[0], row[1], 0.0, 0.0, row[4], row[5], row[6], row[7], 0.0, 0.0, 0.0, 0.0)
            phase = PHASE_HOLD
        xd, yd, vxd, vyd, dx, dy, r1, r2, rd1, rd2, rdd1, rdd2 = row
        tau1, tau2 = self.controller.step(
            self.period_s, q1, q2, qd1, qd2, r1, r2, rd1, rd2, rdd1, rdd2
        )
        fx, fy = sensor_to_global(
            reading.force_x_N, reading.force_y_N, q1, self.sensor_offset_rad
        )
        out1, out2, active, angle = self.assistance.apply(q1, q2, tau1, tau2, fx, fy, dx, dy)
        if phase != PHASE_EXERCISE:
            # The subject's effort counts only on the exercise, not on the way to it.
            out1, out2, active = tau1, tau2, False
        self._last = (
            phase, qd1, qd2, qdd1, qdd2, r1, r2, rd1, rd2, rdd1, rdd2, tau1, tau2, out1, out2,
            xd, yd, vxd, vyd, dx, dy, fx, fy, angle, active,
        )
        return out1, out2

    def record(
        self, k: int, reading: SensorReading, wall_s: float, lateness_s: float,
        compute_s: float, applied: tuple[float, float], state: int, fault: int,
        with_subject: bool = True,
    ) -> tuple:
        """The tick's record (flat_names order), with the subject model run on it.

        A headless run passes with_subject=False and fills the subject's channels for
        the whole trial at once afterwards (`fill_subject_channels`): same formulas,
        vectorised."""
        (phase, qd1, qd2, qdd1, qdd2, r1, r2, rd1, rd2, rdd1, rdd2, tau1, tau2, out1, out2,
         xd, yd, vxd, vyd, dx, dy, fx, fy, angle, active) = self._last
        q1, q2 = reading.q1_rad, reading.q2_rad
        s = subject_state(
            self.robot, self.arm, q1, q2, qd1, qd2, qdd1, qdd2,
            reading.force_x_N, reading.force_y_N, self.sensor_offset_rad,
        ) if with_subject else _NO_SUBJECT
        x, y = self.robot.position(q1, q2)
        return (
            k, k * self.period_s, wall_s, phase, lateness_s, compute_s,
            q1, q2, qd1, qd2, qdd1, qdd2,
            r1, r2, rd1, rd2, rdd1, rdd2,
            tau1, tau2, out1, out2, applied[0], applied[1],
            x, y, xd, yd, vxd, vyd, dx, dy,
            reading.force_x_N, reading.force_y_N, reading.force_z_N, fx, fy,
            angle, active,
            s.shoulder_rad, s.elbow_rad, s.shoulder_rate_rad_s, s.elbow_rate_rad_s,
            s.shoulder_acc_rad_s2, s.elbow_acc_rad_s2,
            s.shoulder_torque_Nm, s.elbow_torque_Nm, s.isb_shoulder_rad, s.isb_elbow_rad,
            s.damped, state, fault,
        )


_NO_SUBJECT = SubjectState(*(math.nan,) * 12, False)


def fill_subject_channels(records: np.ndarray, plan: TrialPlan,
                          sensor_offset_rad: float = 0.0) -> None:
    """Run the subject model (eq. 3.27–3.38) over whole recorded arrays, in place, on the
    samples under control (phase ≠ idle)."""
    sel = records["phase"] != PHASE_IDLE
    q, qd, qdd = (records[n][sel] for n in ("robot_angle", "robot_rate", "robot_acceleration"))
    f = records["force_sensor"][sel]
    s = subject_state(plan.robot, plan.parameters.arm(), q[:, 0], q[:, 1], qd[:, 0], qd[:, 1],
                      qdd[:, 0], qdd[:, 1], f[:, 0], f[:, 1], sensor_offset_rad)
    for name, pair in (
        ("subject_angle", (s.shoulder_rad, s.elbow_rad)),
        ("subject_rate", (s.shoulder_rate_rad_s, s.elbow_rate_rad_s)),
        ("subject_acceleration", (s.shoulder_acc_rad_s2, s.elbow_acc_rad_s2)),
        ("subject_torque", (s.shoulder_torque_Nm, s.elbow_torque_Nm)),
        ("subject_angle_isb", (s.isb_shoulder_rad, s.isb_elbow_rad)),
    ):
        records[name][sel] = np.column_stack(pair)
    records["singular"][sel] = s.damped


def idle_record(
    robot: RobotModel, arm, k: int, reading: SensorReading, wall_s: float, lateness_s: float,
    compute_s: float, state: int, fault: int, period_s: float = PERIOD_S,
    sensor_offset_rad: float = 0.0,
) -> tuple:
    """A record while connected without control (zero torque): sensors and the subject's
    posture for the live view; rates, references and torques are NaN or zero."""
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
        nan, False,
        ts, te, nan, nan, nan, nan, nan, nan, isb_s, isb_e, False, state, fault,
    )
