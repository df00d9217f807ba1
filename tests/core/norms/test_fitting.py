"""Fitting on a simulated control population with a known transform and known coefficients
recovers them, within tolerances set by n; the cross-validated calibration of a model fitted
on such controls is what a calibrated model shows."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from core.norms import scores
from core.norms.fitting import calibration_of, cross_validate, fit_figure, fit_model, fit_task
from core.norms.regression import Covariates, spec_of
from core.norms.transforms import Transform, profile_log_likelihood

LAMBDA = 0.5
BETA = {"intercept": -0.5, "age_years": 0.02, "sex=male": 0.2, "handedness=left": -0.05,
        "tested_side=left": -0.1}
SIGMA = 0.4


def population(n: int, seed: int):
    rng = np.random.default_rng(seed)
    people = [Covariates(float(rng.uniform(20, 80)), str(rng.choice(["female", "male"])),
                         "left" if rng.random() < 0.3 else "right",
                         str(rng.choice(["right", "left"])), "simulator-realistic")
              for _ in range(n)]
    spec = spec_of(people)
    X = spec.design(people)
    beta = np.array([BETA[c] for c in spec.columns])
    t = X @ beta + rng.normal(0, SIGMA, n)
    x = (1.0 + LAMBDA * t) ** (1.0 / LAMBDA)  # Box-Cox inverse
    # a second figure, normal as it is, lower is worse, age lowers it
    y = 0.8 - 0.004 * X[:, 1] + rng.normal(0, 0.05, n)
    return people, spec, X, x, y


def test_recovers_lambda_and_coefficients():
    n = 1500
    people, spec, X, x, _ = population(n, 11)
    fit = fit_figure(x, people, spec, "higher", "box-cox")
    # λ's standard error from the profile likelihood's curvature at its maximum
    lam, h = fit.transform.lam, 1e-3
    ll = [profile_log_likelihood(Transform("box-cox", lam + d), x, X) for d in (-h, 0, h)]
    se_lam = 1.0 / math.sqrt(-(ll[0] - 2 * ll[1] + ll[2]) / h**2)
    assert se_lam < 0.1
    assert abs(lam - LAMBDA) < 4 * se_lam
    # the coefficients' standard errors of least squares (σ²(XᵀX)⁻¹), widened for λ's error
    se = SIGMA * np.sqrt(np.diag(np.linalg.inv(X.T @ X)))
    for column, s in zip(spec.columns, se, strict=True):
        slack = 4 * s + 4 * se_lam * abs(BETA[column]) * 3
        assert fit.regression.coefficients[column] == pytest.approx(BETA[column], abs=slack)
    # σ's relative standard error is 1/√(2(n − p))
    assert fit.regression.residual_sd == pytest.approx(SIGMA, rel=4 / math.sqrt(2 * n) + 4 * se_lam)
    assert fit.regression.n == n


def test_cross_validated_calibration_of_a_well_specified_model():
    n = 600
    people, _, _, x, y = population(n, 5)
    table = {"vgr_reaction_time_s": x, "vgr_max_speed_m_s": y}
    worse = {"vgr_reaction_time_s": "higher", "vgr_max_speed_m_s": "lower"}
    tasks = {"reaching": ["vgr_reaction_time_s", "vgr_max_speed_m_s"]}
    result = cross_validate(table, people, worse, tasks, folds=5, seed=1)
    for key in worse:
        c = result[key]
        assert c.n == n
        assert abs(c.mean) < 4 / math.sqrt(n)
        assert c.sd == pytest.approx(1.0, abs=4 / math.sqrt(2 * n) + 0.02)
        # binomial SD of a 5 % share over n: √(0.05·0.95/n) ≈ 0.009
        assert c.beyond_1_96 == pytest.approx(0.05, abs=4 * math.sqrt(0.0475 / n))
        assert c.qq_max_deviation < 0.25
    score = result["task:reaching"]
    assert score.n == n
    assert score.beyond_1_96 == pytest.approx(0.05, abs=4 * math.sqrt(0.0475 / n))


def test_a_misspecified_model_shows_in_calibration():
    """Fitted without a transform, the skewed figure's held-out Z-scores are visibly off the
    normal QQ line: the calibration is what tells a user."""
    people, _, _, x, _ = population(600, 5)
    skewed = np.exp(3 * (x - x.mean()))
    worse = {"vgr_reaction_time_s": "higher"}
    bad = cross_validate({"vgr_reaction_time_s": skewed}, people, worse, {}, kind="none")
    good = cross_validate({"vgr_reaction_time_s": skewed}, people, worse, {}, kind="box-cox")
    assert bad["vgr_reaction_time_s"].qq_max_deviation > 2 * good[
        "vgr_reaction_time_s"].qq_max_deviation


def test_task_fit_gives_half_normal_controls():
    people, _, _, x, y = population(800, 2)
    model = fit_model({"a": x, "b": y}, people, {"a": "higher", "b": "lower"},
                      {"reaching": ["a", "b"]})
    s = model.task_scores("reaching", {"a": x, "b": y}, model.spec.design(people))
    c = calibration_of(s, one_sided_scores=True)
    assert np.all(s >= 0)
    assert c.beyond_1_96 == pytest.approx(0.05, abs=0.03)
    assert c.qq_max_deviation < 0.2


def test_a_level_one_fold_lacks_is_not_scored_by_guess():
    """One left-hander among 60: the fold holding them out has no left-hander to fit, so it
    cannot score them (the norms would refuse such a patient); the calibration counts them
    as not scored instead of failing (it raised 'not independent' before)."""
    people, _, _, x, _ = population(60, 3)
    people = [Covariates(p.age_years, p.sex, "right", p.tested_side, p.robot) for p in people]
    people[7] = Covariates(people[7].age_years, people[7].sex, "left", people[7].tested_side,
                           people[7].robot)
    result = cross_validate({"vgr_reaction_time_s": x}, people,
                            {"vgr_reaction_time_s": "higher"}, {}, folds=5)
    c = result["vgr_reaction_time_s"]
    assert (c.n, c.not_scored) == (59, 1)


def test_a_rare_figure_one_fold_cannot_fit_leaves_the_others_scored():
    """The shipped simulated norms' calibration: a reach with no reaction is rare (a few
    controls of 482 have one), and the fold whose training controls all have 0 cannot fit
    that count. Before, that fold scored nobody on any figure (97 of 482 held-out controls
    'not scorable by their fold' on every line); now only that count and its task lose it."""
    n, folds, seed = 100, 5, 0
    people, _, _, x, y = population(n, 5)
    order = np.random.default_rng(seed).permutation(n)
    rare = np.zeros(n)
    rare[order[0::folds][:3]] = 1.0  # all in fold 0's held-out part: its training has 0s
    table = {"vgr_reaction_time_s": x, "vgr_max_speed_m_s": y, "vgr_no_reaction_count": rare}
    worse = {"vgr_reaction_time_s": "higher", "vgr_max_speed_m_s": "lower",
             "vgr_no_reaction_count": "higher"}
    tasks = {"reaching": ("vgr_reaction_time_s", "vgr_max_speed_m_s"),
             "with_rare": ("vgr_reaction_time_s", "vgr_no_reaction_count")}
    result = cross_validate(table, people, worse, tasks, folds=folds, seed=seed)
    assert result["vgr_reaction_time_s"].not_scored == 0
    assert result["vgr_reaction_time_s"].n == n
    assert result["task:reaching"].not_scored == 0
    fold_size = len(order[0::folds])
    assert result["vgr_no_reaction_count"].not_scored == fold_size
    assert result["task:with_rare"].not_scored == fold_size
    with pytest.raises(Exception, match="all equal"):  # the whole fit still refuses it
        fit_model({"c": np.zeros(n)}, people, {"c": "higher"}, {})


def test_a_task_score_has_no_ceiling():
    """A task's distance D is Box-Cox transformed, and a greater D is worse: with λ < 0 the
    transformed D tends to −1/λ, and the Z-Task Score could never exceed (−1/λ − mean)/SD
    (the shipped circle's, λ −0.64: 5.4, a task score of 5.5, whatever the patient did).
    Controls whose D the likelihood bends with λ = −0.5 (one figure's Z built so that its
    one-sided deviation is that D): λ is kept at 0 or above, and a patient ever further
    from them scores ever worse."""
    t = np.random.default_rng(6).normal(0.0, 0.15, 800)
    distance = (1.0 - 0.5 * t) ** -2.0  # Box-Cox λ = −0.5 inverse, around D = 1
    z = stats.norm.isf(2.0 * stats.norm.sf(distance))  # one_sided(z) = distance
    assert scores.task_distances({"a": z}, {"a": "higher"}, ("a",)) == pytest.approx(distance)
    task = fit_task(("a",), {"a": z}, {"a": "higher"})
    assert task.transform.lam >= 0.0
    far = [float(scores.one_sided((task.transform.apply(d) - task.mean) / task.sd))
           for d in (10.0, 100.0)]
    assert far[1] > far[0] > 10.0
