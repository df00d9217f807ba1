"""EMG-to-torque models against a known truth: torques made by the synthetic muscle model
from known excitations, so a model that recovers the physiology must score near perfectly;
and the rule that keeps a model that does not generalise away from the assistance."""

import math

import numpy as np
import pytest

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

DT = 0.02  # the models see the envelopes at 50 Hz


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
    return TrialSet(u, tau, subject, f"S{subject}T{k}", DT)


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


def test_usable_needs_the_threshold_at_both_joints_and_to_beat_the_baseline():
    good, bad = Score((0.1, 0.1), (0.9, 0.8)), Score((1.0, 1.0), (0.9, USABLE_R2 - 0.01))
    assert Validation("network", "x", ("t",), good, bad).usable
    refused = Validation("network", "thesis split", ("t",), bad, good)
    assert not refused.usable
    assert "elbow R² 0.59 below 0.60" in refused.why_not
    worse = Validation("network", "x", ("t",), Score((0.2, 0.2), (0.7, 0.7)), good)
    assert "no better than the linear baseline at the shoulder, elbow" in worse.why_not


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
