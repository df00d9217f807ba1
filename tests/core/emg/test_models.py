"""EMG-to-torque models against a known truth: torques made by the synthetic muscle model
from known excitations, so a model that recovers the physiology must score near perfectly;
and the rule that keeps a model that does not generalise away from the assistance."""

import math

import numpy as np
import pytest

from core.emg.force import (
    USABLE_CONE_AGREEMENT,
    ForceContext,
    ForceScore,
    force_score,
    implied_force,
    in_cone,
)
from core.emg.models import (
    USABLE_R2,
    FeedForwardNetwork,
    LinearModel,
    MuscleModel,
    Score,
    TrialSet,
    Validation,
    in_sample,
    leave_one_subject_out,
    score,
    validate,
)
from core.emg.synthetic import (
    MUSCLES,
    MuscleModel as Body,
    activations_from_torques,
    excitation_from_activations,
)
from core.errors import ParameterError
from core.trial import THESIS_SUBJECT

DT = 0.02  # the models see the envelopes at 50 Hz
ARM = THESIS_SUBJECT.arm()


def _trial(subject, k, body=None, duration=40.0):
    """Torques of a reach-like motion; u the excitations behind them (perfect envelopes)."""
    body = body or Body()
    rng = np.random.default_rng(100 * subject + k)
    t = np.arange(0.0, duration, DT)
    f = rng.uniform(0.15, 0.5, 4)
    p = rng.uniform(0, 2 * math.pi, 4)
    tau = np.column_stack((3 * np.sin(2 * math.pi * f[0] * t + p[0])
                           + 1.5 * np.sin(2 * math.pi * f[1] * t + p[1]),
                           2 * np.sin(2 * math.pi * f[2] * t + p[2])
                           + np.sin(2 * math.pi * f[3] * t + p[3])))
    u = excitation_from_activations(activations_from_torques(tau, body), DT, body)
    return TrialSet(u, tau, subject, f"S{subject}T{k}", DT, _context(tau, rng))


def _context(tau, rng):
    """The hand's force those torques make at still arm postures (eq. 5.1), and a desired
    direction within 40° of it either way, so the cone test meets both answers."""
    n = tau.shape[0]
    angles = np.column_stack((rng.uniform(0.4, 1.0, n), rng.uniform(1.6, 2.4, n)))
    still = np.zeros((n, 2))
    probe = ForceContext(ARM, angles, still, still, still, np.ones((n, 2)), math.radians(20))
    force = implied_force(tau, probe)
    heading = np.arctan2(force[:, 1], force[:, 0]) + rng.uniform(-0.7, 0.7, n)
    return ForceContext(ARM, angles, still, still, force,
                        np.column_stack((np.cos(heading), np.sin(heading))), math.radians(20))


def test_the_muscle_model_recovers_a_known_physiology_on_a_new_trial():
    trials = [_trial(1, k) for k in range(3)]
    v = validate(lambda: MuscleModel(MUSCLES, delays_s=(0.0, 0.04)), trials, {"S1T2"},
                 "new trial")
    assert min(v.score.r2) > 0.97
    assert v.usable, v.why_not


def test_the_linear_baseline_and_the_network_fit_what_they_saw():
    trial = _trial(1, 0)
    linear = in_sample(LinearModel, trial)
    network = in_sample(lambda: FeedForwardNetwork(hidden=8), trial)
    assert min(linear.r2) > 0.5
    assert min(network.r2) >= min(linear.r2) - 0.02
    # deterministic for a seed
    a = FeedForwardNetwork(seed=3).fit([trial]).predict(trial)
    b = FeedForwardNetwork(seed=3).fit([trial]).predict(trial)
    np.testing.assert_array_equal(a, b)


def test_leave_one_subject_out_exposes_subjects_whose_bodies_differ():
    """Subjects with other moment arms and strengths: a model fitted on the others
    predicts the left-out subject's torques with the others' gains."""
    strong = Body(max_force_N=(2400.0, 3200.0, 2800.0, 2000.0))
    trials = [_trial(1, 0), _trial(1, 1), _trial(2, 0, strong), _trial(2, 1, strong)]
    results = leave_one_subject_out(lambda: MuscleModel(MUSCLES), trials)
    assert [r.split for r in results] == ["leave subject 1 out", "leave subject 2 out"]
    # the same activation means four times the torque in subject 2: never usable held out
    assert not any(r.usable for r in results)
    assert "does not generalise" in results[0].why_not
    # but each subject alone is described well
    assert min(in_sample(lambda: MuscleModel(MUSCLES), trials[2]).r2) > 0.97


def test_usable_needs_the_threshold_at_both_joints_to_beat_the_baseline_and_the_force():
    good, bad = Score((0.1, 0.1), (0.9, 0.8)), Score((1.0, 1.0), (0.9, USABLE_R2 - 0.01))
    agrees = ForceScore((0.5, 0.7), USABLE_CONE_AGREEMENT, 0.86, 0.8, math.radians(20))
    assert Validation("network", "x", ("t",), good, bad, force=agrees).usable
    refused = Validation("network", "thesis split", ("t",), bad, good, force=agrees)
    assert not refused.usable
    assert "elbow R² 0.59 below 0.60" in refused.why_not
    worse = Validation("network", "x", ("t",), Score((0.2, 0.2), (0.7, 0.7)), good,
                       force=agrees)
    assert "no better than the linear baseline at the shoulder, elbow" in worse.why_not
    # torques that pass, but a force that points elsewhere than the sensor's
    wrong = Validation("network", "x", ("t",), good, bad,
                       force=ForceScore((1.3, 2.2), 0.51, 0.87, 0.44, math.radians(20)))
    assert "agrees with the sensor's on 51% of the samples about the 20° tolerance cone, " \
           "below 80%" in wrong.why_not
    unchecked = Validation("network", "x", ("t",), good, bad)
    assert "no force sensor recording" in unchecked.why_not


def test_the_force_score_judges_the_cone_as_the_assistance_does():
    trial = _trial(1, 0)
    exact = force_score(trial.torques, trial.context)
    assert exact.rmse_N == pytest.approx((0.0, 0.0), abs=1e-9)
    assert exact.cone_agreement == 1.0
    assert 0.2 < exact.sensor_in_cone < 0.8  # both answers met
    # a torque error of 0.3 N·m at the shoulder moves the force by newtons (J_A⁻ᵀ)
    off = force_score(trial.torques + np.array([0.3, 0.0]), trial.context)
    assert min(off.rmse_N) > 0.3
    assert off.cone_agreement < 1.0
    # the cone test is the scheme's own: in the cone at 19°, not at 21°
    d = np.array([[1.0, 0.0]] * 2)
    f = np.array([[math.cos(math.radians(19)), math.sin(math.radians(19))],
                  [math.cos(math.radians(21)), math.sin(math.radians(21))]])
    assert in_cone(f, d, math.radians(20)).tolist() == [True, False]


def test_score_is_rmse_and_r2():
    actual = np.column_stack((np.arange(10.0), np.arange(10.0) * 2))
    s = score(actual + 1.0, actual)
    assert s.rmse_Nm == pytest.approx((1.0, 1.0))
    assert s.r2[0] == pytest.approx(1 - 10 / np.sum((actual[:, 0] - 4.5) ** 2))


def test_bad_inputs_are_refused():
    with pytest.raises(ParameterError, match="muscles"):
        MuscleModel(("biceps", "gluteus"))
    with pytest.raises(ParameterError, match="u, torques"):
        TrialSet(np.zeros((5, 3)), np.zeros((4, 2)), 1, "x", DT)
    trials = [_trial(1, 0)]
    with pytest.raises(ParameterError, match="test_names"):
        validate(LinearModel, trials, {"S1T0"}, "all held out")


def test_only_a_model_that_passed_held_out_may_estimate_the_patients_torque():
    from core.emg.models import ModelRefused, torque_estimator

    trials = [_trial(1, k) for k in range(3)]
    model = MuscleModel(MUSCLES).fit(trials[:2])
    passed = validate(lambda: MuscleModel(MUSCLES), trials, {"S1T2"}, "new trial")
    assert torque_estimator(model, passed) is model
    failed = Validation("muscle model", "leave subject 2 out", ("x",),
                        Score((3.0, 3.0), (0.1, 0.2)), Score((3.0, 3.0), (0.1, 0.2)))
    with pytest.raises(ModelRefused, match="does not generalise"):
        torque_estimator(model, failed)
    with pytest.raises(ParameterError, match="a validation of muscle model"):
        torque_estimator(model, Validation("network", "x", ("x",), failed.score, failed.score))


@pytest.mark.parametrize("make", [LinearModel, lambda: FeedForwardNetwork(hidden=6),
                                  lambda: MuscleModel(MUSCLES, delays_s=(0.0, 0.04))],
                         ids=["linear", "network", "muscle"])
def test_a_fitted_model_and_its_validation_survive_json(make):
    """What an EMG model file holds (app.emg.modelfile): the fitted model and its held-out
    validation as plain JSON, predicting bit for bit the same; bad weights refused."""
    import json

    from core.emg.models import inputs_of, model_from_dict

    trials = [_trial(1, k) for k in range(3)]
    model = make().fit(trials[:2])
    back = model_from_dict(json.loads(json.dumps(model.to_dict())))
    np.testing.assert_array_equal(back.predict(trials[2]), model.predict(trials[2]))
    assert inputs_of(back) == 4
    v = validate(make, trials, {"S1T2"}, "new trial")
    again = Validation.from_dict(json.loads(json.dumps(v.to_dict())))
    assert again == v
    with pytest.raises(ParameterError, match="model"):
        model_from_dict({"model": "svm"})
    broken = model.to_dict()
    if "w" in broken:
        broken["w"] = broken["w"][:-1]
        with pytest.raises(ParameterError, match="w"):
            model_from_dict(broken)
