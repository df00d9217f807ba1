"""The simulator backend (device.sim.simulator): protocol, time, sensors, and the physics
of the coupled robot and arm against the thesis's equations and invariants."""

import math

import numpy as np
import pytest

from core.errors import ParameterError
from core.interaction import coupled_energy, global_to_sensor, sensor_to_global
from core.motor import MotorParameters
from core.robot import FRICTIONLESS, Friction, RobotModel, Stiffness
from core.trial import THESIS_SUBJECT, TrialParameters
from device.backend import Backend, SensorReading
from device.errors import BackendError, SensorRangeError, StateError
from device.sim.patient_parameters import PATIENT_KINDS
from device.sim.patients import make_patient
from device.sim.sensors import ForceSensorModel
from device.sim.simulator import INTEGRATORS, SimulatorBackend

TICK_S = 0.002
QUIET = ForceSensorModel(noise_xy_N=0.0, noise_z_N=0.0)
# A small circle well inside both reaches: free motions from its start stay bent.
CENTRAL = TrialParameters(shape="circle", centre_m=(-0.30, 0.38), radius_m=0.04)


def simulator(kind="healthy", trial=THESIS_SUBJECT, *, seed=0, robot=None, patient_options=None,
              **options):
    patient = make_patient(kind, trial.arm(), trial.trajectory(), seed=seed,
                           **(patient_options or {}))
    sim = SimulatorBackend(patient, robot=robot, seed=seed, **options)
    sim.open()
    return sim


def track(sim, seconds, gains=(30.0, 1.0)):
    """Run a joint PD on the path (encoder readings, rates from the truth) and yield
    (reading, truth) each tick."""
    t = np.arange(round(seconds / TICK_S)) * TICK_S
    q_ref, qd_ref, _ = sim.trajectory.joint_reference(sim.robot, t)
    kp, kd = gains
    for k in range(t.size):
        reading = sim.read(t[k])
        truth = sim.truth
        yield reading, truth
        sim.write(
            kp * (q_ref[k, 0] - reading.q1_rad) + kd * (qd_ref[k, 0] - truth.q1_rate_rad_s),
            kp * (q_ref[k, 1] - reading.q2_rad) + kd * (qd_ref[k, 1] - truth.q2_rate_rad_s),
        )


def free_run(sim, seconds, push=(0.0, 0.0), push_s=0.0):
    """Torque `push` for `push_s`, then zero; yield (reading, truth) each tick."""
    for k in range(round(seconds / TICK_S)):
        t = k * TICK_S
        reading = sim.read(t)
        yield reading, sim.truth
        sim.write(*(push if t < push_s else (0.0, 0.0)))


def is_multiple(values, step):
    ratio = np.asarray(values) / step
    return np.all(np.abs(ratio - np.round(ratio)) < 1e-6)


# ---------------------------------------------------------------- protocol
def test_simulator_is_a_backend_with_its_lifecycle():
    sim = SimulatorBackend.from_trial(THESIS_SUBJECT, "healthy")
    assert isinstance(sim, Backend)
    assert sim.name == "simulator"
    with pytest.raises(StateError, match="open"):
        sim.read(0.0)
    sim.open()
    reading = sim.read(0.0)
    assert isinstance(reading, SensorReading)
    assert reading.time_s == 0.0
    truth = sim.truth
    # at rest at the path's start, hand and handle together (eq. 3.28)
    start = THESIS_SUBJECT.trajectory().at(0.0)[:2]
    np.testing.assert_allclose(sim.hand_position_m(), start, atol=1e-12)
    np.testing.assert_allclose(sim.arm.position(truth.shoulder_rad, truth.elbow_rad), start,
                               atol=1e-12)
    assert (truth.q1_rate_rad_s, truth.q2_rate_rad_s) == (0.0, 0.0)
    assert all(type(v) is float for v in reading)
    sim.write(1.0, -1.0)
    sim.read(0.01)
    assert (sim.truth.torque1_Nm, sim.truth.torque2_Nm) == (1.0, -1.0)
    sim.safe_state()
    sim.read(0.02)
    assert (sim.truth.torque1_Nm, sim.truth.torque2_Nm) == (0.0, 0.0)
    sim.write(1.0, 1.0)
    sim.close()
    sim.close()
    with pytest.raises(StateError):
        sim.read(0.03)
    sim.open()  # a reopened simulator starts over
    assert sim.read(5.0).time_s == 0.0
    np.testing.assert_allclose(sim.hand_position_m(), start, atol=1e-12)
    sim.read(5.01)
    assert (sim.truth.torque1_Nm, sim.truth.torque2_Nm) == (0.0, 0.0)


def test_time_advances_in_whole_steps_from_the_first_read():
    """Wall-clock `now` with jitter: the simulated time trails it by less than one
    step and never drifts; headless k·2 ms gives exactly the tick times."""
    sim = simulator()
    rng = np.random.default_rng(0)
    now = 12345.678  # any clock; the first read anchors it
    assert sim.read(now).time_s == 0.0
    anchor = now
    last = 0.0
    for _ in range(2000):
        now += rng.uniform(0.0015, 0.0025)
        t = sim.read(now).time_s
        assert 0.0 <= (now - anchor) - t < sim.step_s + 1e-9
        assert is_multiple(t, sim.step_s)
        assert t >= last
        last = t
    headless = simulator()
    for k in range(1000):
        assert headless.read(k * TICK_S).time_s == pytest.approx(k * TICK_S, abs=1e-12)
    # reading twice at the same time is the same sample (stale, for the supervisor)
    assert headless.read(999 * TICK_S) is headless.read(999 * TICK_S)
    # and a clock that goes back gives the last sample again rather than rewinding
    assert headless.read(0.5).time_s == pytest.approx(999 * TICK_S)
    for bad in (math.nan, math.inf):
        with pytest.raises(BackendError, match="now_s"):
            headless.read(bad)
        with pytest.raises(BackendError, match="now_s"):
            simulator().read(bad)


def test_drives_saturate_and_broken_torques_are_refused():
    sim = simulator()
    sim.read(0.0)
    sim.write(10.0, -10.0)
    sim.read(TICK_S)
    limit = sim.robot.max_joint_torque_Nm
    assert (sim.truth.torque1_Nm, sim.truth.torque2_Nm) == (limit[0], -limit[1])
    for bad in (math.nan, math.inf, -math.inf):
        with pytest.raises(BackendError, match="not finite"):
            sim.write(bad, 0.0)
    # the refused command left the last good one in place
    sim.read(2 * TICK_S)
    assert sim.truth.torque1_Nm == limit[0]


def test_bad_simulator_options_are_refused_by_name():
    patient = make_patient("healthy", THESIS_SUBJECT.arm(), THESIS_SUBJECT.trajectory())
    for options, name in (
        ({"step_s": 0.002}, "step_s"),
        ({"step_s": 0.0}, "step_s"),
        ({"integrator": "euler"}, "integrator"),
        ({"timing": "fast"}, "timing"),
        ({"seed": -1}, "seed"),
        ({"seed": 1.5}, "seed"),
    ):
        with pytest.raises(ParameterError, match=name):
            SimulatorBackend(patient, **options)
    with pytest.raises(ParameterError, match="patient"):
        SimulatorBackend(object())
    with pytest.raises(ParameterError, match="noise_xy_N"):
        ForceSensorModel(noise_xy_N=-0.1)
    with pytest.raises(ParameterError, match="kind") as info:
        SimulatorBackend.from_trial(THESIS_SUBJECT, "zombie")
    assert all(kind in str(info.value) for kind in PATIENT_KINDS)
    with pytest.raises(ParameterError, match="effort"):
        SimulatorBackend.from_trial(THESIS_SUBJECT, "weak", patient_options={"effort": 2.0})


# ------------------------------------------------------------- determinism
def readings(seed, kind="tremor", seconds=1.0):
    sim = SimulatorBackend.from_trial(THESIS_SUBJECT, kind, seed=seed)
    sim.open()
    return [reading for reading, _ in track(sim, seconds)]


def test_runs_are_repeatable_for_a_seed_and_differ_between_seeds():
    first, again, other = readings(7), readings(7), readings(8)
    assert first == again
    assert first != other
    forces = np.array([r[3:] for r in first])
    assert np.ptp(forces, axis=0).min() > 0.0  # the noise really is on


# ----------------------------------------------------------------- sensors
@pytest.mark.parametrize("noise", [0.0, 0.05])
def test_force_readings_are_whole_steps_of_the_sensor_resolution(noise):
    sensor = ForceSensorModel(noise_xy_N=noise, noise_z_N=noise, normal_load_N=0.3)
    sim = simulator(sensor=sensor)
    rows = [(r, tr) for r, tr in track(sim, 2.0)]
    fx = [r.force_x_N for r, _ in rows]
    fy = [r.force_y_N for r, _ in rows]
    fz = [r.force_z_N for r, _ in rows]
    assert is_multiple(fx, 1 / 24)
    assert is_multiple(fy, 1 / 24)
    assert is_multiple(fz, 1 / 48)
    # the subject really pushes
    assert np.ptp(fx) > 0.5
    assert np.ptp(fy) > 0.5
    if noise == 0.0:
        for r, tr in rows:
            true = global_to_sensor(tr.force_x_N, tr.force_y_N, tr.q1_rad)
            assert abs(r.force_x_N - true[0]) <= 1 / 48 + 1e-12
            assert abs(r.force_y_N - true[1]) <= 1 / 48 + 1e-12
            assert r.force_z_N == pytest.approx(round(0.3 * 48) / 48)


def test_encoder_readings_are_whole_counts_of_the_joint_resolution():
    sim = simulator()
    resolution = sim.robot.motors[0].joint_angle_resolution_rad
    assert resolution == pytest.approx(2 * math.pi / (4000 * 307 / 16))
    moved = 0.0
    for r, tr in track(sim, 2.0):
        assert is_multiple([r.q1_rad, r.q2_rad], resolution)
        assert r.q1_rad == sim.robot.motors[0].quantise_joint_angle(tr.q1_rad)
        assert r.q2_rad == sim.robot.motors[1].quantise_joint_angle(tr.q2_rad)
        assert abs(r.q1_rad - tr.q1_rad) <= resolution / 2 + 1e-12
        assert abs(r.q2_rad - tr.q2_rad) <= resolution / 2 + 1e-12
        moved = max(moved, abs(tr.q1_rad - sim.robot.ik_terms(*sim.trajectory.at(0.0)[:2])[0]))
    assert moved > 100 * resolution


def test_sensor_mounting_offset_rotates_the_reading_and_round_trips_eq_3_35():
    offset = 0.7
    plain = simulator(sensor=QUIET)
    turned = simulator(sensor=ForceSensorModel(noise_xy_N=0.0, noise_z_N=0.0, offset_rad=offset))
    biggest = 0.0
    for (r0, t0), (r1, t1) in zip(track(plain, 1.0), track(turned, 1.0), strict=True):
        assert t1 == t0  # the mounting changes the reading, not the physics
        back = sensor_to_global(r1.force_x_N, r1.force_y_N, t1.q1_rad, offset)
        assert math.dist(back, (t1.force_x_N, t1.force_y_N)) <= math.sqrt(2) / 48 + 1e-12
        expected = global_to_sensor(t1.force_x_N, t1.force_y_N, t1.q1_rad, offset)
        assert math.dist((r1.force_x_N, r1.force_y_N), expected) <= math.sqrt(2) / 48 + 1e-12
        # the turned sensor reads the plain one's force turned back by the offset
        c, s = math.cos(offset), math.sin(offset)
        unturned = (c * r0.force_x_N + s * r0.force_y_N, c * r0.force_y_N - s * r0.force_x_N)
        assert math.dist(r1[3:5], unturned) <= 2 * math.sqrt(2) / 48 + 1e-12
        biggest = max(biggest, math.hypot(t0.force_x_N, t0.force_y_N))
    assert biggest > 1.0


# ----------------------------------------------------------------- physics
def test_hand_force_satisfies_both_equations_of_motion_eq_3_26_3_27():
    """At sampled instants, with the force as the sensor reports it (rotated back,
    quantised): the arm's M_A θ̈_A + C_A θ̇_A = τ_A − J_Aᵀ F (eq. 3.27) and the
    robot's M_R θ̈_R + h_R = τ_R + J_Rᵀ F (eq. 3.6, 3.26); the hand stays on the
    handle (eq. 3.28, 3.30)."""
    sim = simulator("healthy", sensor=QUIET)
    arm, robot = sim.arm, sim.robot
    worst_arm = worst_robot = 0.0
    for k, (r, tr) in enumerate(track(sim, 4.0)):
        if k % 25:
            continue
        fx, fy = sensor_to_global(r.force_x_N, r.force_y_N, tr.q1_rad)
        theta = (tr.shoulder_rad, tr.elbow_rad)
        rates = (tr.shoulder_rate_rad_s, tr.elbow_rate_rad_s)
        tau_a = arm.inverse_dynamics_terms(*theta, *rates, tr.shoulder_acc_rad_s2,
                                           tr.elbow_acc_rad_s2, fx, fy)
        worst_arm = max(worst_arm, np.abs(np.subtract(
            tau_a, (tr.shoulder_torque_Nm, tr.elbow_torque_Nm))).max())
        tau_r = robot.inverse_dynamics_terms(tr.q1_rad, tr.q2_rad, tr.q1_rate_rad_s,
                                             tr.q2_rate_rad_s, tr.q1_acc_rad_s2,
                                             tr.q2_acc_rad_s2, fx, fy)
        worst_robot = max(worst_robot, np.abs(np.subtract(
            tau_r, (tr.torque1_Nm, tr.torque2_Nm))).max())
        np.testing.assert_allclose(arm.position(*theta), robot.position(tr.q1_rad, tr.q2_rad),
                                   atol=1e-12)
        j_a = arm.jacobian(theta)
        j_r = robot.jacobian([tr.q1_rad, tr.q2_rad])
        np.testing.assert_allclose(j_a @ rates, j_r @ [tr.q1_rate_rad_s, tr.q2_rate_rad_s],
                                   atol=1e-12)
    # F is quantised to 1/24 N per axis: |J| < 0.7 m turns that into < 0.03 N·m
    assert worst_arm < 0.03
    assert worst_robot < 0.03


@pytest.mark.parametrize(
    ("integrator", "rel", "abs_"),
    # Euler's rates move by the acceleration at the start of each step, so a central
    # difference over ±2 ms sees it half a step late: a first-order, few-% offset.
    [("semi_implicit_euler", 0.05, 0.02), ("rk4", 2e-3, 1e-3)],
)
def test_reported_accelerations_are_the_derivatives_of_the_motion(integrator, rel, abs_):
    """θ̈ reported at each reading against central differences of the reported rates
    (torques held constant, so the motion is smooth)."""
    sim = simulator("healthy", integrator=integrator)
    rows = [tr for _, tr in free_run(sim, 1.5)]
    for i in range(21, len(rows) - 1, 20):  # after the start, where the path speed jumps
        prev, now, nxt = rows[i - 1], rows[i], rows[i + 1]
        for rate, acc in (("q1_rate_rad_s", "q1_acc_rad_s2"), ("q2_rate_rad_s", "q2_acc_rad_s2"),
                          ("shoulder_rate_rad_s", "shoulder_acc_rad_s2"),
                          ("elbow_rate_rad_s", "elbow_acc_rad_s2")):
            numeric = (getattr(nxt, rate) - getattr(prev, rate)) / (2 * TICK_S)
            assert getattr(now, acc) == pytest.approx(numeric, rel=rel, abs=abs_)


@pytest.mark.parametrize(("integrator", "bound"), [("semi_implicit_euler", 3e-3), ("rk4", 1e-9)])
def test_energy_is_conserved_without_friction_damping_or_control(integrator, bound):
    """A push, then free motion: robot + arm kinetic energy plus the passive tissue's
    elastic energy stays constant to `bound` (relative) over 5 s. (Symplectic Euler's
    error is a bounded oscillation of about hω; RK4's is round-off.)"""
    robot = RobotModel(friction=FRICTIONLESS)
    stiffness = (2.0, 0.5, 1.5)
    sim = simulator("passive", CENTRAL, robot=robot, integrator=integrator,
                    patient_options={"passive_stiffness_Nm_rad": stiffness,
                                     "passive_damping_Nms_rad": (0.0, 0.0, 0.0)})
    ts0, te0 = sim.patient.start_posture_rad
    k = np.array([[stiffness[0], stiffness[1]], [stiffness[1], stiffness[2]]])

    def energy(tr):
        e = np.array([tr.shoulder_rad - ts0, (tr.elbow_rad - tr.shoulder_rad) - (te0 - ts0)])
        return coupled_energy(robot, sim.arm, tr.q1_rad, tr.q2_rad, tr.q1_rate_rad_s,
                              tr.q2_rate_rad_s) + 0.5 * e @ k @ e

    rows = [tr for _, tr in free_run(sim, 5.0, push=(0.4, -0.3), push_s=0.1)]
    free = [energy(tr) for tr in rows if tr.time_s > 0.1 + 1e-9]
    drift = np.abs(np.array(free) - free[0]).max() / free[0]
    assert drift < bound
    assert free[0] > 1e-3  # there is something to conserve
    travel = [math.dist(sim.robot.position(tr.q1_rad, tr.q2_rad),
                        sim.robot.position(rows[0].q1_rad, rows[0].q2_rad)) for tr in rows]
    assert max(travel) > 0.01


def test_motor_work_equals_the_energy_gained():
    """∫ τ_R · θ̇_R dt = ΔE for a frictionless robot and a relaxed arm without tissue
    (RK4; trapezoid rule over each tick, where the torque is held)."""
    robot = RobotModel(friction=FRICTIONLESS)
    sim = simulator("passive", CENTRAL, robot=robot, integrator="rk4",
                    patient_options={"passive_stiffness_Nm_rad": (0.0, 0.0, 0.0),
                                     "passive_damping_Nms_rad": (0.0, 0.0, 0.0)})
    work = 0.0
    previous = None
    energies = []
    for k in range(1000):
        sim.read(k * TICK_S)
        tr = sim.truth
        energies.append(coupled_energy(robot, sim.arm, tr.q1_rad, tr.q2_rad, tr.q1_rate_rad_s,
                                       tr.q2_rate_rad_s))
        if previous is not None:
            tau, rates = previous
            work += 0.5 * TICK_S * (tau[0] * (rates[0] + tr.q1_rate_rad_s)
                                    + tau[1] * (rates[1] + tr.q2_rate_rad_s))
        torque = (0.3 * math.sin(3.0 * k * TICK_S), -0.2 * math.cos(2.0 * k * TICK_S))
        sim.write(*torque)
        previous = (torque, (tr.q1_rate_rad_s, tr.q2_rate_rad_s))
    gained = energies[-1] - energies[0]
    assert abs(gained) > 1e-3
    assert work == pytest.approx(gained, rel=1e-4)


ALL_TERMS = RobotModel(
    friction=Friction((0.05, 0.04), (0.02, 0.03), ee_coulomb_N=0.3, ee_viscous_Ns_m=0.5),
    stiffness=Stiffness(0.5, 0.1, 0.4, 1.0, 2.0),
)
"""A robot with every term of eq. 3.6 switched on: joint and end-effector friction,
stiffness."""


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_the_interpreted_simulator_is_the_compiled_one_bit_for_bit(integrator):
    """The same physics kernels (device.sim.physics), run by numba and by Python, on a
    robot with every term on and a spastic patient: every reading and every true value
    equal."""
    compiled = simulator("spastic", robot=ALL_TERMS, integrator=integrator, compiled=True)
    interpreted = simulator("spastic", robot=ALL_TERMS, integrator=integrator, compiled=False)
    for (rc, tc), (ri, ti) in zip(track(compiled, 0.5), track(interpreted, 0.5), strict=True):
        assert rc == ri
        assert tc == ti


def test_the_simulated_motion_obeys_both_equations_of_motion():
    """At every reading the simulator's accelerations and hand force satisfy the robot's
    eq. 3.26 and the arm's eq. 3.27, checked with RobotModel's and ArmModel's own inverse
    dynamics, and the patient's torque is the one it reports: the coupled solve
    (core.interaction.coupled_motion) is right, not just consistent with itself."""
    sim = simulator("spastic", robot=ALL_TERMS, integrator="rk4")
    worst_robot = worst_arm = 0.0
    previous = (0.0, 0.0)
    for _, tr in track(sim, 1.0):
        tau = ALL_TERMS.inverse_dynamics_terms(
            tr.q1_rad, tr.q2_rad, tr.q1_rate_rad_s, tr.q2_rate_rad_s, tr.q1_acc_rad_s2,
            tr.q2_acc_rad_s2, tr.force_x_N, tr.force_y_N)
        worst_robot = max(worst_robot, abs(tau[0] - tr.torque1_Nm), abs(tau[1] - tr.torque2_Nm))
        arm = sim.arm.inverse_dynamics_terms(
            tr.shoulder_rad, tr.elbow_rad, tr.shoulder_rate_rad_s, tr.elbow_rate_rad_s,
            tr.shoulder_acc_rad_s2, tr.elbow_acc_rad_s2, tr.force_x_N, tr.force_y_N)
        worst_arm = max(worst_arm, abs(arm[0] - tr.shoulder_torque_Nm),
                        abs(arm[1] - tr.elbow_torque_Nm))
        previous = (tr.torque1_Nm, tr.torque2_Nm)
    assert previous != (0.0, 0.0)  # the motors did work
    assert worst_robot < 1e-9
    assert worst_arm < 1e-9


# --------------------------------------------------------------- failures
def test_a_straight_arm_stops_the_simulation_with_a_backend_error():
    strong = RobotModel(motors=(MotorParameters(peak_factor=20.0),) * 2, friction=FRICTIONLESS)
    sim = simulator("passive", robot=strong,
                    patient_options={"passive_stiffness_Nm_rad": (0.0, 0.0, 0.0),
                                     "passive_damping_Nms_rad": (0.0, 0.0, 0.0)})
    shoulder = np.array([sim.arm.shoulder_x_m, sim.arm.shoulder_y_m])

    def drag_the_hand_away_from_the_shoulder():
        for k in range(2500):
            r = sim.read(k * TICK_S)
            away = np.subtract(sim.hand_position_m(), shoulder)
            push = 30.0 * away / np.linalg.norm(away)
            sim.write(*strong.joint_torque_terms(r.q1_rad, r.q2_rad, *push))

    with pytest.raises(BackendError, match="straight") as info:
        drag_the_hand_away_from_the_shoulder()
    assert "reach" in str(info.value)
    # the simulator stays at its last reading: bent, finite, and it says so again
    assert math.dist(sim.hand_position_m(), shoulder) < sim.arm.reach_max_m
    assert sim.time_s > 0.1
    with pytest.raises(BackendError, match="straight"):
        sim.read(10.0)


class _BrokenPatient:
    """A patient whose torque turns NaN after 0.1 s."""

    def __init__(self):
        healthy = make_patient("healthy", THESIS_SUBJECT.arm(), THESIS_SUBJECT.trajectory())
        self.arm, self.trajectory, self._healthy = healthy.arm, healthy.trajectory, healthy

    def torque(self, t_s, ts, te, tsd, ted):
        if t_s > 0.1:
            return (math.nan, 0.0)
        return self._healthy.torque(t_s, ts, te, tsd, ted)


def test_a_non_finite_state_stops_the_simulation_with_a_backend_error():
    sim = SimulatorBackend(_BrokenPatient())
    sim.open()
    sim.read(0.0)
    with pytest.raises(BackendError, match="non-finite"):
        sim.read(0.2)
    assert sim.time_s == 0.0


def test_another_patient_runs_interpreted_and_compiled_is_refused_by_name():
    """The compiled physics take a VirtualPatient's torque; any other object of the
    Patient protocol is simulated by the same kernels interpreted, with its own torque."""
    assert SimulatorBackend(_BrokenPatient()).compiled is False
    with pytest.raises(ParameterError, match="compiled") as error:
        SimulatorBackend(_BrokenPatient(), compiled=True)
    assert "a _BrokenPatient is simulated interpreted" in str(error.value)


def test_a_force_beyond_the_sensors_range_is_a_sensor_range_error():
    sim = simulator("passive", sensor=ForceSensorModel(noise_xy_N=0.0, noise_z_N=0.0,
                                                       limit_xy_N=1.0))

    def run_until_it_fails():
        # the motors push the relaxed arm: the hand resists with its inertia and tissue
        for reading, _ in free_run(sim, 2.0, push=(1.0, 1.0), push_s=2.0):
            assert abs(reading.force_x_N) <= 1.0
            assert abs(reading.force_y_N) <= 1.0

    with pytest.raises(SensorRangeError, match="range of 1 N"):
        run_until_it_fails()
    # nothing was committed: the same read fails again rather than going stale
    stuck = sim.time_s
    with pytest.raises(SensorRangeError):
        sim.read(stuck + TICK_S)
    assert sim.time_s == stuck


def test_a_waiting_patient_holds_still_until_cued_then_does_the_exercise():
    """With patient_waits, a healthy patient holds the start until `cue_patient`, then
    moves exactly as an uncued one does from time 0."""
    waiting = simulator("healthy", patient_waits=True)
    start = waiting.hand_position_m()
    for k in range(500):
        waiting.read(k * TICK_S)
    assert math.dist(waiting.hand_position_m(), start) < 1e-12
    assert waiting.patient_time_s < -1e6
    waiting.cue_patient()
    assert waiting.patient_time_s == 0.0
    prompt = simulator("healthy")
    for k in range(1000):
        prompt.read(k * TICK_S)
        waiting.read((499 + k) * TICK_S)  # the cue came with the reading at 499
        assert math.dist(waiting.hand_position_m(), prompt.hand_position_m()) < 1e-9
    assert math.dist(prompt.hand_position_m(), start) > 0.05
    with pytest.raises(ParameterError, match="at_s"):
        waiting.cue_patient(math.nan)


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("stop_s", [1.0, 2.0, 3.0])
def test_a_patient_told_the_trial_ended_rests_its_hand_where_it_is_and_pushes_nothing(
        compiled, stop_s):
    """`rest_patient` (the loop calls it as a trial ends): the exercise stops there (its
    clock ran on before, and its plan went on without the trial: clinic exploration 2 #3)
    and the patient rests its hand, the robot at zero torque. It used to hold the start
    posture again as before its cue: stopped mid-path, its stiffness threw the handle back
    at up to 1.3 m/s, over the supervisor's 1 m/s, and a plan's Pause or Stop latched a
    speed fault. Now the hand slows from the speed the trial left it with and settles,
    the relaxed arm drifting it slowly back toward its rest posture."""
    sim = simulator("healthy", patient_waits=True, compiled=compiled)
    sim.cue_patient()
    tick = round(stop_s / TICK_S)
    speeds = []

    def step(k):
        before = sim.hand_position_m()
        sim.read(k * TICK_S)
        speeds.append(math.dist(sim.hand_position_m(), before) / TICK_S)

    for k in range(1, tick + 1):
        step(k)
    at_stop = speeds[-1]
    sim.rest_patient()
    assert sim.patient_time_s < -1e6
    speeds.clear()
    for k in range(tick + 1, tick + 5001):
        step(k)
    assert max(speeds) <= at_stop + 0.005, (at_stop, max(speeds))
    assert max(speeds[250:]) < 0.25  # half a second on: slow, whatever it was doing
    assert speeds[-1] < 0.02
    assert math.hypot(sim.truth.force_x_N, sim.truth.force_y_N) < 0.5
