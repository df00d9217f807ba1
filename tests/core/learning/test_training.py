"""Each model learns a tiny known system in seconds: a damped pendulum on one joint,
τ = I q̈ + m g l sin q + b q̇, sampled along smooth swings (whole cycles, as a trial)."""

import numpy as np
import pytest

from core.learning import inference, pendulum as pd
from core.learning.training import TrainingOptions, train

INERTIA, MGL, B = 0.5, 2.0, 0.3  # kg·m², N·m, N·m·s


def swings(count, seed, samples=60):
    """`count` cycles of q(t) = a sin(ω t + φ) + c, each with its own a, ω, φ, c."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 2.0, samples)
    q, qd, qdd, cycle = [], [], [], []
    for c in range(count):
        a, w, p, off = rng.uniform(0.3, 1.2), rng.uniform(1.0, 4.0), rng.uniform(0, 6), \
            rng.uniform(-0.5, 0.5)
        q.append(a * np.sin(w * t + p) + off)
        qd.append(a * w * np.cos(w * t + p))
        qdd.append(-a * w**2 * np.sin(w * t + p))
        cycle.append(np.full(samples, c))
    q, qd, qdd = (np.concatenate(x)[:, None] for x in (q, qd, qdd))
    tau = INERTIA * qdd + MGL * np.sin(q) + B * qd
    return q, qd, qdd, tau, np.concatenate(cycle)


@pytest.fixture(scope="module")
def known():
    return swings(40, 0), swings(6, 1)


def relative_rmse(result, test):
    q, qd, qdd, tau, cycle = test
    pred = inference.predict(result.spec, result.params, q, qd, qdd, cycle)
    return float(np.sqrt(np.mean((pred - tau) ** 2)) / tau.std())


SETTINGS = {"fnn": ((16,), 32, 0.06), "rnn": ((8,), 4, 0.15), "delan": ((8,), 32, 0.08)}


@pytest.fixture(scope="module")
def trained(known):
    data, _ = known
    return {kind: train(*data, TrainingOptions(kind=kind, hidden=hidden, epochs=100,
                                               batch_size=batch, folds=1, window=30, seed=1))
            for kind, (hidden, batch, _) in SETTINGS.items()}


@pytest.mark.parametrize("kind", ["fnn", "rnn", "delan"])
def test_each_model_learns_a_tiny_known_system(known, trained, kind):
    """On swings it never saw, its error is a few per cent of τ's spread (predicting the
    mean would be 100 %)."""
    _, test = known
    result = trained[kind]
    error = relative_rmse(result, test)
    assert error < SETTINGS[kind][2], f"{kind}: RMSE {error:.3f} of τ's spread"
    assert result.metrics["parameters"] == sum(v.size for v in result.params.values())


def test_delan_finds_the_physics_of_the_known_system(known, trained):
    """With accelerations that vary independently of the state, the DeLaN's terms are the
    pendulum's: inertia, gravity m g l sin q and damping b q̇ (gravity and dissipation
    together: a position force may sit in either)."""
    _, test = known
    q, qd, qdd, tau, _ = test
    terms = inference.delan_terms(trained["delan"].spec, trained["delan"].params, q, qd, qdd)
    np.testing.assert_allclose(terms.H[:, 0, 0], INERTIA, rtol=0.15)
    position_and_rate = terms.gravity + terms.dissipative - (MGL * np.sin(q) + B * qd)
    assert np.sqrt(np.mean(position_and_rate**2)) < 0.08 * tau.std()
    # one joint: ½ H'(q) q̇², zero for the constant inertia, small for the learned one
    assert np.sqrt(np.mean(terms.coriolis**2)) < 0.05 * tau.std()


def test_same_seed_same_model(known):
    data, _ = known
    options = TrainingOptions(kind="fnn", hidden=(4,), epochs=2, batch_size=256, folds=2)
    a, b = train(*data, options), train(*data, options)
    for name in a.params:
        np.testing.assert_array_equal(a.params[name], b.params[name])
    assert len(a.metrics["folds"]) == 2  # 2-fold cross-validation: two models, the best kept
    assert a.metrics["chosen_fold"] == min(
        a.metrics["folds"], key=lambda f: f["validation_loss"])["fold"]


def test_early_stopping_stops(known):
    data, _ = known
    result = train(*data, TrainingOptions(kind="fnn", hidden=(4,), epochs=400, patience=3,
                                          batch_size=256, folds=1, learning_rate=0.5))
    assert all(f["epochs_run"] < 400 for f in result.metrics["folds"])
    # it watches from the schedule's middle: 3 epochs without a better error after epoch 200
    assert all(f["epochs_run"] - max(f["best_epoch"], 200) == 3 for f in result.metrics["folds"])


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_averaged_weights_beat_the_last_steps_at_a_high_rate(known, seed):
    """At a high constant rate Adam's steps jitter the weights; the weights averaged over
    about an epoch's steps (the default, from the schedule's middle on) validate lower than
    the steps' own."""
    data, _ = known
    losses = {}
    for average in (True, False):
        result = train(*data, TrainingOptions(
            kind="fnn", hidden=(8,), epochs=40, batch_size=32, folds=1, learning_rate=0.1,
            final_learning_rate=0.1, patience=40, seed=seed, average_weights=average))
        losses[average] = result.metrics["folds"][0]["validation_loss"]
    assert losses[True] < 0.9 * losses[False], losses


def test_delan_default_batch_converges_further_than_512_samples():
    """The DeLaN's default batch (128 samples) takes four times the steps of 512 in the same
    epochs; on a small pendulum data set (30 cycles) its validation error after 30 epochs is
    a small fraction of 512's."""
    data = pd.generate(np.linspace(1.0, 10.0, 30))
    losses = {}
    for batch in (None, 512):
        result = train(data.q, data.qd, data.qdd, data.tau, data.cycle, TrainingOptions(
            kind="delan", epochs=30, folds=1, cyclic=(0,), batch_size=batch))
        losses[batch] = result.metrics["folds"][0]["validation_loss"]
    assert losses[None] < 0.2 * losses[512], losses


@pytest.mark.parametrize(("options", "message"), [
    ({"kind": "svm"}, "unknown model 'svm'"),
    ({"kind": "fnn", "folds": 50}, "50-fold cross-validation needs at least 50 cycles"),
    ({"kind": "fnn", "cyclic": (0,)}, "at least one must remain"),
])
def test_bad_options_refused(known, options, message):
    data, _ = known
    with pytest.raises(ValueError, match=message):
        train(*data, TrainingOptions(**options))

