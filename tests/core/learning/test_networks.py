"""The models' numpy inference (the loop's) against JAX's, and the DeLaN's structure."""

import jax
import numpy as np
import pytest
from hypothesis import given, strategies as st

from core.learning import inference, jaxmodels, networks as nw


def spec_for(kind, dof=2, hidden=(6, 5), activation="tanh", cyclic=(), seed=0):
    rng = np.random.default_rng(seed)
    spec = {"kind": kind, "dof": dof, "hidden": list(hidden),
            "position_inputs": [i for i in range(dof) if i not in cyclic],
            "input_mean": rng.normal(size=3 * dof).tolist(),
            "input_std": rng.uniform(0.5, 2.0, 3 * dof).tolist(),
            "output_mean": rng.normal(size=dof).tolist(),
            "output_std": rng.uniform(0.5, 3.0, dof).tolist()}
    if kind == "delan":
        spec.update(dissipation_hidden=[4], activation=activation, mass_scale=1.5,
                    potential_scale=2.0, coulomb_speed_fraction=0.05)
    return spec


def random_params(spec, seed):
    rng = np.random.default_rng(seed)
    return {k: rng.normal(scale=0.8, size=v) for k, v in nw.param_shapes(spec).items()}


def samples(dof, count, seed):
    rng = np.random.default_rng(seed)
    return (rng.normal(scale=1.5, size=(count, dof)), rng.normal(scale=2.0, size=(count, dof)),
            rng.normal(scale=3.0, size=(count, dof)))


@pytest.mark.parametrize(("dof", "cyclic", "activation"), [
    (1, (), "tanh"), (2, (), "softplus"), (2, (0,), "tanh"), (3, (1,), "softplus")])
def test_delan_numpy_equals_jax_autodiff(dof, cyclic, activation):
    """The loop's forward-mode derivatives give the Euler–Lagrange terms JAX's automatic
    differentiation gives, term by term, to 1e-6."""
    spec = spec_for("delan", dof, activation=activation, cyclic=cyclic)
    params = random_params(spec, 1)
    q, qd, qdd = samples(dof, 40, 2)
    ours = inference.delan_terms(spec, params, q, qd, qdd)
    components = jax.jit(lambda *a: jaxmodels.delan_components(spec, params, *a))
    theirs = {k: np.asarray(v) for k, v in components(q, qd, qdd).items()}
    for name in ("H", "inertial", "coriolis", "gravity", "dissipative"):
        np.testing.assert_allclose(getattr(ours, name), theirs[name], rtol=1e-9, atol=1e-6,
                                   err_msg=name)
    forces = jax.jit(lambda *a: jaxmodels.delan_forces(spec, params, *a))
    np.testing.assert_allclose(inference.predict(spec, params, q, qd, qdd),
                               np.asarray(forces(q, qd, qdd)), rtol=1e-9, atol=1e-6)


def test_fnn_numpy_equals_jax():
    spec = spec_for("fnn", cyclic=(0,))
    params = random_params(spec, 3)
    q, qd, qdd = samples(2, 50, 4)
    np.testing.assert_allclose(inference.predict(spec, params, q, qd, qdd),
                               np.asarray(jaxmodels.fnn_forces(spec, params, q, qd, qdd)),
                               rtol=1e-9, atol=1e-6)


def test_rnn_numpy_equals_jax_through_each_cycle():
    spec = spec_for("rnn", hidden=(7,))
    params = random_params(spec, 5)
    q, qd, qdd = samples(2, 60, 6)
    cycle = np.repeat([3, 8, 9], [25, 20, 15])  # three sequences of different lengths
    ours = inference.predict(spec, params, q, qd, qdd, cycle)
    x = nw.normalised_inputs(np, spec, q, qd, qdd)
    for c in np.unique(cycle):
        rows = cycle == c
        theirs = np.asarray(jaxmodels.rnn_forces(spec, params, x[rows][None]))[0]
        np.testing.assert_allclose(ours[rows], theirs, rtol=1e-9, atol=1e-6)
    # one tick at a time, as the loop runs it
    state = inference.RecurrentState(spec, params)
    ticks = np.array([state.step(q[i], qd[i], qdd[i]) for i in range(25)])
    np.testing.assert_allclose(ticks, ours[:25], rtol=1e-12, atol=1e-12)


@given(seed=st.integers(0, 2**32 - 1), dof=st.integers(1, 4),
       scale=st.floats(0.01, 1.0), position_scale=st.floats(0.0, 1e6))
def test_delan_mass_matrix_is_symmetric_positive_definite(seed, dof, scale, position_scale):
    """For any weights of a trained size (|w| of order 1) and any position, however far
    out, H = L Lᵀ is symmetric positive definite."""
    spec = spec_for("delan", dof, seed=seed)
    rng = np.random.default_rng(seed)
    params = {k: rng.normal(scale=scale, size=v) for k, v in nw.param_shapes(spec).items()}
    q = rng.normal(scale=position_scale, size=(20, dof))
    H = nw.mass_matrix(np, spec, params, q)
    np.testing.assert_array_equal(H, np.swapaxes(H, -1, -2))
    # the Cholesky factor's diagonal is ≥ ε, so det H ≥ ε^(2n) > 0 and every eigenvalue > 0
    L = nw.cholesky_factor(np, spec, nw.mlp(np, params, "L",
                                            nw.normalised_positions(np, spec, q)))
    assert np.all(np.diagonal(L, axis1=-2, axis2=-1) >= nw.DIAGONAL_EPS)
    assert np.all(np.linalg.eigvalsh(H) > 0)
    np.linalg.cholesky(H)  # raises unless positive definite


def test_default_sizes_are_those_of_table_2_1():
    """About 800 parameters, as the thesis's networks (Table 2.1)."""
    from core.learning.training import TrainingOptions, make_spec

    q, qd, qdd = samples(2, 30, 0)
    tau = q + qd
    counts = {kind: nw.count_parameters(make_spec(TrainingOptions(kind=kind, cyclic=(0,)),
                                                  q, qd, qdd, tau))
              for kind in nw.KINDS}
    assert counts["delan"] <= 801
    assert all(700 <= c <= 830 for c in counts.values()), counts


def test_unknown_kind_refused():
    with pytest.raises(ValueError, match="unknown model kind 'svm'"):
        nw.param_shapes({"kind": "svm", "dof": 2, "hidden": [3], "position_inputs": [0, 1]})


@pytest.mark.parametrize(("kind", "activation", "dof"), [
    ("fnn", "tanh", 2), ("rnn", "tanh", 2), ("delan", "tanh", 2), ("delan", "softplus", 2),
    ("delan", "tanh", 3)])  # two coordinates take the DeLaN's fast path, three the general
def test_tick_model_equals_batch_inference(kind, activation, dof):
    """What the loop would call, one sample at a time, gives the batch inference's forces."""
    from core.learning.tick import TickModel

    spec = spec_for(kind, dof, hidden=(7,) if kind == "rnn" else (6, 5),
                    activation=activation, cyclic=(0,))
    params = random_params(spec, 8)
    q, qd, qdd = samples(dof, 30, 9)
    batch = inference.predict(spec, params, q, qd, qdd)
    tick = TickModel(spec, params)
    ticks = np.array([tick.forces(q[i], qd[i], qdd[i]) for i in range(30)])
    np.testing.assert_allclose(ticks, batch, rtol=1e-12, atol=1e-12)
    tick.reset()
    np.testing.assert_allclose(tick.forces(q[0], qd[0], qdd[0]), batch[0], rtol=1e-12)
