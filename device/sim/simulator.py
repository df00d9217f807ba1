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

The equations are kernels (device.sim.physics, on core.interaction's
`arm_state` and `coupled_motion`): compiled by numba (`compiled=True`, the default for
a device.sim.patients.VirtualPatient, whose torque is a kernel too), or interpreted for
any other object of the Patient protocol, whose torque is plain Python, and for
reference runs (`compiled=False`): the same code either way, so the same numbers.

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
use it to validate physics. bench/simulate.py measures both.

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

The zero at Connect: `open()` takes the sensor's zero as the hardware does, and refuses
one taken under load; a virtual patient's hand may take hold of the handle meanwhile
(`push_at_connect_N`, device.sim.grip).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError, capitalised, check_finite, check_range
from core.robot import RobotModel
from core.trial import THESIS_SUBJECT, TrialParameters
from device.backend import SIMULATED, TIMINGS, SensorReading, Tare
from device.errors import BackendError, SensorRangeError, StateError, TareUnderLoad
from device.sim import physics
from device.sim.grip import zero_at_connect
from device.sim.patients import Patient, VirtualPatient, make_patient
from device.sim.plant import Plant
from device.sim.seeds import ROBOT_SEED, check_seed, child_seed
from device.sim.sensors import ForceSensorModel
from device.sim.simulator_kernels import Kernels, constants_of
from device.sim.tasks import own_movement, split_options

INTEGRATORS = ("rk4", "semi_implicit_euler")
DEFAULT_STEP_S = 0.001
MAX_STEP_S = 0.001
NOISE_BLOCK = 4096
"""Sensor-noise triples drawn from the generator at a time."""
# A waiting patient's clock: this far before the exercise's start, the desired
# motion is the start posture at rest (finite, so the tremor's sine stays defined).
_WAITING_S = 1e9
_RESTING_S = 2e9  # a resting one's, after a trial (patient_torque.RELAXED_BEFORE_S)


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
    `integrator`, `compiled`, `patient_waits` and `timing` are described in the module
    notes. The physics are device.sim.physics's kernels (bound to this simulator by
    device.sim.simulator_kernels) on this object's vectors (`constants`, `state`,
    `noise`), which the loop's tick engine uses as they are; the seeds device.sim.seeds'.
    """

    name = "simulator"

    def __init__(
        self,
        patient: Patient,
        *,
        robot: RobotModel | None = None,
        plant: Plant | None = None,
        seed: int = 0,
        sensor: ForceSensorModel | None = None,
        step_s: float = DEFAULT_STEP_S,
        integrator: str = "semi_implicit_euler",
        compiled: bool | None = None,
        patient_waits: bool = False,
        timing: str = SIMULATED,
        push_at_connect_N: tuple[float, float] = (0.0, 0.0),
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
        if compiled is None:
            compiled = compilable
        if compiled and not compilable:
            raise ParameterError(
                "compiled", compiled, "False for this patient",
                f"the compiled physics take a VirtualPatient's torque; a "
                f"{type(patient).__name__} is simulated interpreted, with its own torque",
            )
        check_seed(seed)
        self.step_s = check_range(
            "step_s", step_s, 0.0, MAX_STEP_S, "s",
            "the simulator's internal step must resolve the 2 ms loop", low_open=True,
        )
        if not isinstance(patient_waits, bool):
            raise ParameterError("patient_waits", patient_waits, "True or False")
        self.patient = patient
        if plant is not None and robot is not None and robot != plant.robot:
            raise ParameterError("robot", "a second robot", "None when a plant is given",
                                 "the plant's robot is the one simulated")
        if plant is not None and not isinstance(plant, Plant):
            raise ParameterError("plant", type(plant).__name__, "a device.sim.plant.Plant")
        self.robot = plant.robot if plant is not None else (
            robot if robot is not None else RobotModel())
        self.plant = plant if plant is not None else Plant.ideal(self.robot)
        """What is simulated (device.sim.plant): the robot, the drives' delay and gain."""
        self.arm = patient.arm
        self.trajectory = patient.trajectory
        self.sensor = sensor if sensor is not None else ForceSensorModel()
        self.seed = int(seed)
        self.integrator = integrator
        self.compiled = bool(compiled)
        self.patient_waits = patient_waits
        try:
            push = tuple(float(v) for v in push_at_connect_N)
        except (TypeError, ValueError):
            push = ()
        if len(push) != 2 or not all(math.isfinite(v) for v in push):
            raise ParameterError("push_at_connect_N", push_at_connect_N,
                                 "(fx, fy) in N, finite", "a hand's push at Connect")
        self.push_at_connect_N = push
        self.tare: Tare | None = None
        """How the zero at the last `open()` went (None before one)."""
        x0, y0, *_ = self.trajectory.at(0.0)
        q1, q2 = self.robot.ik_terms(x0, y0)
        if math.isnan(q1):
            raise ParameterError(
                "trajectory", f"start ({x0:.3f}, {y0:.3f}) m", "a point the robot reaches",
                "the simulation starts at rest at the path's start",
            )
        self._q0 = (q1, q2)
        self.constants = constants_of(self)
        """The sensors' and the integrator's constants (device.physics' S_* names)."""
        self._kernels = Kernels(self)
        self.state = self._kernels.vector(physics.X_SIZE)
        """The simulator's state (device.sim.physics' X_* names)."""
        self._scratch = self._kernels.vector(physics.SCRATCH_SIZE)
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
        plant: str = "ideal",
        robot_seed: int = ROBOT_SEED,
        **options,
    ) -> SimulatorBackend:
        """A simulator for `trial` with a patient of `kind` (one of PATIENT_KINDS,
        device.sim.patient_parameters).

        `seed` sets the trial's draws: the patient's and the sensor noise (through
        independent child seeds); `patient_options` go to make_patient; `plant` is
        "ideal" (the robot simulated is `options["robot"]`, the controller's model) or
        "realistic" (device.sim.plant, drawn around it by `robot_seed`: one robot for
        every trial, as a station has one, whatever each trial's seed); the other
        `options` go to the constructor.
        """
        check_seed(seed)
        check_seed(robot_seed)
        nominal = options.pop("robot", None) or RobotModel()
        patient_seed = child_seed(seed, 0)
        # an assessment task's patient moves on its own plan (device.sim.tasks), an
        # exercise's follows the reference
        body, movement = split_options(trial, dict(patient_options or {}))
        own = own_movement(trial, kind, {**body, **movement}, patient_seed, nominal)
        built = make_patient(
            kind, trial.arm(), own or trial.trajectory(), seed=patient_seed, **body,
        )
        x0, y0, *_ = built.trajectory.at(0.0)
        rest = nominal.ik_terms(x0, y0)
        return cls(built, seed=seed, plant=Plant.of_kind(plant, nominal, robot_seed, rest),
                   **options)

    # --------------------------------------------------------------- protocol
    def open(self) -> None:
        """Take the force sensor's zero (TareUnderLoad when taken under load), then reset
        to rest at the path's start with zero torque; the next read is time 0."""
        self.tare = self._take_zero()
        refused = self.tare.refusal()
        if refused:
            raise TareUnderLoad(capitalised(refused) + ".")
        self._reset()
        self._is_open = True

    def _take_zero(self) -> Tare:
        """The zero's samples as the sensor reads them (device.sim.grip)."""
        return zero_at_connect(self.push_at_connect_N, self.sensor, child_seed(self.seed, 2))

    def read(self, now_s: float) -> SensorReading:
        """Advance to `now_s` (whole steps, torques held) and sample the sensors."""
        if not self._is_open:
            raise StateError("the simulator is not open; call open() before read()")
        self.top_up_noise(1)
        status = self._kernels.read(self.state, now_s, self.noise, self._scratch)
        if status != physics.OK:
            raise self.failure(status, now_s)
        return self.sampled()

    def sampled(self) -> SensorReading:
        """The last reading, after device.sim.physics' read ran on `state` (here or in the
        tick engine): the same object again when it did not advance (a stale sample)."""
        steps = self.state[physics.X_STEPS]
        if steps != self._sampled_at:
            self._sampled_at = steps
            self._reading = self.reading
        return self._reading

    def write(self, torque1_Nm: float, torque2_Nm: float) -> None:
        """Command joint torques; the drives saturate at the motors' limit."""
        # plain floats: a numpy scalar would slow every later step
        torque1_Nm = float(torque1_Nm)
        torque2_Nm = float(torque2_Nm)
        if not (math.isfinite(torque1_Nm) and math.isfinite(torque2_Nm)):
            raise BackendError(
                f"torque command ({torque1_Nm}, {torque2_Nm}) N·m is not finite; the "
                "controller's output is broken. The motors were left at their last command."
            )
        self._kernels.write(self.state, torque1_Nm, torque2_Nm)

    def safe_state(self) -> None:
        """Zero the motor torques."""
        self.state[physics.X_TAU1] = 0.0
        self.state[physics.X_TAU2] = 0.0
        self.state[physics.X_PENDING] = 0.0
        self.state[physics.X_PENDING + 1] = 0.0

    def close(self) -> None:
        """Zero the torques and stop; safe to call twice."""
        self.safe_state()
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
        self.state[physics.X_T0] = start
        self.state[physics.X_CACHED] = 0.0  # the patient's torque at this instant changed

    def rest_patient(self) -> None:
        """The trial ended (its end, Stop, a fault): the patient stops the exercise and
        rests its hand where the trial left it, pushing nothing, while the robot's torque
        is zero, until the next trial cues it (device.sim.patient_torque.RELAXED_BEFORE_S:
        why not its clock running on, nor holding the start posture as before its cue)."""
        self.state[physics.X_T0] = self.time_s + _RESTING_S
        self.state[physics.X_CACHED] = 0.0

    @property
    def patient_time_s(self) -> float:
        """Time on the patient's clock (since their cue; negative while waiting)."""
        return self.time_s - float(self.state[physics.X_T0])

    # ------------------------------------------------------------ validation
    def noise_generator(self) -> np.random.Generator:
        """A new generator of the force sensor's noise, as `open` starts it: the
        sensor's child seed of `seed`, independent of the patient's."""
        return np.random.default_rng(child_seed(self.seed, 1))

    @property
    def start_angles_rad(self) -> tuple[float, float]:
        """The robot's joint angles at rest at the path's start, where `open` puts it."""
        return self._q0

    @property
    def time_s(self) -> float:
        """Simulated time of the last reading."""
        return float(self.state[physics.X_STEPS]) * self.step_s

    @property
    def reading(self) -> SensorReading:
        """The last reading."""
        at = physics.X_READING
        values = self.state[at:at + 6]
        return _reading(values.tolist() if self.compiled else values)

    @property
    def truth(self) -> SimulatorTruth:
        """The true state, force and torques at the last reading."""
        x = self.state
        r = [float(v) for v in x[physics.X_LAST:physics.X_LAST + 12]]
        return SimulatorTruth(
            self.time_s, float(x[physics.X_Q1]), float(x[physics.X_Q2]),
            float(x[physics.X_QD1]), float(x[physics.X_QD2]), *r,
            float(x[physics.X_LAST_TAU1]), float(x[physics.X_LAST_TAU2]),
        )

    @property
    def physics(self):
        """What the tick engine needs to run device.sim.physics on this simulator: the
        constant vectors (r, a, c, p, table, episodes), the flavour (a function from a
        kernel to the callable the simulator runs) and the scratch."""
        return self._kernels.arrays, self._kernels.flavour, self._scratch

    @property
    def replacements(self) -> dict:
        """What an interpreted flavour of the physics replaces (the patient's own torque
        for a patient that is not a VirtualPatient), for kernels that call them."""
        return self._kernels.replacements

    def hand_position_m(self) -> tuple[float, float]:
        """The handle's true position (eq. 3.2)."""
        return self.robot.position(float(self.state[physics.X_Q1]),
                                   float(self.state[physics.X_Q2]))

    # ------------------------------------------------------------------ noise
    def top_up_noise(self, rows: int) -> None:
        """Make sure at least `rows` noise triples are left, drawing the next block now if
        not. The stream keeps its order (the rows left come first), so the readings are
        the same however it is cut into blocks: the live loop calls this between ticks so
        that no tick pays for a draw."""
        used = int(self.state[physics.X_NOISE])
        if len(self.noise) - used >= rows:
            return
        fresh = self._noise_rng.standard_normal((max(NOISE_BLOCK, rows), 3))
        left = np.asarray(self.noise[used:], dtype=float).reshape(-1, 3)
        self.noise = self._kernels.rows(np.vstack((left, fresh)))
        self.state[physics.X_NOISE] = 0.0

    def next_noise(self, n: int) -> list[list[float]]:
        """The next `n` noise triples the sensor will use (for tests: they are not used)."""
        self.top_up_noise(n)
        used = int(self.state[physics.X_NOISE])
        return [[float(v) for v in row] for row in self.noise[used:used + n]]

    # --------------------------------------------------------------- private
    def _reset(self) -> None:
        # the sensor noise has its own child seed, independent of the patient's (child 0)
        self._noise_rng = self.noise_generator()
        self.noise = self._kernels.rows(self._noise_rng.standard_normal((NOISE_BLOCK, 3)))
        self.state[physics.X_NOISE] = 0.0
        t0 = _WAITING_S if self.patient_waits else 0.0
        status = self._kernels.reset(*self._q0, t0, self.state, self.noise, self._scratch)
        if status != physics.OK:
            raise self.failure(status, 0.0)
        self._sampled_at = 0.0
        self._reading = self.reading

    def failure(self, status: int, now_s: float) -> BackendError:
        """The error a physics status means (device.sim.physics), as `read` raises it, with
        what the last failed call left in the scratch."""
        if status == physics.BAD_TIME:
            return BackendError(
                f"read() got now_s = {now_s}; pass the loop's clock in seconds, finite")
        scratch = [float(v) for v in self._scratch]
        if status == physics.SENSOR_RANGE:
            fxs, fys, fzs = scratch[:3]
            limit_xy, limit_z = self.sensor.limit_xy_N, self.sensor.limit_z_N
            return SensorRangeError(
                f"the handle's force sensor reads ({fxs:.1f}, {fys:.1f}, {fzs:.1f}) N at "
                f"t = {self.time_s + self.step_s:.3f} s, beyond its range of {limit_xy:g} N "
                f"horizontal and {limit_z:g} N normal (Table 3.1). Stop the trial; the "
                "simulated subject is pushing against a stalled or runaway robot."
            )
        t, q1, q2, qd1, qd2 = scratch[physics.FAILED_AT:physics.FAILED_AT + 5]
        if status == physics.NOT_FINITE or not all(
                math.isfinite(v) for v in (q1, q2, qd1, qd2)):
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


_reading = SensorReading._make
