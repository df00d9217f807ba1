"""Virtual patients (device.sim.patients): each model's torques against its definition and
the arm's equations, evaluated directly (no simulation)."""

import math
from pathlib import Path

import numpy as np
import pytest

from core.errors import ParameterError, UnreachableError
from core.trial import THESIS_SUBJECT
from device.sim.desired_motion import passive_torque_terms
from device.sim.patient_parameters import (
    DEFAULT_EFFORT,
    DEFAULT_SELECTIVITY_LOSS,
    HEALTHY_IMPEDANCE,
    PASSIVE_TISSUE,
    PATIENT_KINDS,
    SYNERGY_DIRECTION_RAD,
    TREMOR_BAND_HZ,
    Spasticity,
    spastic_resistance_Nm,
)
from device.sim.patients import Patient, make_patient

ARM = THESIS_SUBJECT.arm()
TRAJECTORY = THESIS_SUBJECT.trajectory()


def random_states(seed, n=25):
    """Times inside the trial and arm states near the path (θ_s, θ_e, θ̇_s, θ̇_e)."""
    rng = np.random.default_rng(seed)
    t = rng.uniform(0.0, TRAJECTORY.total_duration_s, n)
    theta = ARM.ik(TRAJECTORY.sample(t).position_m) + rng.normal(0.0, 0.05, (n, 2))
    rates = rng.normal(0.0, 0.8, (n, 2))
    return [(float(t[i]), *theta[i].tolist(), *rates[i].tolist()) for i in range(n)]


def joint_to_generalised(sh, el):
    """Anatomical joint torques (shoulder, elbow) to τ_A by virtual work."""
    return np.array([sh - el, el])


# ------------------------------------------------------------------ factory
def test_every_kind_builds_and_speaks_the_patient_protocol():
    for kind in PATIENT_KINDS:
        patient = make_patient(kind, ARM, TRAJECTORY, seed=1)
        assert isinstance(patient, Patient)
        assert patient.kind == kind
        tau = patient.torque(0.5, *patient.start_posture_rad, 0.1, -0.1)
        assert all(math.isfinite(v) for v in tau)


def test_unknown_kind_is_refused_with_the_list_of_kinds():
    with pytest.raises(ParameterError, match="zombie") as info:
        make_patient("zombie", ARM, TRAJECTORY)
    for kind in PATIENT_KINDS:
        assert kind in str(info.value)


@pytest.mark.parametrize(
    ("kind", "options", "name"),
    [
        ("healthy", {"stifness_Nm_rad": (1, 0, 1)}, "stifness_Nm_rad"),
        ("passive", {"effort": 0.5}, "effort"),
        ("weak", {"tremor_hz": 5.0}, "tremor_hz"),
        ("weak", {"effort": 1.5}, "effort"),
        ("weak", {"synergy": 0.9}, "synergy"),
        ("passive", {"synergy": 0.3}, "synergy"),
        ("weak", {"selectivity_loss": 0.95}, "selectivity_loss"),
        ("weak", {"selectivity_loss": -0.1}, "selectivity_loss"),
        ("passive", {"selectivity_loss": 0.3}, "selectivity_loss"),
        ("weak", {"synergy_direction_rad": 2.0}, "synergy_direction_rad"),
        ("healthy", {"stiffness_Nm_rad": (1.0, 5.0, 1.0)}, r"stiffness_Nm_rad\[cross\]"),
        ("healthy", {"damping_Nms_rad": (1.0, 0.0)}, "damping_Nms_rad"),
        ("healthy", {"passive_stiffness_Nm_rad": (-1.0, 0.0, 1.0)}, "passive_stiffness"),
        ("spastic", {"reflex_gain_Nms_rad": (1.0, -2.0)}, r"reflex_gain_Nms_rad\[1\]"),
        ("spastic", {"spastic_threshold_rad_s": 0.3}, "spastic_threshold_rad_s"),
        ("tremor", {"tremor_hz": 30.0}, "tremor_hz"),
        ("tremor", {"tremor_amplitude_Nm": (math.nan, 1.0)}, "tremor_amplitude_Nm"),
        ("wrong_way", {"wrong_way_fraction": 0.0}, "wrong_way_fraction"),
        ("wrong_way", {"wrong_way_episode_s": -1.0}, "wrong_way_episode_s"),
        ("wrong_way", {"wrong_way_force_N": 500.0}, "wrong_way_force_N"),
    ],
)
def test_bad_options_are_refused_by_name(kind, options, name):
    with pytest.raises(ParameterError, match=name):
        make_patient(kind, ARM, TRAJECTORY, **options)


def test_a_path_out_of_the_arms_reach_is_refused():
    far = THESIS_SUBJECT.replace(shoulder_m=(0.5, 0.9))
    with pytest.raises(UnreachableError, match="shoulder"):
        make_patient("healthy", far.arm(), TRAJECTORY)


# ------------------------------------------------------------------ passive
def test_passive_arm_rests_in_its_starting_posture():
    patient = make_patient("passive", ARM, TRAJECTORY)
    ts, te = patient.start_posture_rad
    np.testing.assert_allclose(ARM.position(ts, te), TRAJECTORY.at(0.0)[:2], atol=1e-12)
    assert patient.torque(1.0, ts, te, 0.0, 0.0) == pytest.approx((0.0, 0.0), abs=1e-12)


def test_passive_tissue_is_a_stiffness_and_a_damper_in_joint_coordinates():
    """Power balance: τ_Aᵀ θ̇_A equals the joint torques times the joint rates, and
    the torque is −∂V/∂θ of ½ eᵀ K e plus a damper that only dissipates."""
    patient = make_patient("passive", ARM, TRAJECTORY)
    ks, kc, ke = PASSIVE_TISSUE.stiffness_Nm_rad
    bs, bc, be = PASSIVE_TISSUE.damping_Nms_rad
    ts0, te0 = patient.start_posture_rad
    for t, ts, te, tsd, ted in random_states(0):
        e = np.array([ts - ts0, (te - ts) - (te0 - ts0)])
        w = np.array([tsd, ted - tsd])
        joint = -np.array([[ks, kc], [kc, ke]]) @ e - np.array([[bs, bc], [bc, be]]) @ w
        np.testing.assert_allclose(
            patient.torque(t, ts, te, tsd, ted), joint_to_generalised(*joint), atol=1e-12
        )
        tau = np.array(patient.torque(t, ts, te, tsd, ted))
        # the vectorised form the healthy feed-forward uses agrees with the per-step one
        np.testing.assert_allclose(
            passive_torque_terms(PASSIVE_TISSUE, (ts0, te0 - ts0), ts, te - ts, tsd, ted - tsd),
            tau, atol=1e-12,
        )
        assert tau @ [tsd, ted] == pytest.approx(joint @ w, abs=1e-12)
        # at rest in a displaced posture the damper is silent: pure spring
        spring = np.array(patient.torque(t, ts, te, 0.0, 0.0))
        damper = tau - spring
        assert damper @ [tsd, ted] <= 1e-12


# ------------------------------------------------------------------ healthy
def desired_by_finite_differences(t, h=1e-4):
    """The desired arm motion straight from the path, with derivatives by central
    differences of the inverse kinematics (independent of the patient's J_A algebra)."""
    theta = ARM.ik(TRAJECTORY.sample(np.array([t - h, t, t + h])).position_m)
    rate = (theta[2] - theta[0]) / (2 * h)
    acc = (theta[2] - 2 * theta[1] + theta[0]) / (h * h)
    return theta[1], rate, acc


def test_healthy_effort_on_the_desired_motion_is_the_arms_inverse_dynamics_eq_3_20():
    """With the push along the path off (drive_N=0), on the desired motion the impedance
    is silent and the feed-forward, which also overcomes the passive tissue, makes the
    net torque M_A θ̈_d + C_A θ̇_d."""
    patient = make_patient("healthy", ARM, TRAJECTORY, drive_N=0.0, variability=0.0)
    # inside the line and the arc of the D, away from the corners where the speed jumps
    for t in (0.3, 0.9, 1.2, 2.0, 2.6, 3.3, 3.7, 4.9, 7.1):
        theta, rate, acc = desired_by_finite_differences(t)
        expected = ARM.inverse_dynamics(theta, rate, acc)
        got = patient.torque(t, *theta, *rate)
        np.testing.assert_allclose(got, expected, atol=2e-3)
        # and it is not trivially zero: the arc needs centripetal torques
        if 1.6 < t % 4.0 < 3.9:
            assert np.abs(expected).max() > 0.02


def test_healthy_impedance_restores_the_desired_posture_with_a_symmetric_stiffness():
    """∂τ_A/∂θ_A about the desired posture is −Tᵀ (K_active + K_passive) T: symmetric
    and negative definite (the arm is pulled back, and conservatively so)."""
    patient = make_patient("healthy", ARM, TRAJECTORY, drive_N=0.0, variability=0.0)
    t = 1.0
    theta, rate, _ = desired_by_finite_differences(t)
    h = 1e-6
    columns = []
    for j in range(2):
        d = np.zeros(2)
        d[j] = h
        plus = np.array(patient.torque(t, *(theta + d), *rate))
        minus = np.array(patient.torque(t, *(theta - d), *rate))
        columns.append((plus - minus) / (2 * h))
    stiffness = -np.column_stack(columns)
    to_joint = np.array([[1.0, 0.0], [-1.0, 1.0]])  # (θ_s, θ_e) → (θ_s, φ)

    def matrix(k):
        return np.array([[k[0], k[1]], [k[1], k[2]]])

    joint_k = matrix(HEALTHY_IMPEDANCE.stiffness_Nm_rad) + matrix(PASSIVE_TISSUE.stiffness_Nm_rad)
    np.testing.assert_allclose(stiffness, to_joint.T @ joint_k @ to_joint, rtol=1e-6)
    np.testing.assert_allclose(stiffness, stiffness.T, atol=1e-6)
    assert np.all(np.linalg.eigvalsh(stiffness) > 0)


def test_weak_effort_is_the_stated_fraction_of_healthy_effort():
    """The weak arm's effort is 0.4 of the healthy one's (its selectivity kept whole here:
    the loss is the test below's)."""
    assert DEFAULT_EFFORT["weak"] == 0.4
    passive = make_patient("passive", ARM, TRAJECTORY)
    healthy = make_patient("healthy", ARM, TRAJECTORY)
    weak = make_patient("weak", ARM, TRAJECTORY, selectivity_loss=0.0)
    half = make_patient("weak", ARM, TRAJECTORY, effort=0.5, selectivity_loss=0.0)
    for state in random_states(1):
        tissue = np.array(passive.torque(*state))
        effort = np.array(healthy.torque(*state)) - tissue
        assert np.abs(effort).max() > 1e-3
        np.testing.assert_allclose(np.array(weak.torque(*state)) - tissue, 0.4 * effort,
                                   atol=1e-12)
        np.testing.assert_allclose(np.array(half.torque(*state)) - tissue, 0.5 * effort,
                                   atol=1e-12)


def test_an_arm_in_synergy_plans_the_elbow_to_move_with_the_shoulder():
    """The flexion synergy: the arm's planned elbow angle (φ, relative) moves by
    `synergy` times the shoulder's change from the start, its rate likewise; the
    shoulder's plan is the path's."""
    path = make_patient("weak", ARM, TRAJECTORY, variability=0.0).table
    coupled = make_patient("weak", ARM, TRAJECTORY, variability=0.0, synergy=0.3).table
    shoulder, phi, shoulder_rate, phi_rate = path[:, 0], path[:, 1], path[:, 2], path[:, 3]
    np.testing.assert_array_equal(coupled[:, 0], shoulder)
    np.testing.assert_allclose(coupled[:, 1], phi + 0.3 * (shoulder - shoulder[0]), atol=1e-12)
    np.testing.assert_allclose(coupled[:, 3], phi_rate + 0.3 * shoulder_rate, atol=1e-12)
    assert np.ptp(coupled[:, 1] - phi) > 0.05  # it moves the plan, by some degrees


def to_joint_torques(tau_a):
    """τ_A (absolute-angle convention) to anatomical joint torques (shoulder, elbow)."""
    return np.array([tau_a[0] + tau_a[1], tau_a[1]])


def test_a_weak_arm_keeps_its_command_along_the_synergy_and_loses_a_share_across_it():
    """Loss of selective joint control (device.sim.patients, selectivity): on its plan
    (impedance silent) the weak arm's voluntary joint torques are the same arm's without
    the loss, with their part along the synergy's direction s kept and their part across it
    scaled by 1 − the loss; off its plan its stiffness across the synergy loses the same
    share (Q K Q), still symmetric."""
    loss = 0.5
    passive = make_patient("passive", ARM, TRAJECTORY)
    weak = make_patient("weak", ARM, TRAJECTORY, variability=0.0, selectivity_loss=loss)
    selective = make_patient("weak", ARM, TRAJECTORY, variability=0.0, selectivity_loss=0.0)
    s = np.array([math.cos(SYNERGY_DIRECTION_RAD), math.sin(SYNERGY_DIRECTION_RAD)])
    n = np.array([-s[1], s[0]])
    assert s[0] > 0.0 > s[1]  # shoulder one way, elbow the other: abduction with flexion
    assert abs(s[1]) > 2 * s[0]  # the elbow first (elbow flexion leads the flexor synergy)
    across = []
    for t in (0.3, 1.2, 2.0, 2.6, 3.3, 5.1):
        ts, phi, tsd, phid = weak.desired(t)[:4]
        state = (t, ts, ts + phi, tsd, tsd + phid)
        tissue = np.array(passive.torque(*state))
        lost = to_joint_torques(np.array(weak.torque(*state)) - tissue)
        whole = to_joint_torques(np.array(selective.torque(*state)) - tissue)
        assert lost @ s == pytest.approx(whole @ s, abs=1e-12)
        assert lost @ n == pytest.approx((1.0 - loss) * (whole @ n), abs=1e-12)
        across.append(abs(whole @ n))
    assert max(across) > 1e-2  # the D asks for torques out of the synergy
    # the stiffness about the plan: −Tᵀ (w P K P + K_passive) T, symmetric (the push along
    # the path off: its torque J_Aᵀ F turns with the arm)
    weak = make_patient("weak", ARM, TRAJECTORY, variability=0.0, drive_N=0.0,
                        selectivity_loss=loss)
    t = 1.0
    ts, phi, tsd, phid = weak.desired(t)[:4]
    theta = np.array([ts, ts + phi])
    h = 1e-6
    columns = []
    for j in range(2):
        d = np.zeros(2)
        d[j] = h
        plus = np.array(weak.torque(t, *(theta + d), tsd, tsd + phid))
        minus = np.array(weak.torque(t, *(theta - d), tsd, tsd + phid))
        columns.append((plus - minus) / (2 * h))
    stiffness = -np.column_stack(columns)
    to_joint = np.array([[1.0, 0.0], [-1.0, 1.0]])
    q = np.eye(2) - (1.0 - math.sqrt(1.0 - loss)) * np.outer(n, n)
    k = HEALTHY_IMPEDANCE.stiffness_Nm_rad
    kp = PASSIVE_TISSUE.stiffness_Nm_rad
    active = q @ np.array([[k[0], k[1]], [k[1], k[2]]]) @ q
    joint_k = weak.parameters.effort * active + np.array([[kp[0], kp[1]], [kp[1], kp[2]]])
    np.testing.assert_allclose(stiffness, to_joint.T @ joint_k @ to_joint, rtol=1e-5)
    np.testing.assert_allclose(stiffness, stiffness.T, atol=1e-6)
    whole = np.array([[k[0], k[1]], [k[1], k[2]]])
    assert n @ active @ n == pytest.approx((1.0 - loss) * (n @ whole @ n))
    assert np.all(np.linalg.eigvalsh(stiffness) > 0)


def test_only_the_weak_kind_loses_selectivity_unless_asked():
    """The weak patient is a stroke survivor's arm: weak and with half its selective joint
    control lost (DEFAULT_SELECTIVITY_LOSS); every other kind keeps it whole by default."""
    assert DEFAULT_SELECTIVITY_LOSS == {"weak": 0.5}
    for kind in PATIENT_KINDS:
        default = DEFAULT_SELECTIVITY_LOSS.get(kind, 0.0)
        assert make_patient(kind, ARM, TRAJECTORY).constants == make_patient(
            kind, ARM, TRAJECTORY, **({} if kind == "passive" else {"selectivity_loss": default})
        ).constants
        assert make_patient(kind, ARM, TRAJECTORY).parameters.selectivity_loss == default
    assert make_patient("weak", ARM, TRAJECTORY).constants != make_patient(
        "weak", ARM, TRAJECTORY, selectivity_loss=0.0).constants


# ------------------------------------------------------------------- tremor
def test_tremor_frequency_is_drawn_from_the_seed_in_4_to_6_hz():
    freqs = [make_patient("tremor", ARM, TRAJECTORY, seed=s).tremor_frequency_hz
             for s in range(40)]
    low, high = TREMOR_BAND_HZ
    assert all(low <= f <= high for f in freqs)
    assert len(set(freqs)) == 40
    assert max(freqs) - min(freqs) > 1.0  # spread over the band, not clustered
    again = make_patient("tremor", ARM, TRAJECTORY, seed=7).tremor_frequency_hz
    assert again == freqs[7]
    assert make_patient("tremor", ARM, TRAJECTORY, tremor_hz=8.0).tremor_frequency_hz == 8.0


def test_tremor_adds_an_oscillation_whose_spectrum_peaks_at_its_frequency():
    tremor = make_patient("tremor", ARM, TRAJECTORY, seed=3)
    healthy = make_patient("healthy", ARM, TRAJECTORY, seed=3)
    ts, te = tremor.start_posture_rad
    dt = 0.002
    t = np.arange(2000) * dt  # 4 s, 0.25 Hz bins
    added = np.array([np.subtract(tremor.torque(ti, ts, te, 0.0, 0.0),
                                  healthy.torque(ti, ts, te, 0.0, 0.0)) for ti in t])
    freqs = np.fft.rfftfreq(t.size, dt)
    for column in added.T:
        spectrum = np.abs(np.fft.rfft(column * np.hanning(t.size)))
        assert abs(freqs[np.argmax(spectrum)] - tremor.tremor_frequency_hz) <= 0.25
    # the elbow carries the larger amplitude (0.8 N·m against the shoulder's 0.5)
    assert np.abs(added[:, 1]).max() == pytest.approx(0.8, abs=0.01)


# ------------------------------------------------------------------ spastic
def test_spastic_resistance_grows_with_speed_and_only_dissipates():
    spastic = make_patient("spastic", ARM, TRAJECTORY)
    healthy = make_patient("healthy", ARM, TRAJECTORY)
    defaults = Spasticity()
    t = 1.0
    ts, te = ARM.ik(np.array(TRAJECTORY.at(t)[:2]))
    for direction in ((1.0, 0.0), (0.0, 1.0), (0.7, -0.7), (-0.6, -0.8)):
        magnitudes = []
        for speed in np.linspace(0.05, 3.0, 30):
            w = speed * np.array(direction)  # joint rates (shoulder, elbow)
            tsd, ted = w[0], w[0] + w[1]
            extra = np.subtract(spastic.torque(t, ts, te, tsd, ted),
                                healthy.torque(t, ts, te, tsd, ted))
            assert extra @ [tsd, ted] < 0.0  # power into the arm is negative
            magnitudes.append(np.linalg.norm(extra))
            resistance = spastic_resistance_Nm(defaults, *w)
            np.testing.assert_allclose(extra, joint_to_generalised(*(-np.array(resistance))),
                                       atol=1e-12)
        assert np.all(np.diff(magnitudes) > 0)


def test_spastic_reflex_engages_above_its_velocity_threshold():
    p = Spasticity(threshold_rad_s=(0.5, 0.5), reflex_gain_Nms_rad=(1.5, 2.0),
                   viscous_Nms_rad=(0.3, 0.5))
    below = [spastic_resistance_Nm(p, 0.0, w)[1] for w in (0.1, 0.2, 0.4)]
    np.testing.assert_allclose(np.diff(below) / [0.1, 0.2], 0.5)  # viscous slope only
    above = [spastic_resistance_Nm(p, 0.0, w)[1] for w in (1.0, 1.5)]
    assert (above[1] - above[0]) / 0.5 == pytest.approx(0.5 + 2.0)  # viscous + reflex
    assert spastic_resistance_Nm(p, -1.0, 0.0)[0] == pytest.approx(-(0.3 + 1.5 * 0.5))


# ---------------------------------------------------------------- wrong way
def test_wrong_way_episodes_cover_the_stated_fraction_of_the_trial():
    patient = make_patient("wrong_way", ARM, TRAJECTORY, seed=2)
    episodes = patient.episodes_s
    total = TRAJECTORY.total_duration_s
    covered = sum(end - start for start, end in episodes)
    # one episode per 2.5 s window: 8 whole windows in 20 s, exactly 20 %
    assert covered / total == pytest.approx(0.2, abs=1e-9)
    assert all(end - start == pytest.approx(0.5) for start, end in episodes)
    t = np.arange(0.0, total, 0.001)
    flags = np.array([patient.pushing_wrong_way(ti) for ti in t])
    assert flags.mean() == pytest.approx(0.2, abs=0.002)
    other = make_patient("wrong_way", ARM, TRAJECTORY, seed=3).episodes_s
    assert other != episodes
    assert make_patient("wrong_way", ARM, TRAJECTORY, seed=2).episodes_s == episodes
    assert not patient.pushing_wrong_way(total + 1.0)


def test_wrong_way_pushes_the_hand_against_the_desired_direction():
    """During an episode the push turns round: compared with a healthy subject the
    torque differs by J_Aᵀ F with F = −3 N along the path minus the healthy push
    (eq. 3.27 at rest); outside it the patient is healthy."""
    wrong = make_patient("wrong_way", ARM, TRAJECTORY, seed=4)
    healthy = make_patient("healthy", ARM, TRAJECTORY, seed=4)
    checked = 0
    for t, ts, te, tsd, ted in random_states(2, n=200):
        extra = np.subtract(wrong.torque(t, ts, te, tsd, ted), healthy.torque(t, ts, te, tsd, ted))
        if not wrong.pushing_wrong_way(t):
            np.testing.assert_allclose(extra, 0.0, atol=1e-12)
            continue
        checked += 1
        force = np.linalg.solve(ARM.jacobian([ts, te]).T, extra)
        desired = wrong.desired(t)
        direction, push = np.array(desired[6:8]), np.array(desired[8:10])
        np.testing.assert_allclose(force, -3.0 * direction - push, atol=1e-9)
    assert checked > 10


def test_each_trial_draws_its_own_effort_and_drive_around_the_subjects_mean():
    """Issue 27 #16: a new seed per trial drew only the noise, so a course of simulated
    trials at one setting gave the same figures (a healthy patient's led % 97.3976 in every
    trial). Each trial's effort and drive are now drawn by its seed: log-normal factors of
    mean 1 and coefficient of variation VARIABILITY, repeatable for a seed."""
    from device.sim.patients import VARIABILITY, trial_factors

    drawn = np.array([trial_factors(seed, VARIABILITY) for seed in range(4000)])
    np.testing.assert_allclose(drawn.mean(axis=0), 1.0, atol=0.01)
    np.testing.assert_allclose(drawn.std(axis=0), VARIABILITY, rtol=0.1)
    assert abs(np.corrcoef(drawn.T)[0, 1]) < 0.05  # effort and drive drawn apart
    assert trial_factors(7, VARIABILITY) == trial_factors(7, VARIABILITY)
    assert trial_factors(7, 0.0) == (1.0, 1.0)
    efforts = {make_patient("weak", ARM, TRAJECTORY, seed=s).parameters.effort
               for s in range(5)}
    assert len(efforts) == 5
    assert all(e <= 1.0 for s in range(20)
               for e in [make_patient("healthy", ARM, TRAJECTORY, seed=s).parameters.effort])
    # the tremor's draws of a seed are what they were
    assert make_patient("tremor", ARM, TRAJECTORY, seed=3).tremor_frequency_hz == \
        make_patient("tremor", ARM, TRAJECTORY, seed=3, variability=0.0).tremor_frequency_hz


def test_a_course_of_simulated_trials_at_one_setting_varies():
    from app.trials.analysis import analyse
    from app.trials.headless import simulate
    from core.trial import THESIS_SUBJECT

    params = THESIS_SUBJECT.replace(repetitions=1, assist="as-needed")
    figures = []
    for seed in range(1, 5):
        records = simulate(params, patient="weak", seed=seed).records
        metrics = analyse({n: records[n] for n in records.dtype.names}, params).metrics
        figures.append((metrics.led_pct, metrics.directional_performance_pct))
    led, directional = np.array(figures).T
    assert np.ptp(led) > 0.5  # percentage points; 0.07 before
    assert np.ptp(directional) > 1.0


def test_the_lagged_push_is_lfilter_s_bit_for_bit_without_importing_scipy_signal():
    """The push's lag (device.sim.desired_motion._first_order_filter) does lfilter's products and
    sums in its order, so the tables are what they were with lfilter, signed zeros
    included; it runs without scipy.signal, whose import the loop process no longer pays."""
    import subprocess
    import sys

    from scipy.signal import lfilter

    from device.sim.desired_motion import DRIVE_LAG_S, _first_order_filter
    from device.sim.patient_torque import TABLE_STEP_S

    a = math.exp(-TABLE_STEP_S / DRIVE_LAG_S)
    direction = TRAJECTORY.sample(np.arange(0.0, TRAJECTORY.duration_s, TABLE_STEP_S)).direction
    rng = np.random.default_rng(5)
    edges = rng.normal(size=(400, 3))
    edges[:50, 0] = -0.0  # a column that starts at a signed zero
    edges[:120, 1] = 0.0
    edges[200:230, 2] = -0.0
    for x in (np.vstack((direction, direction)), edges, np.array([[1.0], [0.0], [-0.0]])):
        expected, _ = lfilter([1.0 - a], [1.0, -a], x, axis=0, zi=a * x[:1])
        got = _first_order_filter(x, a)
        assert got.tobytes() == expected.tobytes()
    assert np.signbit(edges).any()
    code = ("import sys, device.loop.process, device.recording.recorder; "
            "print('scipy.signal' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=Path(__file__).resolve().parents[2]).stdout
    assert out.strip() == "False"
