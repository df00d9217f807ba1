"""What the assistance modes do in closed loop (the assistance issue's outcomes): on the
realistic plant, the as-needed mode gives way as the patient does more, does not brake a
good patient, tracks every patient, keeps a learning patient working; the thesis mode,
on the ideal plant, is what it always was, bit for bit.

Work W over the exercise phase: the robot's Σ τ_applied · Δθ_R, the patient's Σ F · Δp
at the handle, the help's Σ (τ_applied − τ_own) · Δθ_R (τ_own what carried the robot's own
dynamics, core.control.own); the robot's share max(W_help, 0) / (max(W_help, 0) +
max(W_patient, 0)) (core.work.MechanicalWork). bench/assistance.py prints the whole table."""

import itertools
import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from app.trials.adaptation import run_course
from app.trials.analysis import analyse
from app.trials.headless import simulate
from core.control.guidance import GuidanceGains
from core.trial import THESIS_SUBJECT
from device.sim.patient_parameters import PATIENT_KINDS

GOLDEN = Path(__file__).parents[2] / "device" / "data" / "thesis_ideal_records.json"


@cache
def run(patient: str, assist: str, plant: str = "realistic", **options):
    params = THESIS_SUBJECT.replace(assist=assist)
    # the subject's mean (no trial-to-trial variation): the figures are the patient kind's
    trial = simulate(params, patient=patient, seed=0, plant=plant,
                     patient_options={"variability": 0.0, **options})
    channels = {n: trial.records[n] for n in trial.records.dtype.names}
    return trial, analyse(channels, params).metrics


def test_the_robots_share_of_the_work_falls_as_the_patient_does_more():
    share = {p: run(p, "as-needed")[1].robot_work_share for p in ("passive", "weak",
                                                                    "healthy")}
    assert share["passive"] > share["weak"] > share["healthy"]
    assert share["passive"] >= 0.80
    assert share["healthy"] <= 0.25


def test_a_healthy_patient_is_not_braked():
    m = run("healthy", "as-needed")[1]
    assert max(-m.robot_work_J, 0.0) <= 0.10 * m.patient_work_J
    thesis = run("healthy", "thesis")[1]
    assert -thesis.robot_work_J > 0.25 * thesis.patient_work_J  # what it replaces


def test_the_weak_patient_gets_a_fifth_less_work_than_the_thesis_scheme_gives():
    as_needed = run("weak", "as-needed")[1].robot_work_J
    thesis = run("weak", "thesis")[1].robot_work_J
    assert as_needed <= 0.8 * thesis


def test_an_arm_that_lost_selectivity_is_helped_as_needed_and_still_leads():
    """The weak patient's loss of selective joint control (device.sim.patients,
    selectivity; the weak kind's default): its plan is still the path, so the channel holds
    the hand on it and the as-needed help still gives way to it most of the time; the robot
    does more of the work than for the same arm with its selectivity whole, and the push,
    bent toward the synergy, is less often in the cone."""
    trial, m = run("weak", "as-needed")
    without = run("weak", "as-needed", selectivity_loss=0.0)[1]
    assert trial.status == "complete"
    assert m.led_pct >= 80.0
    assert max(m.rmse_x_m, m.rmse_y_m) <= 0.010
    share = {p: run(p, "as-needed")[1].robot_work_share for p in ("passive", "healthy")}
    assert share["passive"] > m.robot_work_share > without.robot_work_share > share["healthy"]
    assert m.directional_performance_pct < 0.5 * without.directional_performance_pct


@pytest.mark.parametrize("patient", PATIENT_KINDS)
def test_every_patient_is_tracked_within_its_bound(patient):
    trial, m = run(patient, "as-needed")
    assert trial.status == "complete"
    bound = 0.015 if patient == "wrong_way" else 0.010
    assert max(m.rmse_x_m, m.rmse_y_m) <= bound


def test_the_help_along_the_path_is_bounded_by_its_limit_times_the_distance():
    """The only source of energy in the guidance is the help along the path, in
    [0, help_limit_N] along the tangent: its work is at most the limit × the distance the
    handle travelled, whatever the patient does."""
    for patient in ("passive", "wrong_way", "spastic"):
        trial, _ = run(patient, "as-needed")
        r = trial.records
        ex = r["phase"] == 2
        helped = (r["torque_commanded"] - r["torque_controller"])[ex][:-1]
        work = float(np.sum(helped * np.diff(r["robot_angle"][ex], axis=0)))
        distance = float(np.sum(np.hypot(*np.diff(r["position"][ex], axis=0).T)))
        assert work <= GuidanceGains().help_limit_N * distance
        assert work > 0.0 or patient != "passive"


def test_without_help_the_channel_gives_the_passive_patient_no_more_than_it_stored():
    """At level 0 the guidance is a spring-damper across the path, and a share of the
    robot's friction compensated (less than the friction): the energy it can give the
    patient is the spring's, ½ K_n e², and the hand is not moved along the path."""
    params = THESIS_SUBJECT.replace(assist="as-needed", assistance_level=0.0,
                                    repetitions=2)
    trial = simulate(params, patient="passive", seed=0, plant="ideal")
    r = trial.records
    ex = r["phase"] == 2
    given = -float(np.sum(0.5 * (r["force"][ex][1:] + r["force"][ex][:-1])
                          * np.diff(r["position"][ex], axis=0)))
    error = np.hypot(*(r["position"] - r["position_desired"])[ex].T).max()
    stored = 0.5 * GuidanceGains().channel_stiffness_N_m * error ** 2
    assert given <= stored + 1e-3
    travelled = float(np.sum(np.hypot(*np.diff(r["position"][ex], axis=0).T)))
    assert travelled < 0.05  # the D is 1 m over two repetitions
    thesis = simulate(params.replace(assist="thesis", assistance_level=1.0),
                      patient="passive", seed=0, plant="ideal").records
    tex = thesis["phase"] == 2
    thesis_given = -float(np.sum(0.5 * (thesis["force"][tex][1:] + thesis["force"][tex][:-1])
                                 * np.diff(thesis["position"][tex], axis=0)))
    assert thesis_given > 100 * max(given, 1e-3)  # the clock tracker drives the arm


def test_a_learning_patient_keeps_working_under_as_needed_and_slacks_under_full_help():
    """The weak learning patient keeps its effort under the as-needed mode and lets it
    fall under the thesis's fixed full help. Under that help the robot does all the work
    from the first trial for the weak arm as it is (its selectivity half lost: its push,
    bent toward the synergy, does no net work against the stiff tracker), so the robot's
    share can only show the slacking on the same arm with its selectivity whole."""
    as_needed = run_course(THESIS_SUBJECT.replace(assist="as-needed"), patient="weak",
                           trials=20)
    full = run_course(THESIS_SUBJECT.replace(assist="thesis"), patient="weak", trials=20)
    assert as_needed[-1].share >= 0.80
    assert full[-1].share <= 0.6
    shares = [t.share for t in full]
    assert all(b <= a + 1e-12 for a, b in itertools.pairwise(shares))
    assert min(t.robot_work_share for t in full) >= 0.95
    whole = run_course(THESIS_SUBJECT.replace(assist="thesis"), patient="weak", trials=20,
                       patient_options={"selectivity_loss": 0.0})
    assert whole[-1].share <= 0.6
    # the robot's share of the work grows as the patient slacks under full help
    assert whole[-1].robot_work_share > whole[0].robot_work_share


def test_a_healthy_learning_patient_keeps_working_when_the_console_s_proposals_are_taken():
    """Held at the same settings the healthy patient settles under the goal (the module
    notes of app.trials.adaptation say why); taking the proposals keeps it working,
    while fixed full assistance lets it slack."""
    params = THESIS_SUBJECT.replace(assist="as-needed")
    taken = run_course(params, patient="healthy", trials=20, follow_proposals=True)
    fixed = run_course(params, patient="healthy", trials=20)
    full = run_course(THESIS_SUBJECT.replace(assist="thesis"), patient="healthy", trials=20)
    assert taken[-1].share >= 0.80
    assert full[-1].share <= 0.5
    assert fixed[-1].share < taken[-1].share
    # it led nearly all of it, so the proposals made it faster first, the help kept;
    # its effort never sagged to where the fixed course leaves it
    assert (taken[1].duration_s, taken[1].assistance_level) == (
        pytest.approx(0.9 * params.duration_s), params.assistance_level)
    assert taken[-1].duration_s < params.duration_s
    assert min(t.share for t in taken) >= 0.85 > fixed[-1].share
    assert {t.duration_s for t in fixed} == {params.duration_s}
    assert all(t.status == "complete" for t in taken)


def test_a_course_is_the_same_for_the_same_seed():
    a = run_course(THESIS_SUBJECT.replace(assist="as-needed", repetitions=1),
                   patient="healthy", trials=3)
    b = run_course(THESIS_SUBJECT.replace(assist="as-needed", repetitions=1),
                   patient="healthy", trials=3)
    assert a == b


def test_the_realistic_plant_is_not_the_model_and_is_drawn_by_its_own_seed():
    """The robot is drawn by `robot_seed`, the same for any trial's seed (one station, one
    robot); the trial's seed draws the rest."""
    a = simulate(THESIS_SUBJECT.replace(repetitions=1), seed=1)
    b = simulate(THESIS_SUBJECT.replace(repetitions=1), seed=1)
    c = simulate(THESIS_SUBJECT.replace(repetitions=1), seed=2)
    d = simulate(THESIS_SUBJECT.replace(repetitions=1), seed=1, robot_seed=2)
    ideal = simulate(THESIS_SUBJECT.replace(repetitions=1), seed=1, plant="ideal")
    assert a.plant == b.plant == c.plant != d.plant
    assert not np.array_equal(a.records["position"], c.records["position"])
    assert a.plant["kind"] == "realistic"
    assert a.plant["actuator_delay_periods"] == 1
    assert ideal.plant["kind"] == "ideal"
    assert ideal.plant["actuator_delay_periods"] == 0
    assert not np.array_equal(a.records["position"], ideal.records["position"])
    assert np.array_equal(a.records["position"], b.records["position"])


def fingerprint(channel: np.ndarray) -> list[float]:
    """A channel's values at FINGERPRINT_SAMPLES ticks spread over the trial, then its sum
    and its sum of magnitudes (all its samples count in those two)."""
    values = np.asarray(channel, dtype=np.float64).reshape(len(channel), -1)
    picks = np.linspace(0, len(values) - 1, FINGERPRINT_SAMPLES).astype(int)
    return [*values[picks].ravel().tolist(), float(values.sum()), float(np.abs(values).sum())]


FINGERPRINT_SAMPLES = 64
FINGERPRINT_RTOL = 1e-9


def thesis_ideal_records(key: str):
    patient, controller = key.split("-")
    params = THESIS_SUBJECT.replace(repetitions=1, controller=controller)
    assert params.assist == "thesis"
    return simulate(params, patient=patient, seed=3, engine="python", plant="ideal",
                    patient_options={"variability": 0.0}).records


def test_the_thesis_mode_on_the_ideal_plant_reproduces_the_earlier_trials():
    """The records of the tree before the assistance modes (interpreted engine: plain
    Python floats, no compiler in between), channel by channel, to FINGERPRINT_RTOL of
    each channel's scale. They were SHA-256 hashes until 2026-12-03: the same code gave
    other last bits of the reference's angles, rates and accelerations (and so of the
    torques) on an AMD EPYC than on the Intel machine the hashes were made on, every other
    channel equal to the bit; a hash cannot tell those last bits from a real change. The
    fingerprints were made then from the tree whose every other channel still hashed
    equal (tests/device/data/thesis_ideal_records.json)."""
    golden = json.loads(GOLDEN.read_text())
    assert set(golden) == {"healthy-smc", "wrong_way-ctpid"}
    for key, channels in golden.items():
        records = thesis_ideal_records(key)
        assert set(channels) == set(records.dtype.names)
        for name, expected in channels.items():
            got = np.array(fingerprint(records[name]))
            expected = np.array(expected)
            # NaN where the channel is undefined (no force angle at rest): equal as NaN
            scale = np.nan_to_num(max(np.nanmax(np.abs(expected[:-2])),
                                      expected[-1] / len(records)), nan=1.0)
            np.testing.assert_allclose(got, expected, rtol=FINGERPRINT_RTOL,
                                       atol=FINGERPRINT_RTOL * scale,
                                       err_msg=f"{key}: channel {name} changed")


@pytest.mark.parametrize("patient", PATIENT_KINDS)
def test_the_as_needed_mode_is_stable_for_every_patient_level_and_speed(patient):
    """The realistic plant, no help or full help, the thesis's pace or twice it: every
    trial completes (no torque, speed or workspace fault) and the hand stays near the
    path: within 5 mm RMS at the thesis's pace with help; within 25 mm RMS otherwise,
    where a heavy arm at twice the pace, or a weak or contrary one left alone, cuts the
    D's corners against the channel's 5 N (measured 2026-12-05, seed 1: up to 24 mm RMS,
    61 mm at worst, the weak arm, its selectivity half lost, at twice the pace with full
    help; 56 mm before that loss was the weak kind's default; docs/validation.md,
    Assistance)."""
    for level in (0.0, 1.0):
        for duration in (4.0, 2.0):
            params = THESIS_SUBJECT.replace(assist="as-needed", assistance_level=level,
                                            duration_s=duration, repetitions=2)
            trial = simulate(params, patient=patient, seed=1)
            assert trial.status == "complete", (level, duration, trial.events[-1])
            r = trial.records
            hand = r["position"][r["phase"] == 2]
            path = params.path().points(0.002)
            off = np.min(np.hypot(hand[:, None, 0] - path[None, :, 0],
                                  hand[:, None, 1] - path[None, :, 1]), axis=1)
            rms = np.sqrt(np.mean(off ** 2))
            assert rms < (0.005 if (level, duration) == (1.0, 4.0) else 0.025)
            assert off.max() < 0.065


def test_the_trial_file_keeps_the_mode_its_gains_the_learned_force_and_the_work(tmp_path):
    import h5py

    from app.trials.headless import save

    params = THESIS_SUBJECT.replace(assist="as-needed", repetitions=2,
                                    gains="guidance.delay_s=0.4")
    trial = simulate(params, patient="passive", seed=0)
    save(trial, tmp_path / "t.h5")
    with h5py.File(tmp_path / "t.h5", "r") as f:
        group = f["assistance"]
        assert group.attrs["mode"] == "as-needed"
        assert group.attrs["delay_s"] == pytest.approx(0.4)
        learned = group["feedforward_N"][()]
        assert learned.shape == (2, GuidanceGains().bins)
        assert np.array_equal(learned, trial.feedforward_N)
        assert learned[1].sum() > learned[0].sum() > 0.0  # it learns the limp arm's need
        assert f["summary"].attrs["plant"] == "realistic"
        for key in ("robot_work_J", "patient_work_J", "robot_work_share", "led_pct"):
            assert np.isfinite(f["metrics"].attrs[key])
