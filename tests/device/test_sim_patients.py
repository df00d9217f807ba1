"""Virtual patients in the simulator: what each impairment does to the motion and to the
force the handle measures, with the robot passive or holding the path."""

import math

import numpy as np
import pytest

from core.trial import THESIS_SUBJECT
from device.sim.sensors import ForceSensorModel
from device.sim.simulator import SimulatorBackend

TICK_S = 0.002
QUIET = ForceSensorModel(noise_xy_N=0.0, noise_z_N=0.0)


def run(kind, seconds, *, trial=THESIS_SUBJECT, hold_path=False, seed=0, **patient_options):
    """Simulate `kind` for `seconds`: with zero motor torque (the robot passive, its
    friction on) or, with `hold_path`, a stiff joint PD on the path. Returns arrays of
    time, hand position, true hand force and patient torques, and the simulator."""
    sim = SimulatorBackend.from_trial(trial, kind, seed=seed, sensor=QUIET,
                                      patient_options=patient_options)
    sim.open()
    t = np.arange(round(seconds / TICK_S)) * TICK_S
    q_ref, qd_ref, _ = sim.trajectory.joint_reference(sim.robot, t)
    rows = []
    for k in range(t.size):
        sim.read(t[k])
        tr = sim.truth
        rows.append((tr.time_s, *sim.hand_position_m(), tr.force_x_N, tr.force_y_N,
                     tr.shoulder_torque_Nm, tr.elbow_torque_Nm))
        if hold_path:
            sim.write(60.0 * (q_ref[k, 0] - tr.q1_rad) + 1.5 * (qd_ref[k, 0] - tr.q1_rate_rad_s),
                      60.0 * (q_ref[k, 1] - tr.q2_rad) + 1.5 * (qd_ref[k, 1] - tr.q2_rate_rad_s))
    a = np.array(rows)
    return a[:, 0], a[:, 1:3], a[:, 3:5], a[:, 5:7], sim


def path_error_m(t, position, trial=THESIS_SUBJECT):
    return np.hypot(*(position - trial.trajectory().sample(t).position_m).T)


def test_a_healthy_subject_moves_a_passive_robot_along_the_path():
    """Zero motor torque, friction on: the subject's own torques carry the handle
    round the D twice within 15 mm RMS and 35 mm at worst (the thesis's healthy
    subject, with the SMC assisting, was within 8.7 mm RMS per axis). A passive arm
    in the same robot stays exactly where it started."""
    t, position, _, _, _ = run("healthy", 8.0)
    error = path_error_m(t, position)
    assert math.sqrt(np.mean(error**2)) < 0.015
    assert error.max() < 0.035
    travelled = np.hypot(*(position - position[0]).T).max()
    assert travelled > 0.19  # it went round: the D is 0.2 m tall

    t, position, force, _, _ = run("passive", 8.0)
    assert np.hypot(*(position - position[0]).T).max() < 1e-9
    assert np.abs(force).max() < 1e-9
    assert math.sqrt(np.mean(path_error_m(t, position) ** 2)) > 0.05


def test_a_weak_subject_falls_behind_where_a_healthy_one_keeps_up():
    t, healthy, _, _, _ = run("healthy", 4.0)
    _, weak, _, _, _ = run("weak", 4.0)
    rms_healthy = math.sqrt(np.mean(path_error_m(t, healthy) ** 2))
    rms_weak = math.sqrt(np.mean(path_error_m(t, weak) ** 2))
    assert rms_weak > 2.0 * rms_healthy


def test_tremor_shows_in_the_torque_spectrum_between_4_and_6_hz():
    for seed in (1, 2):
        t, _, _, torque, sim = run("tremor", 8.0, seed=seed)
        frequency = sim.patient.tremor_frequency_hz
        assert 4.0 <= frequency <= 6.0
        freqs = np.fft.rfftfreq(t.size, TICK_S)
        band = (freqs >= 1.0) & (freqs <= 50.0)  # above the movement's own 0.25 Hz rhythm
        for column in torque.T:
            spectrum = np.abs(np.fft.rfft((column - column.mean()) * np.hanning(t.size)))
            peak = freqs[band][np.argmax(spectrum[band])]
            assert 4.0 <= peak <= 6.0
            assert abs(peak - frequency) <= 0.25


def test_wrong_way_subject_pushes_against_the_path_for_the_stated_fraction():
    """With the robot holding the path, the hand force points against the desired
    direction by more than half the episode's 3 N for about 20 % of the time (the
    default fraction); a healthy subject almost never does."""
    against = {}
    for kind in ("healthy", "wrong_way"):
        t, _, force, _, sim = run(kind, 10.0, hold_path=True, seed=3)
        direction = sim.trajectory.sample(t).direction
        along = np.einsum("ij,ij->i", force, direction)
        against[kind] = along < -1.5
        if kind == "wrong_way":
            episode = np.array([sim.patient.pushing_wrong_way(ti) for ti in t])
    assert against["healthy"].mean() < 0.05
    assert against["wrong_way"].mean() == pytest.approx(0.2, abs=0.05)
    # within each episode, once the push has accelerated the arm and the robot's
    # controller has taken it up (tens of ms)
    assert against["wrong_way"][episode].mean() > 0.75


def test_spastic_resistance_grows_with_the_speed_of_the_movement():
    """The robot drives the D at three speeds; the extra hand force a spastic arm
    puts up over a healthy one more than doubles with each doubling of speed (a
    viscous arm would only double it: the stretch reflex adds above threshold)."""
    extra = []
    for duration in (8.0, 4.0, 2.0):
        trial = THESIS_SUBJECT.replace(duration_s=duration, repetitions=1)
        _, _, healthy, _, _ = run("healthy", duration, trial=trial, hold_path=True)
        _, _, spastic, _, _ = run("spastic", duration, trial=trial, hold_path=True)
        extra.append(math.sqrt(np.mean(np.sum((spastic - healthy) ** 2, axis=1))))
    assert extra[0] > 0.1
    assert extra[1] > 2.2 * extra[0]
    assert extra[2] > 2.2 * extra[1]
