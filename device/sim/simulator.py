"""The simulated robot: the thesis robot with a virtual patient holding its handle.

What is simulated
-----------------
The robot (eq. 3.6) and the subject's arm (eq. 3.20) are joined rigidly at the
handle: the hand and the end effector share position, velocity and acceleration
(eq. 3.28–3.31). The state is the robot's joints (θ_R, θ̇_R); the arm's angles
and rates follow from the closure at every evaluation (anatomical branch), so
the two never drift apart. The reduced equations are those of
`core.interaction.coupled_forward_dynamics`:

    (M_R + Gᵀ M_A G) θ̈_R = τ_R − h_R + Gᵀ (τ_A − C_A θ̇_A − M_A g),   G = J_A⁻¹ J_R

and the force of the hand on the handle comes out of the arm's equation
(eq. 3.27), F = J_A⁻ᵀ (τ_A − M_A θ̈_A − C_A θ̇_A): it is computed, not assumed.
τ_R is the last written torque, held (zero-order hold) and saturated at the
drives' limit as the amplifier would; τ_A is the patient's (device.sim.patients),
asked for at every evaluation.

For speed `dynamics="fused"` (the default for a device.sim.patients.VirtualPatient)
evaluates those equations in one compiled function with the patient's torque folded
in (no repeated inverse kinematics, the arm's trigonometry done algebraically;
device.compiled.dynamics.evaluate); it is the same algebra, held equal to
`coupled_forward_dynamics` by the tests. `dynamics="reference"` calls
`core.interaction.coupled_forward_dynamics` itself, for validation runs and for
any other object of the Patient protocol, whose torque is plain Python.

Integrator
----------
Semi-implicit (symplectic) Euler with a fixed 1 ms step, 2 steps per 2 ms tick:
θ̇ += h θ̈(θ, θ̇); θ += h θ̇. It needs one evaluation of the dynamics per step,
and the first of each tick is free (below), so a tick costs two evaluations.
Measured against RK4 at 0.1 ms on the thesis's D with a healthy patient and a
passive robot (4 s): joint angles within 1.8·10⁻⁴ rad (two encoder counts, 0.07 mm
at the hand) and hand force within 0.01 N (a quarter of the sensor's 1/24 N
step and of its noise). Being symplectic, it keeps a free frictionless run's
energy within a bounded oscillation (1.7·10⁻³ of it with the arm's passive
stiffness, 3·10⁻⁵ without) that does not grow over 20 s. Those errors vanish
under the sensors' resolution, so the cheap integrator is the default.
`integrator="rk4"` (classical Runge–Kutta, same 1 ms step, 8 evaluations per
tick, about 3× the cost) brings the same figures to 10⁻⁹ rad, 10⁻⁷ N and 10⁻¹²:
use it to validate physics. `bench_tick` measures both.

The first evaluation of each tick reuses the one made for the previous
reading: the accelerations at the sampled state are affine in the motor torque,
so the new torque enters through the inverse of the coupled mass matrix.

Time
----
`read(now_s)` advances in whole steps while a step fits before `now_s` and
returns the reading at the simulator's own time, which trails `now_s` by less
than one step and never accumulates lag. The clock is anchored at the first
read after `open()`: that reading is the initial state at simulated time 0,
whatever clock the caller uses (wall-clock seconds in the real-time loop,
k·0.002 in headless runs). The patient's own clock starts there too, unless the
simulator was built with `patient_waits=True`: then the patient holds the path's
start until `cue_patient()` (call it with the trial's first exercise tick).

`timing` (device.backend) tells the live loop which clock to pass: SIMULATED (the
default) gets the nominal time, tick × period, so every tick steps the robot and
the patient by one period however late it started; REAL_TIME gets the wall clock
and the hardware's late-tick watchdog, to rehearse on a PC how the real robot's
loop would be timed there (a stall then catches up in one read, as a real arm
would have moved on).

Sensors
-------
Encoders: `robot.motors[i].quantise_joint_angle` (its arithmetic, inlined).
Force sensor: the true hand force rotated into the sensor frame (eq. 3.35–3.36
inverted, with the mounting offset), Gaussian noise added, then quantised to
1/24 N horizontal and 1/48 N normal (Table 3.1; device.sim.sensors). Noise comes
from a numpy Generator seeded by `seed`, drawn in blocks, so runs are
repeatable for a seed.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError, SingularityError, check_finite, check_range
from core.interaction import coupled_forward_dynamics
from core.robot import RobotModel
from core.trial import THESIS_SUBJECT, TrialParameters
from device.backend import SIMULATED, TIMINGS, SensorReading
from device.errors import BackendError, SensorRangeError, StateError
from device.sim.patients import Patient, VirtualPatient, make_patient
from device.sim.sensors import ForceSensorModel

INTEGRATORS = ("rk4", "semi_implicit_euler")
DYNAMICS = ("fused", "reference")
DEFAULT_STEP_S = 0.001
MAX_STEP_S = 0.001
NOISE_BLOCK = 4096
"""Sensor-noise triples drawn from the generator at a time."""
_TWO_PI = 2.0 * math.pi
# A waiting patient's clock: this far before the exercise's start, the desired
# motion is the start posture at rest (finite, so the tremor's sine stays defined).
_WAITING_S = 1e9
# |det J_A| (m²) below which the arm counts as straight: core.interaction's bound.
_ARM_DET_MIN = 1e-9


@dataclass(frozen=True, slots=True)
class SimulatorTruth:
    """What really happened at the last reading: no quantisation, no noise.

    Forces are the hand's force on the handle in the global frame; torques are
    the motor torques actually applied (after saturation) and the patient's net
    joint torques τ_A (eq. 3.20). Arm angles are core.arm's absolute θ_s, θ_e
    (the elbow's flexion is θ_e − θ_s), with their rates and accelerations.
    """

    time_s: float
    q1_rad: float
    q2_rad: float
    q1_rate_rad_s: float
    q2_rate_rad_s: float
    q1_acc_rad_s2: float
    q2_acc_rad_s2: float
    force_x_N: float
    force_y_N: float
    shoulder_rad: float
    elbow_rad: float
    shoulder_rate_rad_s: float
    elbow_rate_rad_s: float
    shoulder_acc_rad_s2: float
    elbow_acc_rad_s2: float
    shoulder_torque_Nm: float
    elbow_torque_Nm: float
    torque1_Nm: float
    torque2_Nm: float


class SimulatorBackend:
    """A Backend (device.backend) that simulates the robot with a virtual patient.

    Build it from a trial with `from_trial`, or from a patient (any object of the
    `device.sim.patients.Patient` protocol: its arm, its trajectory, its torques).
    `robot` defaults to the thesis robot (with its default friction), `sensor` to
    the Nano25 of Table 3.1, `seed` draws the sensor noise; `step_s` (≤ 1 ms),
    `integrator`, `dynamics`, `patient_waits` and `timing` are described in the module
    notes.
    """

    name = "simulator"

    def __init__(
        self,
        patient: Patient,
        *,
        robot: RobotModel | None = None,
        seed: int = 0,
        sensor: ForceSensorModel | None = None,
        step_s: float = DEFAULT_STEP_S,
        integrator: str = "semi_implicit_euler",
        dynamics: str | None = None,
        patient_waits: bool = False,
        timing: str = SIMULATED,
    ) -> None:
        if not isinstance(patient, Patient):
            raise ParameterError(
                "patient", type(patient).__name__,
                "an object with arm, trajectory and torque(t_s, ts, te, tsd, ted)",
                "build one with device.sim.patients.make_patient",
            )
        if timing not in TIMINGS:
            raise ParameterError("timing", timing, "one of " + ", ".join(TIMINGS),
                                 "simulated steps by the nominal period; real runs on the "
                                 "wall clock with the hardware's late-tick watchdog")
        self.timing = timing
        if integrator not in INTEGRATORS:
            raise ParameterError("integrator", integrator, "one of " + ", ".join(INTEGRATORS))
        compilable = isinstance(patient, VirtualPatient)
        if dynamics is None:
            dynamics = "fused" if compilable else "reference"
        if dynamics not in DYNAMICS:
            raise ParameterError("dynamics", dynamics, "one of " + ", ".join(DYNAMICS))
        if dynamics == "fused" and not compilable:
            raise ParameterError(
                "dynamics", dynamics, "reference for this patient",
                f"the fused dynamics are compiled with a VirtualPatient's torque; a "
                f"{type(patient).__name__} runs the reference dynamics",
            )
        _check_seed(seed)
        self.step_s = check_range(
            "step_s", step_s, 0.0, MAX_STEP_S, "s",
            "the simulator's internal step must resolve the 2 ms loop", low_open=True,
        )
        self.patient = patient
        self.robot = robot if robot is not None else RobotModel()
        self.arm = patient.arm
        self.trajectory = patient.trajectory
        self.sensor = sensor if sensor is not None else ForceSensorModel()
        self.seed = int(seed)
        self.integrator = integrator
        self.dynamics = dynamics
        if not isinstance(patient_waits, bool):
            raise ParameterError("patient_waits", patient_waits, "True or False")
        self.patient_waits = patient_waits
        if dynamics == "fused":
            self._evaluate = _fused_dynamics(self)
        else:
            self._evaluate = _reference_dynamics(self.robot, self.arm, patient)
        self._max_torque = self.robot.max_joint_torque_Nm
        sn = self.sensor
        self._sensor_constants = (
            sn.offset_rad, sn.noise_xy_N, sn.noise_z_N, sn.normal_load_N, sn.resolution_xy_N,
            sn.resolution_z_N, sn.limit_xy_N, sn.limit_z_N,
        )
        # MotorParameters.quantise_joint_angle's arithmetic, inlined in `_sample` (the two
        # method calls cost 0.6 µs a tick); the tests hold the two equal bit for bit
        self._counts_per_rev = (
            self.robot.motors[0].counts_per_joint_rev, self.robot.motors[1].counts_per_joint_rev
        )
        x0, y0, *_ = self.trajectory.at(0.0)
        q1, q2 = self.robot.ik_terms(x0, y0)
        if math.isnan(q1):
            raise ParameterError(
                "trajectory", f"start ({x0:.3f}, {y0:.3f}) m", "a point the robot reaches",
                "the simulation starts at rest at the path's start",
            )
        self._q0 = (q1, q2)
        self._is_open = False
        self._reset()

    @classmethod
    def from_trial(
        cls,
        trial: TrialParameters = THESIS_SUBJECT,
        kind: str = "healthy",
        *,
        seed: int = 0,
        patient_options: Mapping[str, object] | None = None,
        **options,
    ) -> SimulatorBackend:
        """A simulator for `trial` with a patient of `kind` (device.sim.patients.PATIENT_KINDS).

        `seed` sets both the patient's draws and the sensor noise (through
        independent child seeds); `patient_options` go to make_patient and
        `options` to the constructor.
        """
        _check_seed(seed)
        built = make_patient(
            kind, trial.arm(), trial.trajectory(), seed=_child_seed(seed, 0),
            **dict(patient_options or {}),
        )
        return cls(built, seed=seed, **options)

    # --------------------------------------------------------------- protocol
    def open(self) -> None:
        """Reset to rest at the path's start with zero torque; the next read is time 0."""
        self._reset()
        self._is_open = True

    def read(self, now_s: float) -> SensorReading:
        """Advance to `now_s` (whole steps, torques held) and sample the sensors."""
        if not self._is_open:
            raise StateError("the simulator is not open; call open() before read()")
        if self._anchor is None:
            if now_s - now_s != 0.0:
                raise BackendError(
                    f"read() got now_s = {now_s}; pass the loop's clock in seconds, finite"
                )
            self._anchor = now_s
        # whole steps that fit before now_s (a hair of tolerance for k·0.002 round-off)
        ahead = (now_s - self._anchor) * self._rate - self._steps + 1e-7
        if ahead >= 1.0 and ahead != math.inf:
            self._advance(int(ahead))
        elif not ahead < 1.0:
            raise BackendError(
                f"read() got now_s = {now_s}; pass the loop's clock in seconds, finite"
            )
        return self._reading

    def write(self, torque1_Nm: float, torque2_Nm: float) -> None:
        """Command joint torques; the drives saturate at the motors' limit."""
        # plain floats: a numpy scalar would slow every later step threefold
        torque1_Nm = float(torque1_Nm)
        torque2_Nm = float(torque2_Nm)
        if torque1_Nm - torque1_Nm != 0.0 or torque2_Nm - torque2_Nm != 0.0:
            raise BackendError(
                f"torque command ({torque1_Nm}, {torque2_Nm}) N·m is not finite; the "
                "controller's output is broken. The motors were left at their last command."
            )
        m1, m2 = self._max_torque
        self._tau1 = m1 if torque1_Nm > m1 else -m1 if torque1_Nm < -m1 else torque1_Nm
        self._tau2 = m2 if torque2_Nm > m2 else -m2 if torque2_Nm < -m2 else torque2_Nm

    def safe_state(self) -> None:
        """Zero the motor torques."""
        self._tau1 = 0.0
        self._tau2 = 0.0

    def close(self) -> None:
        """Zero the torques and stop; safe to call twice."""
        self._tau1 = 0.0
        self._tau2 = 0.0
        self._is_open = False

    # ----------------------------------------------------------------- patient
    def cue_patient(self, at_s: float | None = None) -> None:
        """Tell the patient to start the exercise at simulated time `at_s` (default:
        the last reading's time, i.e. the tick this is called after).

        A simulator built with `patient_waits=True` holds the patient at the path's
        start until cued, so the exercise starts when the trial does (after Connect
        and a live view, say), not when the simulator opened. Without it the patient
        starts at the first read, as a headless run wants.
        """
        start = self.time_s if at_s is None else check_finite("at_s", at_s, "s")
        self._patient_t0 = start
        self._cached_k1 = False  # the patient's torque at this instant changed

    @property
    def patient_time_s(self) -> float:
        """Time on the patient's clock (since their cue; negative while waiting)."""
        return self.time_s - self._patient_t0

    # ------------------------------------------------------------ validation
    def noise_generator(self) -> np.random.Generator:
        """A new generator of the force sensor's noise, as `open` starts it: the
        sensor's child seed of `seed`, independent of the patient's."""
        return np.random.default_rng(_child_seed(self.seed, 1))

    @property
    def start_angles_rad(self) -> tuple[float, float]:
        """The robot's joint angles at rest at the path's start, where `open` puts it."""
        return self._q0

    @property
    def time_s(self) -> float:
        """Simulated time of the last reading."""
        return self._steps * self.step_s

    @property
    def truth(self) -> SimulatorTruth:
        """The true state, force and torques at the last reading."""
        q1, q2, qd1, qd2 = self._state
        r = self._last
        return SimulatorTruth(
            self._steps * self.step_s, q1, q2, qd1, qd2, r[0], r[1], r[2], r[3], r[4], r[5],
            r[6], r[7], r[8], r[9], r[10], r[11], self._last_tau[0], self._last_tau[1],
        )

    def hand_position_m(self) -> tuple[float, float]:
        """The handle's true position (eq. 3.2)."""
        return self.robot.position(self._state[0], self._state[1])

    # --------------------------------------------------------------- private
    def _reset(self) -> None:
        self._rate = 1.0 / self.step_s
        self._steps = 0
        self._anchor: float | None = None
        self._tau1 = self._tau2 = 0.0
        self._patient_t0 = _WAITING_S if self.patient_waits else 0.0
        self._cached_k1 = True
        self._state = (self._q0[0], self._q0[1], 0.0, 0.0)
        # the sensor noise has its own child seed, independent of the patient's (child 0)
        self._noise_rng = self.noise_generator()
        self._draw_noise_block()
        self._last = self._evaluate_safely(-self._patient_t0, *self._state, 0.0, 0.0, True)
        self._last_tau = (0.0, 0.0)
        self._reading = self._sample(0, self._state[0], self._state[1], self._last)

    def _draw_noise_block(self) -> None:
        # drawn a block at a time (numpy stays off the per-tick path); the rows come in
        # the generator's order whatever the block size, so runs repeat for a seed
        self._noise_block = self._noise_rng.standard_normal((NOISE_BLOCK, 3))
        self._noise_rows = self._noise_block.tolist()
        self._noise_pos = 0

    def top_up_noise(self, rows: int) -> None:
        """Make sure at least `rows` noise triples are left in the current block, drawing
        the next block now if not. The stream keeps its order (the rows left come first),
        so the readings are the same as without: the live loop calls this between ticks
        so that no tick pays for a draw (device.compiled.looptick)."""
        left = len(self._noise_rows) - self._noise_pos
        if left >= rows:
            return
        fresh = self._noise_rng.standard_normal((max(NOISE_BLOCK, rows), 3))
        self._noise_block = np.vstack((self._noise_block[self._noise_pos:], fresh))
        self._noise_rows = self._noise_block.tolist()
        self._noise_pos = 0

    def _noise(self) -> list[float]:
        if self._noise_pos == len(self._noise_rows):
            self._draw_noise_block()
        row = self._noise_rows[self._noise_pos]
        self._noise_pos += 1
        return row

    def _evaluate_safely(self, t, q1, q2, qd1, qd2, tau1, tau2, full):
        try:
            return self._evaluate(t, q1, q2, qd1, qd2, tau1, tau2, full)
        except (SingularityError, ZeroDivisionError, ValueError, OverflowError) as error:
            raise self._failure(t, q1, q2, qd1, qd2) from error

    def _failure(self, t, q1, q2, qd1, qd2) -> BackendError:
        if not all(math.isfinite(v) for v in (q1, q2, qd1, qd2)):
            return BackendError(
                f"the simulation's state became non-finite at t = {t:.3f} s (joint rates "
                f"{qd1:.3g}, {qd2:.3g} rad/s); a torque or the patient model blew up. Stop the "
                "trial and check the controller's gains and the patient's options."
            )
        x, y = self.robot.position(q1, q2)
        return BackendError(
            f"the simulated subject's arm is straight (or folded flat) at t = {t:.3f} s with the "
            f"handle at ({x:.3f}, {y:.3f}) m, "
            f"{math.hypot(x - self.arm.shoulder_x_m, y - self.arm.shoulder_y_m):.3f} m from the "
            f"shoulder (the arm reaches {self.arm.reach_max_m:.3f} m); the coupled model has no "
            "solution there. Keep the handle within the arm's reach (check the path and the "
            "controller)."
        )

    def _advance(self, n: int) -> None:
        tau1, tau2 = self._tau1, self._tau2
        h = self.step_s
        t0 = self._patient_t0
        q1, q2, qd1, qd2 = self._state
        evaluate = self._evaluate
        last = self._last
        rk4 = self.integrator == "rk4"
        steps = self._steps
        t = steps * h - t0  # the patient's time: from their cue to start
        try:
            for i in range(n):
                if i == 0 and self._cached_k1:
                    # The last reading's accelerations, with the torque change through
                    # the inverse coupled mass: they are affine in τ_R.
                    dt1 = tau1 - self._last_tau[0]
                    dt2 = tau2 - self._last_tau[1]
                    a1 = last[0] + last[12] * dt1 + last[13] * dt2
                    a2 = last[1] + last[13] * dt1 + last[14] * dt2
                else:
                    a1, a2 = evaluate(t, q1, q2, qd1, qd2, tau1, tau2, False)
                if rk4:
                    hh = 0.5 * h
                    tm = t + hh
                    v1b, v2b = qd1 + hh * a1, qd2 + hh * a2
                    b1, b2 = evaluate(tm, q1 + hh * qd1, q2 + hh * qd2, v1b, v2b, tau1, tau2,
                                      False)
                    v1c, v2c = qd1 + hh * b1, qd2 + hh * b2
                    c1, c2 = evaluate(tm, q1 + hh * v1b, q2 + hh * v2b, v1c, v2c, tau1, tau2,
                                      False)
                    v1d, v2d = qd1 + h * c1, qd2 + h * c2
                    d1, d2 = evaluate(t + h, q1 + h * v1c, q2 + h * v2c, v1d, v2d, tau1, tau2,
                                      False)
                    h6 = h / 6.0
                    q1 += h6 * (qd1 + 2.0 * (v1b + v1c) + v1d)
                    q2 += h6 * (qd2 + 2.0 * (v2b + v2c) + v2d)
                    qd1 += h6 * (a1 + 2.0 * (b1 + c1) + d1)
                    qd2 += h6 * (a2 + 2.0 * (b2 + c2) + d2)
                else:
                    qd1 += h * a1
                    qd2 += h * a2
                    q1 += h * qd1
                    q2 += h * qd2
                steps += 1
                t = steps * h - t0
                total = q1 + q2 + qd1 + qd2
                if total - total != 0.0:
                    raise OverflowError
            last = evaluate(t, q1, q2, qd1, qd2, tau1, tau2, True)
        except (SingularityError, ZeroDivisionError, ValueError, OverflowError) as error:
            # the simulator stays at its last reading, which was sound
            raise self._failure(t + t0, q1, q2, qd1, qd2) from error
        self._reading = self._sample(steps, q1, q2, last)  # may raise: commit after it
        self._state = (q1, q2, qd1, qd2)
        self._steps = steps
        self._last = last
        self._last_tau = (tau1, tau2)
        self._cached_k1 = True

    def _sample(self, steps: int, q1: float, q2: float, last: tuple) -> SensorReading:
        """The sensors' reading of the state (θ_R at step `steps`, `last` evaluation)."""
        fx, fy = last[2], last[3]
        offset, noise_xy, noise_z, load, rxy, rz, limit_xy, limit_z = self._sensor_constants
        # eq. 3.35–3.36 inverted: the sensor turns with link 4 (θ_R1) plus its mounting
        angle = q1 + offset
        c, s = math.cos(angle), math.sin(angle)
        n1, n2, n3 = self._noise()
        # noise on the analogue signal, then the ADC's quantisation (device.sim.sensors)
        fxs = math.floor((c * fx + s * fy + noise_xy * n1) / rxy + 0.5) * rxy
        fys = math.floor((c * fy - s * fx + noise_xy * n2) / rxy + 0.5) * rxy
        fzs = math.floor((load + noise_z * n3) / rz + 0.5) * rz
        if not (-limit_xy <= fxs <= limit_xy and -limit_xy <= fys <= limit_xy
                and -limit_z <= fzs <= limit_z):
            raise SensorRangeError(
                f"the handle's force sensor reads ({fxs:.1f}, {fys:.1f}, {fzs:.1f}) N at "
                f"t = {steps * self.step_s:.3f} s, beyond its range of {limit_xy:g} N "
                f"horizontal and {limit_z:g} N normal (Table 3.1). Stop the trial; the "
                "simulated subject is pushing against a stalled or runaway robot."
            )
        cpr1, cpr2 = self._counts_per_rev
        return _reading((
            steps * self.step_s,
            round(q1 * cpr1 / _TWO_PI) * 2.0 * math.pi / cpr1,
            round(q2 * cpr2 / _TWO_PI) * 2.0 * math.pi / cpr2,
            fxs, fys, fzs,
        ))


_reading = SensorReading._make


def _check_seed(seed) -> None:
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ParameterError("seed", seed, "a whole number >= 0")


def _child_seed(seed: int, index: int) -> np.random.SeedSequence:
    """The `index`-th independent stream of `seed` (what SeedSequence.spawn gives)."""
    return np.random.SeedSequence(int(seed), spawn_key=(index,))


# ------------------------------------------------------- compiled hand-over
@dataclass(frozen=True, slots=True)
class SimulatorSnapshot:
    """Everything `read` and `write` change, for the compiled tick (device.compiled) to
    take over the simulation and hand it back unchanged."""

    steps: int
    state: tuple[float, float, float, float]
    torque: tuple[float, float]
    last_torque: tuple[float, float]
    last: tuple
    reading: SensorReading
    cached_k1: bool
    patient_t0: float
    anchor: float | None
    noise_block: np.ndarray
    noise_pos: int


def snapshot(simulator: SimulatorBackend) -> SimulatorSnapshot:
    """The simulator's state now (the noise block is shared, not copied)."""
    s = simulator
    return SimulatorSnapshot(
        s._steps, s._state, (s._tau1, s._tau2), s._last_tau, s._last, s._reading,
        s._cached_k1, s._patient_t0, s._anchor, s._noise_block, s._noise_pos,
    )


def restore(simulator: SimulatorBackend, snap: SimulatorSnapshot) -> None:
    """Put the simulator in the state `snap` describes (plain floats, as `read` keeps it).
    The noise block must be the simulator's own current block or the next rows of its
    stream are lost."""
    s = simulator
    if snap.noise_block is not s._noise_block:
        raise StateError("a snapshot can only restore the noise block it was taken with")
    s._steps = int(snap.steps)
    s._state = tuple(float(v) for v in snap.state)
    s._tau1, s._tau2 = (float(v) for v in snap.torque)
    s._last_tau = tuple(float(v) for v in snap.last_torque)
    s._last = tuple(float(v) for v in snap.last)
    s._reading = _reading(float(v) for v in snap.reading)
    s._cached_k1 = bool(snap.cached_k1)
    s._patient_t0 = float(snap.patient_t0)
    s._anchor = None if snap.anchor is None else float(snap.anchor)
    s._noise_pos = int(snap.noise_pos)


# ------------------------------------------------------------------ dynamics
def _fused_dynamics(simulator: SimulatorBackend):
    """`evaluate(t, q1, q2, qd1, qd2, τ1, τ2, full)` for the coupled robot and arm.

    The algebra of core.interaction.coupled_forward_dynamics, flattened on plain
    floats with the patient's torque computed from the arm's state in between,
    compiled: device.compiled.dynamics.evaluate, which the compiled engines use too.
    Returns (θ̈_R1, θ̈_R2) or, with `full`, a 15-tuple: θ̈_R1, θ̈_R2, F_x, F_y,
    θ_s, θ_e, θ̇_s, θ̇_e, θ̈_s, θ̈_e, τ_s, τ_e and the inverse coupled mass
    matrix (n11, n12, n22) that maps a change of motor torque to θ̈_R.
    Raises SingularityError when the arm is straight or out of reach, and
    OverflowError when a full evaluation is not finite.
    """
    from device.compiled import dynamics as compiled  # numba only where it is used

    constants = compiled.simulator_constants(simulator)
    p, table, episodes = compiled.patient_arrays(simulator.patient)
    out = np.empty(15)
    kernel, ok, isfinite = compiled.evaluate, compiled.OK, math.isfinite

    def evaluate(t, q1, q2, qd1, qd2, tau1, tau2, full):
        if kernel(constants, p, table, episodes, t, q1, q2, qd1, qd2, tau1, tau2, out) != ok:
            raise SingularityError("the arm is straight or out of reach")
        values = out.tolist()  # plain floats: a numpy scalar slows every later step
        if not full:
            return values[0], values[1]
        if not isfinite(sum(values)):
            raise OverflowError("the coupled dynamics are not finite")
        return tuple(values)

    return evaluate


def _reference_dynamics(robot: RobotModel, arm, patient):
    """`evaluate` as `_fused_dynamics`, through core.interaction.coupled_forward_dynamics
    and the patient's own `torque`.

    The patient needs the arm's state before its torque is known; the coupled
    dynamics return it, so the first call (with τ_A = 0) gives the state and the
    second the motion.
    """

    def evaluate(t, q1, q2, qd1, qd2, tau1, tau2, full):
        *_, ts, te, tsd, ted = coupled_forward_dynamics(
            robot, arm, q1, q2, qd1, qd2, tau1, tau2, 0.0, 0.0
        )
        tau_s, tau_e = patient.torque(t, ts, te, tsd, ted)
        qdd1, qdd2, fx, fy, *_ = coupled_forward_dynamics(
            robot, arm, q1, q2, qd1, qd2, tau1, tau2, tau_s, tau_e
        )
        if not full:
            return qdd1, qdd2
        tsdd, tedd = arm.forward_dynamics_terms(ts, te, tsd, ted, tau_s, tau_e, fx, fy)
        # the inverse coupled mass from the response to unit torques (validation only)
        u1 = coupled_forward_dynamics(robot, arm, q1, q2, qd1, qd2, tau1 + 1.0, tau2,
                                      tau_s, tau_e)
        u2 = coupled_forward_dynamics(robot, arm, q1, q2, qd1, qd2, tau1, tau2 + 1.0,
                                      tau_s, tau_e)
        return (
            qdd1, qdd2, fx, fy, ts, te, tsd, ted, tsdd, tedd, tau_s, tau_e,
            u1[0] - qdd1, u2[0] - qdd1, u2[1] - qdd2,
        )

    return evaluate


# --------------------------------------------------------------------- bench
def bench_tick(
    kinds=("passive", "healthy", "weak", "spastic", "tremor", "wrong_way"),
    *,
    seconds: float = 4.0,
    integrators=INTEGRATORS,
    trial: TrialParameters = THESIS_SUBJECT,
    repeats: int = 3,
) -> dict[tuple[str, str], float]:
    """Wall-clock µs of one headless tick of the simulator alone (read at k·2 ms,
    then write), per (patient kind, integrator): the best of `repeats` runs.

    A first run with a joint PD on the path records the torques; the timed runs
    replay them, so the motion is a trial's and no controller is on the clock.
    For bench/simulate.py; prints nothing.
    """
    ticks = round(seconds / 0.002)
    robot = RobotModel()
    q_ref, qd_ref, _ = trial.trajectory().joint_reference(robot, np.arange(ticks) * 0.002)
    results = {}
    for integrator in integrators:
        for kind in kinds:
            sim = SimulatorBackend.from_trial(trial, kind, robot=robot, integrator=integrator)
            sim.open()
            torques = []
            for k in range(ticks):
                sim.read(k * 0.002)
                tr = sim.truth
                torques.append((
                    30.0 * (q_ref[k, 0] - tr.q1_rad) + (qd_ref[k, 0] - tr.q1_rate_rad_s),
                    30.0 * (q_ref[k, 1] - tr.q2_rad) + (qd_ref[k, 1] - tr.q2_rate_rad_s),
                ))
                sim.write(*torques[-1])
            times = [k * 0.002 for k in range(ticks)]
            best = math.inf
            for _ in range(repeats):
                sim.open()
                read, write = sim.read, sim.write
                start = time.perf_counter()
                for now, (tau1, tau2) in zip(times, torques, strict=True):
                    read(now)
                    write(tau1, tau2)
                best = min(best, time.perf_counter() - start)
            results[(kind, integrator)] = best / ticks * 1e6
    return results
